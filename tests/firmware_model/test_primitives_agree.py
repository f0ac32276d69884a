"""One set of fixed-point primitives: the njit scalar primitives the firmware runs (firmware_model.fixed_kernel
_add/_sub/_mul/_div, round half even + saturate) give the bits and the overflow counts of the array primitives of
firmware_model.fixedpoint - whose every mode apytypes checks (test_fixedpoint.py) - and the C primitives
(firmware_model/c/fixedpoint.c) give the kernels' bits and counts, on 10,000 random operand/format cases each,
saturating ones included."""

from __future__ import annotations

import numpy as np
import pytest

from firmware_model import c_reference
from firmware_model import fixed_kernel as fk
from firmware_model import fixedpoint as fp
from firmware_model.fixedpoint import Fx, QFormat

OPS = ("add", "sub", "mul", "div")


def random_case(rng, op):
    """(a, fa, b, fb, out) within the ranges fixedpoint allows for ``op``."""
    while True:
        wa, wb, wo = (int(rng.integers(8, 33)) for _ in range(3))
        fa, fb = int(rng.integers(-4, 40)), int(rng.integers(-4, 40))
        fo = int(rng.integers(-4, 40))
        if op in ("add", "sub") and abs(fa - fb) > 31:
            continue
        if op == "mul" and not -40 <= fa + fb - fo <= 62:
            continue
        if op in ("add", "sub") and not -40 <= max(fa, fb) - fo <= 62:
            continue
        if op == "div" and abs(fo - fa + fb) > 30:
            continue
        qa, qb = QFormat(wa, fa), QFormat(wb, fb)
        pick = lambda q: int(rng.choice([q.min_raw, q.max_raw, 0, -1, 1, int(rng.integers(q.min_raw, q.max_raw + 1)),  # noqa: E731
                                         int(rng.integers(-64, 65))]))
        a, b = pick(qa), pick(qb)
        a = min(max(a, qa.min_raw), qa.max_raw)
        b = min(max(b, qb.min_raw), qb.max_raw)
        return a, qa, b, qb, QFormat(wo, fo)


def kernel(op, a, qa, b, qb, out):
    counts = np.zeros(1, np.int64)
    p = np.array([out.word_bits, out.frac_bits], np.int64)
    fn = {"add": fk._add, "sub": fk._sub, "mul": fk._mul, "div": fk._div}[op]
    return int(fn(np.int64(a), qa.frac_bits, np.int64(b), qb.frac_bits, p, 0, counts, 0)), int(counts[0])


@pytest.mark.parametrize("op", OPS)
def test_kernel_primitives_equal_the_apytypes_checked_array_primitives(op):
    rng = np.random.default_rng(OPS.index(op))
    saturated = 0
    for _ in range(10_000):
        a, qa, b, qb, out = random_case(rng, op)
        counter = fp.OverflowCounter()
        want = getattr(fp, op)(Fx(np.int64(a), qa), Fx(np.int64(b), qb), out, counter=counter, site="s")
        got, n = kernel(op, a, qa, b, qb, out)
        assert (got, n) == (int(want.raw), counter.total), (op, a, qa, b, qb, out)
        saturated += n
    assert saturated > 100  # the cases reach saturation


@pytest.mark.parametrize("op", OPS)
def test_c_primitives_equal_the_kernel_primitives(op):
    ffi, lib = c_reference.load()
    fn = getattr(lib, f"fx_{op}")
    rng = np.random.default_rng(100 + OPS.index(op))
    counts = np.zeros(1, np.int64)
    buf = ffi.from_buffer("int64_t[]", counts)
    for _ in range(10_000):
        a, qa, b, qb, out = random_case(rng, op)
        counts[0] = 0
        got = fn(a, qa.frac_bits, b, qb.frac_bits, out.word_bits, out.frac_bits, buf, 0)
        assert (got, int(counts[0])) == kernel(op, a, qa, b, qb, out), (op, a, qa, b, qb, out)


def test_a_broken_c_saturation_is_caught(tmp_path):
    ffi, lib = c_reference.load_modified({"fixedpoint.c": ("if (x > hi) { counts[site] += 1; return hi; }",
                                                          "if (x > hi) { return hi; }")}, tmp_path)
    counts = np.zeros(1, np.int64)
    buf = ffi.from_buffer("int64_t[]", counts)
    rng = np.random.default_rng(7)
    mismatches = 0
    for _ in range(2000):
        a, qa, b, qb, out = random_case(rng, "mul")
        counts[0] = 0
        got = lib.fx_mul(a, qa.frac_bits, b, qb.frac_bits, out.word_bits, out.frac_bits, buf, 0)
        mismatches += (got, int(counts[0])) != kernel("mul", a, qa, b, qb, out)
    assert mismatches > 0
