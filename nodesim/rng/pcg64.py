"""numpy's PCG64 generator and its ``random()`` / ``standard_normal()`` as compiled loops over many streams.

Building one :class:`numpy.random.Generator` per stream and calling it costs a few microseconds per object
and per call; a batched run with R realizations has R streams per node and link, so that overhead dominated
it.  Here the streams are rows of a (M, 4) uint64 state array ``[state_hi, state_lo, inc_hi, inc_lo]`` and
one compiled call draws from all of them.  The numbers are numpy's, bit for bit (tests/nodesim/rng/test_pcg64.py):

* seeding (``PCG64(seed_sequence)``, numpy ``pcg64_set_seed``): words w = seed_sequence.generate_state(4,
  uint64), initstate = w0:w1, initseq = w2:w3; inc = (initseq << 1) | 1, state = 0, step, state += initstate,
  step;
* step: state = state x 2549297995355413924:4865540595714422341 + inc (mod 2^128); output XSL-RR of the new
  state: rotr64(hi ^ lo, hi >> 58);
* ``random()``: (next64 >> 11) x 2^-53;
* ``standard_normal()``: the 256-strip ziggurat of numpy's ``random_standard_normal``
  (numpy/random/src/distributions/distributions.c), with numpy's tables (ziggurat_constants.h), vendored in
  :mod:`nodesim.rng.ziggurat_tables` (no private module of numpy or numba is imported).
"""

from __future__ import annotations

import numpy as np
from llvmlite import ir
from numba import njit, types, uint64
from numba.extending import intrinsic
from nodesim.rng.ziggurat_tables import (
    fi_double,
    ki_double,
    wi_double,
    ziggurat_nor_inv_r,
    ziggurat_nor_r,
)

MULT_HI = np.uint64(2549297995355413924)
MULT_LO = np.uint64(4865540595714422341)
_DOUBLE_UNIT = 1.0 / 9007199254740992.0  # 2^-53


@intrinsic
def _mul_hi(typingctx, a, b):
    """High 64 bits of the 128-bit product of two uint64 (one LLVM i128 multiply)."""
    def codegen(context, builder, signature, args):
        i128 = ir.IntType(128)
        product = builder.mul(builder.zext(args[0], i128), builder.zext(args[1], i128))
        return builder.trunc(builder.lshr(product, ir.Constant(i128, 64)), ir.IntType(64))
    return types.uint64(types.uint64, types.uint64), codegen


@njit(cache=True, inline="always")
def _advance(hi, lo, inc_hi, inc_lo):
    """state x MULT + inc (mod 2^128), as (hi, lo) words."""
    new_lo = lo * MULT_LO
    new_hi = _mul_hi(lo, MULT_LO) + lo * MULT_HI + hi * MULT_LO
    add_lo = new_lo + inc_lo
    carry = uint64(1) if add_lo < new_lo else uint64(0)
    return new_hi + inc_hi + carry, add_lo


@njit(cache=True, inline="always")
def _output(hi, lo):
    """XSL-RR: rotr64(hi ^ lo, hi >> 58)."""
    x = hi ^ lo
    rot = hi >> uint64(58)
    return (x >> rot) | (x << ((uint64(64) - rot) & uint64(63)))


@njit(cache=True, inline="always")
def uniform(hi, lo, inc_hi, inc_lo):
    """(next ``random()`` draw, new hi, new lo)."""
    hi, lo = _advance(hi, lo, inc_hi, inc_lo)
    return (_output(hi, lo) >> uint64(11)) * _DOUBLE_UNIT, hi, lo


@njit(cache=True, inline="always")
def normal(hi, lo, inc_hi, inc_lo):
    """(next ``standard_normal()`` draw, new hi, new lo)."""
    while True:
        hi, lo = _advance(hi, lo, inc_hi, inc_lo)
        r = _output(hi, lo)
        idx = r & uint64(0xFF)
        r >>= uint64(8)
        sign = r & uint64(1)
        rabs = (r >> uint64(1)) & uint64(0x000FFFFFFFFFFFFF)
        x = rabs * wi_double[idx]
        if sign:
            x = -x
        if rabs < ki_double[idx]:
            return x, hi, lo
        if idx == 0:
            while True:
                u, hi, lo = uniform(hi, lo, inc_hi, inc_lo)
                xx = -ziggurat_nor_inv_r * np.log1p(-u)
                u, hi, lo = uniform(hi, lo, inc_hi, inc_lo)
                yy = -np.log1p(-u)
                if yy + yy > xx * xx:
                    tail = ziggurat_nor_r + xx
                    return (-tail if (rabs >> uint64(8)) & uint64(1) else tail), hi, lo
        else:
            u, hi, lo = uniform(hi, lo, inc_hi, inc_lo)
            if (fi_double[idx - 1] - fi_double[idx]) * u + fi_double[idx] < np.exp(-0.5 * x * x):
                return x, hi, lo


@njit(cache=True)
def seeded(words: np.ndarray) -> np.ndarray:
    """PCG64 states (M, 4) from seed-sequence words (M, 4) uint64 (numpy's ``pcg64_set_seed``)."""
    s = np.zeros(words.shape, dtype=np.uint64)
    for i in range(words.shape[0]):
        inc_hi = (words[i, 2] << uint64(1)) | (words[i, 3] >> uint64(63))
        inc_lo = (words[i, 3] << uint64(1)) | uint64(1)
        hi, lo = _advance(uint64(0), uint64(0), inc_hi, inc_lo)
        new_lo = lo + words[i, 1]
        carry = uint64(1) if new_lo < lo else uint64(0)
        hi, lo = _advance(hi + words[i, 0] + carry, new_lo, inc_hi, inc_lo)
        s[i, 0], s[i, 1], s[i, 2], s[i, 3] = hi, lo, inc_hi, inc_lo
    return s


@njit(cache=True, nogil=True)
def fill_normals(states: np.ndarray, out: np.ndarray) -> None:
    """Row i of ``out`` (M, n) = the next n ``standard_normal()`` draws of stream i (advanced in place):
    :func:`fill_normals_rows` with n for every row."""
    fill_normals_rows(states, np.full(out.shape[0], out.shape[1], np.int64), out)


@njit(cache=True, nogil=True)
def fill_normals_rows(states: np.ndarray, counts: np.ndarray, out: np.ndarray) -> None:
    """Row i of ``out`` (M, n) begins with the next ``counts[i]`` ``standard_normal()`` draws of stream i (its other
    entries are left as they are), each stream advanced in place by exactly its count: a stream read in pieces
    gives the same numbers as read at once."""
    for i in range(out.shape[0]):
        hi, lo, inc_hi, inc_lo = states[i, 0], states[i, 1], states[i, 2], states[i, 3]
        for j in range(counts[i]):
            out[i, j], hi, lo = normal(hi, lo, inc_hi, inc_lo)
        states[i, 0], states[i, 1] = hi, lo


@njit(cache=True, nogil=True)
def fill_uniforms(states: np.ndarray, rows: np.ndarray, buffer: np.ndarray, start: np.ndarray,
                  stop: np.ndarray) -> None:
    """``buffer[start[j]:stop[j]]`` = the next ``random()`` draws of stream ``rows[j]`` (advanced in place)."""
    for j in range(rows.shape[0]):
        i = rows[j]
        hi, lo, inc_hi, inc_lo = states[i, 0], states[i, 1], states[i, 2], states[i, 3]
        for p in range(start[j], stop[j]):
            buffer[p], hi, lo = uniform(hi, lo, inc_hi, inc_lo)
        states[i, 0], states[i, 1] = hi, lo
