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


ZERO_LANE = 1 << 8  # vectoring_lanes: the pre-shift slot of a zero vector (real shifts lie in -34..28)


@njit(cache=True, _nrt=False)
def vectoring_lanes(x, y, iterations, angle, shift_s, lanes32=None):
    """:func:`vectoring` of every lane j < len(x) at once: (x[j], y[j]) -> angle[j] and, in place, x[j] =
    the magnitude (y and ``shift_s`` are work rows; int64 arrays of one length).  Pre-shift and pre-rotation
    lane by lane, then each micro-rotation over all lanes (independent lanes: the compiler runs them in SIMD
    registers, the MCU's one vector after the other gives the same integers), then the gain lane by lane.
    ``lanes32``, an int32 array (3, >= len(x)), if given, holds x, y and the angle through the micro-rotations:
    the same integers (x and y fit an int32, module docstring; the angle is kept modulo 2^32, as its wrap32 is),
    twice as many lanes per SIMD register: ~18 % less time in them (64 lanes, 24 iterations, min of 15, 2026-12-06);
    the survey of a drilling-day node-window 94-99 against 101-111 ns a tick (whole processes alternated, a slow
    stretch of the VM)."""
    if lanes32 is None:
        _vectoring_lanes(x, y, iterations, angle, shift_s, x, y, angle)
    else:
        _vectoring_lanes(x, y, iterations, angle, shift_s, lanes32[0], lanes32[1], lanes32[2])


@njit(cache=True, _nrt=False, inline="always")
def _vectoring_lanes(x, y, iterations, angle, shift_s, xs, ys, zs):
    """:func:`vectoring_lanes` with the micro-rotations' x, y and angle in ``xs``, ``ys``, ``zs`` (x, y, angle
    themselves, or int32 rows)."""
    if iterations < MIN_ITERATIONS or iterations > MAX_ITERATIONS:
        raise FirmwareError("cordic: iterations outside MIN_ITERATIONS..MAX_ITERATIONS")
    n = x.shape[0]
    for j in range(n):
        xj, yj = x[j], y[j]
        ax, ay = abs(xj), abs(yj)
        if ax > MAX_INPUT or ay > MAX_INPUT:
            raise FirmwareError("cordic: an input beyond +/-(2^62 - 1)")
        m = max(ax, ay)
        if m == 0:  # angle 0, magnitude 0 (math.atan2(0, 0) = 0): the iterations run on zeros, the result is set below
            shift_s[j] = ZERO_LANE
            xs[j], ys[j], zs[j] = 0, 0, 0
            continue
        s = norm_shift(m, NORM_BITS)
        shift_s[j] = s
        xj, yj = shift(xj, s), shift(yj, s)
        # the pre-rotation without branches (the quadrant of a spinning string's toolface is not predictable):
        # sx, sy = -1 where x < 0, y < 0 (else 0); for x < 0: x <- |y|, y <- -x (y >= 0) or x (y < 0), z <- +/-2^30
        sx, sy = xj >> 63, yj >> 63
        xs[j] = (xj & ~sx) | (((yj ^ sy) - sy) & sx)
        ys[j] = (yj & ~sx) | (((xj ^ ~sy) + 1 + sy) & sx)
        zs[j] = ((QUARTER_TURN ^ sy) - sy) & sx
    for i in range(iterations):  # branchless: d = y >> 63 is 0 (y >= 0) or -1, (v ^ d) - d is v or -v
        a = ATAN[i]
        for j in range(n):
            xj, yj = xs[j], ys[j]
            d = yj >> 63
            xs[j] = xj + (((yj >> i) ^ d) - d)
            ys[j] = yj - (((xj >> i) ^ d) - d)
            zs[j] += (a ^ d) - d
    k_inv = K_INV[iterations]
    for j in range(n):
        s = shift_s[j]
        if s == ZERO_LANE:
            x[j], angle[j] = 0, 0
            continue
        mag = shift_right_round(xs[j] * k_inv, GAIN_FRAC)
        if s > 0:
            mag = shift_right_round(mag, s)
        elif s < 0:
            mag = mag << -s
        x[j], angle[j] = mag, wrap32(zs[j])


