"""Integer CORDIC in vectoring mode: atan2(y, x) as a binary angle and |(x, y)|, the way an MCU without an FPU
computes the survey's trigonometry (issue 19, build item 2; docs/firmware.md "survey").

Angles are binary angles: 2^32 = one turn, held in an int64 as the wrapped (two's-complement) 32-bit value
in [-2^31, 2^31).  The algorithm (J. E. Volder, "The CORDIC trigonometric computing technique", IRE Trans.
Electron. Comput. EC-8, 1959; vectoring mode):

    pre-shift:   s such that max(|x|, |y|) * 2^s lies in [2^28, 2^29) (s < 0: arithmetic right shift, floor);
                 so small count sums keep 28 bits of precision and every intermediate fits an int32:
                 |x_i|, |y_i| <= 2^29 sqrt(2) K_n < 2^31
    pre-rotate:  x < 0, y >= 0: (x, y) <- (y, -x), z = +2^30 (a quarter turn)
                 x < 0, y < 0:  (x, y) <- (-y, x), z = -2^30            (then x >= 0, |angle| <= 90 deg)
    i = 0..n-1:  d = +1 if y >= 0 else -1
                 x <- x + d (y >> i);  y <- y - d (x >> i);  z <- z + d ATAN[i]
    angle = wrap32(z);  magnitude = round_he(round_he(x K_INV[n] / 2^30) / 2^s)   (s < 0: << -s)

with ATAN[i] = round_he(atan(2^-i) / (2 pi) 2^32) (generated from math.atan at import, checked against an exact
series in the tests; the C twin firmware_model/c/cordic.c carries the same integers) and
K_INV[n] = round_he(2^30 / K_n), K_n = prod_{i<n} sqrt(1 + 2^-2i) (the CORDIC gain, ~1.6468).  The residual
angle after n iterations is at most atan(2^-(n-1)) (Volder), plus half an LSB per table entry and the shift
truncations (~2^-28 rad each): the error bound the tests check is 2^-(n-1) + (n + 4) 2^-27 rad.
The zero vector gives angle 0 and magnitude 0 (math.atan2(0, 0) = 0).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numba.cpython.unsafe.numbers import leading_zeros

from firmware_model.errors import FirmwareError
from firmware_model.fixed_kernel import shift_right_round

ANGLE_BITS = 32
TURN = 1 << ANGLE_BITS  # binary-angle LSBs per turn
QUARTER_TURN = 1 << (ANGLE_BITS - 2)
MIN_ITERATIONS = 8
MAX_ITERATIONS = 30  # ATAN[29] = 1 LSB; ATAN[30] would round to 1 again: more iterations add nothing
DEFAULT_ITERATIONS = 24
NORM_BITS = 29  # pre-shifted inputs: max(|x|, |y|) in [2^(NORM_BITS-1), 2^NORM_BITS)
GAIN_FRAC = 30  # K_INV in Q2.30
MAX_INPUT = (1 << 62) - 1  # |x|, |y| beyond this are rejected (abs of int64 and the shifts stay defined)


def _atan_table() -> np.ndarray:
    """ATAN[i] = round_he(atan(2^-i) / (2 pi) * 2^32), i < MAX_ITERATIONS (Python's round is half even)."""
    return np.array([round(math.atan(2.0 ** -i) / (2.0 * math.pi) * TURN) for i in range(MAX_ITERATIONS)],
                    dtype=np.int64)


def _gain_inverse_table() -> np.ndarray:
    """K_INV[n] = round_he(2^30 / K_n), K_n = prod_{i<n} sqrt(1 + 2^-2i), n = 0..MAX_ITERATIONS."""
    out, k = [], 1.0
    for n in range(MAX_ITERATIONS + 1):
        out.append(round((1 << GAIN_FRAC) / k))
        k *= math.sqrt(1.0 + 2.0 ** (-2 * n))
    return np.array(out, dtype=np.int64)


ATAN = _atan_table()
K_INV = _gain_inverse_table()


def check_iterations(iterations: int) -> int:
    """``iterations`` if it is an int in [MIN_ITERATIONS, MAX_ITERATIONS], else FirmwareError."""
    if isinstance(iterations, bool) or not isinstance(iterations, (int, np.integer)) or not (
            MIN_ITERATIONS <= iterations <= MAX_ITERATIONS):
        raise FirmwareError(f"cordic_iterations = {iterations!r}: allowed integers {MIN_ITERATIONS}..{MAX_ITERATIONS}")
    return int(iterations)


@njit(cache=True, inline="always")
def wrap32(x):
    """Two's-complement wrap into 32 bits: the binary angle in [-2^31, 2^31)."""
    x &= (np.int64(1) << 32) - 1
    return x - ((x >> 31) << 32)


@njit(cache=True, inline="always")
def norm_shift(m, bits):
    """s such that m * 2^s lies in [2^(bits-1), 2^bits) for m >= 1 (s < 0: a right shift): the shift that gives
    m ``bits`` significant bits, ``bits - bit_length(m)``, bit_length(m) = 64 - clz(m) (a floor right shift of
    m >= 1 by t keeps bit_length(m) - t bits; the C twin steps the shift one bit at a time to the same s)."""
    return bits - (64 - leading_zeros(m))


@njit(cache=True, inline="always")
def shift(x, s):
    """x * 2^s: a left shift for s >= 0, an arithmetic (floor) right shift for s < 0."""
    return x << s if s >= 0 else x >> -s


@njit(cache=True)
def vectoring(x, y, iterations):
    """(angle, magnitude) of the vector (x, y) (int64 count sums, |x|, |y| <= 2^62 - 1): angle = atan2(y, x) as a
    wrapped 32-bit binary angle, magnitude = |(x, y)| in the inputs' units (module docstring)."""
    if iterations < MIN_ITERATIONS or iterations > MAX_ITERATIONS:
        raise FirmwareError("cordic: iterations outside MIN_ITERATIONS..MAX_ITERATIONS")
    ax, ay = abs(x), abs(y)
    if ax > MAX_INPUT or ay > MAX_INPUT:
        raise FirmwareError("cordic: an input beyond +/-(2^62 - 1)")
    m = max(ax, ay)
    if m == 0:
        return np.int64(0), np.int64(0)
    s = norm_shift(m, NORM_BITS)
    x, y = shift(x, s), shift(y, s)
    # the pre-rotation without branches (the quadrant of a spinning string's toolface is not predictable):
    # sx, sy = -1 where x < 0, y < 0 (else 0); for x < 0: x <- |y|, y <- -x (y >= 0) or x (y < 0), z <- +/-2^30
    sx, sy = x >> 63, y >> 63
    x, y, z = (x & ~sx) | (((y ^ sy) - sy) & sx), (y & ~sx) | (((x ^ ~sy) + 1 + sy) & sx), \
        ((QUARTER_TURN ^ sy) - sy) & sx
    for i in range(iterations):  # branchless: d = y >> 63 is 0 (y >= 0) or -1, (v ^ d) - d is v or -v
        d = y >> 63
        x, y, z = x + (((y >> i) ^ d) - d), y - (((x >> i) ^ d) - d), z + ((ATAN[i] ^ d) - d)
    mag = shift_right_round(x * K_INV[iterations], GAIN_FRAC)
    if s > 0:
        mag = shift_right_round(mag, s)
    elif s < 0:
        mag = mag << -s
    return wrap32(z), mag


def angle_rad(raw) -> np.ndarray:
    """Binary angle(s) (2^32 = one turn) in radians: raw 2 pi / 2^32 (exact in a double)."""
    return np.ldexp(np.asarray(raw, dtype=np.int64).astype(float), -ANGLE_BITS) * (2.0 * math.pi)
