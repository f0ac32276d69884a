"""Survey resolution and the 32-point moving average as the node MCU computes them (integer binary angles).

Per firmware tick, from the tick's accelerometer count sums (f'_x, f'_y, f'_z, int64, sensor frame) and the
filter's yaw (a binary angle in the yaw format), thesis eqs 1.1-1.3 (digest 1.2;
:mod:`firmware_model.survey_resolution` is the float form):

    toolface tau' = atan2(f'_y, f'_x);   h = hypot(f'_x, f'_y);   I = atan2(h, f'_z);   A = tau' + psi

Two ways, the configuration's ``survey_math`` (``FirmwareConfig``):

- ``"cordic"`` (MODE_CORDIC, the default): the three sums are first shifted together (floor) so the largest
  magnitude lies in [2^27, 2^28) (a common scale, so the ratio h / f'_z is kept, and h, at most sqrt(2) 2^28,
  stays inside the CORDIC's range); tau' and h from one CORDIC vectoring of (f'_x, f'_y), I = |angle| of the
  vectoring of (f'_z, h) (h >= 0: the exact angle lies in [0, 180 deg]; the absolute value folds the CORDIC's
  residual back into that range) -- :func:`firmware_model.cordic.vectoring`;
- ``"fpu"`` (MODE_FPU): an MCU with a single-precision FPU: the sums converted to float32, tau' = atan2f,
  h = sqrtf(x x + y y), I = atan2f(h, z) (every operation in float32, as numpy float32 scalars / C ``float``),
  then to binary angles as rint(angle * float32(2^32 / 2 pi)) (float32 multiply, round half even).

Output words: I in [0, 2^31] (2^31 = 180 deg), A = (tau' + psi_32) mod 2^32 in [0, 2^32) (the binary-angle add
wraps: the mod 2 pi of eq 1.3 is free), psi_32 the yaw at 32 fraction bits of a turn (left shift, or a
round-half-even right shift for a yaw format with more than 32 fraction bits).

Moving average over the last N = ``points`` ticks (the first N - 1 outputs average what has arrived, as the
float version's ring buffer that is filling up; state layout :data:`MA_STATE` + 2 N ring words):

    I_avg = round_he(sum_window I / n)
    A_avg = (A_k + round_he(sum_window wrap32(A_j - A_k) / n)) mod 2^32     (A_k the newest sample)

i.e. the mean of the wrapped differences to the newest sample, added to it: exact integer arithmetic, no
trigonometry, right across the 0/360 deg seam.  C twin: firmware_model/c/survey.c (same words bit for bit).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from firmware_model import cordic
from firmware_model.cordic import wrap32
from firmware_model.errors import FirmwareError
from firmware_model.fixed_kernel import div_round, shift_right_round

MODE_CORDIC = 0
MODE_FPU = 1
MODES = {"cordic": MODE_CORDIC, "fpu": MODE_FPU}
SURVEY_NORM_BITS = 28  # cordic mode: the common pre-shift puts max(|f'|) in [2^27, 2^28)
MASK32 = (1 << 32) - 1
RAD_TO_BA32_F32 = np.float32(cordic.TURN / (2.0 * math.pi))  # float32(683565275.58...)
MA_COUNT, MA_HEAD, MA_SUM_I, MA_RING = 0, 1, 2, 3  # moving-average state words; rings of I then A follow
MA_STATE = ("count", "head", "sum_i")
W_FX, W_FY, W_FZ, W_YAW32, W_INC, W_AZI, W_SHIFT = range(7)  # rows of resolve_cordic_lanes' work array
WORK_ROWS = 7
BLOCK = 64  # fixed_surveys resolves this many ticks at once (lanes of resolve_cordic_lanes)


def ma_state_size(points: int) -> int:
    return MA_RING + 2 * points


@njit(cache=True, inline="always")
def yaw_to_ba32(yaw_raw, yaw_frac_bits):
    """The yaw (turns, ``yaw_frac_bits`` fraction bits) as a 32-bit binary angle in [0, 2^32)."""
    if yaw_frac_bits <= 32:
        y = yaw_raw << (32 - yaw_frac_bits)
    else:
        y = shift_right_round(yaw_raw, yaw_frac_bits - 32)
    return y & MASK32


@njit(cache=True, _nrt=False)
def resolve_cordic_lanes(work, iterations):
    """(I, A) binary angles by integer CORDIC (module docstring) of every lane j of ``work`` (int64 (WORK_ROWS, n)):
    rows W_FX, W_FY, W_FZ the count sums and W_YAW32 the yaw binary angle in, rows W_INC, W_AZI the result out
    (the other rows and the inputs are overwritten); both vectorings run over all lanes at once
    (:func:`firmware_model.cordic.vectoring_lanes`)."""
    fx, fy, fz = work[W_FX], work[W_FY], work[W_FZ]
    for j in range(fx.shape[0]):
        m = max(abs(fx[j]), abs(fy[j]), abs(fz[j]))
        if m > cordic.MAX_INPUT:
            raise FirmwareError("survey: an accelerometer sum beyond +/-(2^62 - 1)")
        if m > 0:
            s = cordic.norm_shift(m, SURVEY_NORM_BITS)
            fx[j], fy[j], fz[j] = cordic.shift(fx[j], s), cordic.shift(fy[j], s), cordic.shift(fz[j], s)
    cordic.vectoring_lanes(fx, fy, iterations, work[W_AZI], work[W_SHIFT])  # toolface -> W_AZI, h -> W_FX
    cordic.vectoring_lanes(fz, fx, iterations, work[W_INC], work[W_SHIFT])  # inclination -> W_INC
    inc, azi, yaw32 = work[W_INC], work[W_AZI], work[W_YAW32]
    for j in range(inc.shape[0]):
        inc[j], azi[j] = abs(inc[j]), (azi[j] + yaw32[j]) & MASK32


@njit(cache=True)
def resolve_cordic(fx, fy, fz, yaw32, iterations):
    """(I, A) binary angles from count sums by integer CORDIC (module docstring): one lane of
    :func:`resolve_cordic_lanes`."""
    work = np.empty((WORK_ROWS, 1), dtype=np.int64)
    work[W_FX, 0], work[W_FY, 0], work[W_FZ, 0], work[W_YAW32, 0] = fx, fy, fz, yaw32
    resolve_cordic_lanes(work, iterations)
    return work[W_INC, 0], work[W_AZI, 0]


@njit(cache=True)
def resolve_fpu(fx, fy, fz, yaw32):
    """(I, A) binary angles from count sums in single-precision float (module docstring)."""
    x, y, z = np.float32(fx), np.float32(fy), np.float32(fz)
    toolface = np.arctan2(y, x)
    h = np.sqrt(x * x + y * y)
    inc = np.arctan2(h, z)
    k = RAD_TO_BA32_F32
    tf_raw = np.int64(np.rint(toolface * k))
    inc_raw = np.int64(np.rint(inc * k))
    return inc_raw, (tf_raw + yaw32) & MASK32


@njit(cache=True)
def resolve(fx, fy, fz, yaw32, mode, iterations):
    """(I, A) binary angles of one tick in ``mode`` (MODE_CORDIC or MODE_FPU)."""
    if mode == MODE_CORDIC:
        return resolve_cordic(fx, fy, fz, yaw32, iterations)
    if mode == MODE_FPU:
        return resolve_fpu(fx, fy, fz, yaw32)
    raise FirmwareError("survey: mode must be MODE_CORDIC (0) or MODE_FPU (1)")


@njit(cache=True, _nrt=False)
def ma_reset(state):
    state[MA_COUNT] = 0
    state[MA_HEAD] = 0
    state[MA_SUM_I] = 0


@njit(cache=True, _nrt=False)
def ma_push(state, points, inc, azi):
    """Add one survey (I, A) to the moving average, return (I_avg, A_avg) (module docstring)."""
    head = state[MA_HEAD]
    ri, ra = MA_RING, MA_RING + points
    if state[MA_COUNT] == points:
        state[MA_SUM_I] -= state[ri + head]
    else:
        state[MA_COUNT] += 1
    state[ri + head], state[ra + head] = inc, azi
    state[MA_SUM_I] += inc
    state[MA_HEAD] = head + 1 if head + 1 < points else 0  # (head + 1) mod points, without a division
    n = state[MA_COUNT]
    d = np.int64(0)
    for j in range(n):
        d += wrap32(state[ra + j] - azi)
    return div_round(state[MA_SUM_I], n), (azi + div_round(d, n)) & MASK32


@njit(cache=True, nogil=True)
def fixed_surveys(accel_counts, yaw_raw, points, mode, iterations, inc_raw_out, azi_raw_out, yaw_frac_bits=32):
    """``accel_counts`` (R, K, 3) int64 count sums, ``yaw_raw`` (R, K) int64 yaw words -> the moving-averaged
    I and A binary angles (R, K) into ``inc_raw_out`` and ``azi_raw_out`` (module docstring); each realization's
    average starts empty at k = 0."""
    if points < 1:
        raise FirmwareError("survey: points must be >= 1")
    if mode == MODE_CORDIC and (iterations < cordic.MIN_ITERATIONS or iterations > cordic.MAX_ITERATIONS):
        raise FirmwareError("survey: cordic iterations outside MIN_ITERATIONS..MAX_ITERATIONS")
    R, K = yaw_raw.shape
    state = np.zeros(MA_RING + 2 * points, dtype=np.int64)
    work = np.zeros((WORK_ROWS, BLOCK), dtype=np.int64)
    for r in range(R):
        ma_reset(state)
        for k0 in range(0, K, BLOCK):  # BLOCK ticks resolved at once (CORDIC lanes), then averaged one by one
            n = min(BLOCK, K - k0)
            for j in range(n):
                k = k0 + j
                y32 = yaw_to_ba32(yaw_raw[r, k], yaw_frac_bits)
                if mode == MODE_CORDIC:
                    work[W_FX, j], work[W_FY, j], work[W_FZ, j] = accel_counts[r, k, 0], accel_counts[r, k, 1], \
                        accel_counts[r, k, 2]
                    work[W_YAW32, j] = y32
                else:
                    work[W_INC, j], work[W_AZI, j] = resolve(accel_counts[r, k, 0], accel_counts[r, k, 1],
                                                             accel_counts[r, k, 2], y32, mode, iterations)
            if mode == MODE_CORDIC:
                work[:W_YAW32 + 1, n:] = 0  # a last, partial block: zero vectors in the unused lanes
                resolve_cordic_lanes(work, iterations)
            for j in range(n):
                inc_raw_out[r, k0 + j], azi_raw_out[r, k0 + j] = ma_push(state, points, work[W_INC, j], work[W_AZI, j])


def mode_of(survey_math: str) -> int:
    """MODE_* of a ``survey_math`` name ("cordic" or "fpu")."""
    if survey_math not in MODES:
        raise FirmwareError(f"survey_math = {survey_math!r}: allowed {sorted(MODES)}")
    return MODES[survey_math]


def inclination_rad(inc_raw) -> np.ndarray:
    """I words (2^32 = one turn, [0, 2^31]) in radians."""
    return cordic.angle_rad(inc_raw)


def azimuth_rad(azi_raw) -> np.ndarray:
    """A words ([0, 2^32)) in radians, [0, 2 pi)."""
    return cordic.angle_rad(azi_raw)