@njit(cache=True)
def vectoring(x, y, iterations):
    """(angle, magnitude) of the vector (x, y) (int64 count sums, |x|, |y| <= 2^62 - 1): angle = atan2(y, x) as a
    wrapped 32-bit binary angle, magnitude = |(x, y)| in the inputs' units (module docstring); one lane of
    :func:`vectoring_lanes`."""
    w = np.empty((4, 1), dtype=np.int64)
    w[0, 0], w[1, 0] = x, y
    vectoring_lanes(w[0], w[1], iterations, w[2], w[3])
    return w[2, 0], w[0, 0]


@njit(cache=True, _nrt=False)
def sin_cos(angle, iterations):
    """(sin, cos) of a binary angle (2^32 = one turn) in Q2.30, CORDIC in rotation mode (Volder 1959): the angle is
    folded into [-90, 90] deg (a half turn off, both results negated), then from (x, y, z) = (K_INV[n], 0, angle)

        i = 0..n-1:  z >= 0: x <- x - (y >> i), y <- y + (x >> i), z <- z - ATAN[i]
                     z < 0:  x <- x + (y >> i), y <- y - (x >> i), z <- z + ATAN[i]

    ends at (x, y) = (cos, sin) 2^30 (the gain K_n cancelled by the start value; |x|, |y| < 2^31).  Error: the
    residual angle |z| <= atan(2^-(n-1)) plus one floor LSB per shifted term and iteration, at most
    atan(2^-(n-1)) + (2 n + 1) 2^-30 (tests/firmware_model/test_cordic_survey.py checks it).  The C twin is
    cordic_sin_cos (firmware_model/c/cordic.c); the 6-state fixed filter uses it for its roll and pitch."""
    if iterations < MIN_ITERATIONS or iterations > MAX_ITERATIONS:
        raise FirmwareError("cordic: iterations outside MIN_ITERATIONS..MAX_ITERATIONS")
    z = wrap32(angle)
    flip = False
    if z > QUARTER_TURN:
        z -= 2 * QUARTER_TURN
        flip = True
    elif z < -QUARTER_TURN:
        z += 2 * QUARTER_TURN
        flip = True
    x, y = K_INV[iterations], np.int64(0)
    for i in range(iterations):
        xs, ys = x >> i, y >> i
        if z >= 0:
            x, y, z = x - ys, y + xs, z - ATAN[i]
        else:
            x, y, z = x + ys, y - xs, z + ATAN[i]
    if flip:
        x, y = -x, -y
    return y, x


_TURN_PER_LSB = 2.0**-ANGLE_BITS


def angle_rad(raw) -> np.ndarray:
    """Binary angle(s) (2^32 = one turn) in radians: (raw 2^-32) 2 pi; raw 2^-32 is exact (a power of two, |raw| <
    2^53), as an ``np.ldexp`` by -32 is (the same bits)."""
    return (np.asarray(raw, dtype=np.int64).astype(float) * _TURN_PER_LSB) * (2.0 * math.pi)


@njit(cache=True, _nrt=False, nogil=True)
def angle_rad_into(raw, out) -> None:
    """``out[r, k]`` = :func:`angle_rad` of ``raw[r, k]`` ((R, K) int64 into (R, K) float64, views allowed), its
    expression in one pass without temporaries (tests/firmware_model/test_cordic_survey.py compares the bits).  A
    drilling-day node's surveys are ~160 k of each word, converted to floats for its records."""
    for r in range(raw.shape[0]):
        for k in range(raw.shape[1]):
            out[r, k] = (float(raw[r, k]) * _TURN_PER_LSB) * (2.0 * math.pi)
