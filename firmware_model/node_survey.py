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
trigonometry, right across the 0/360 deg seam.

Mid-window yaw.  A tick's count sums are the sum of the samples read over [T_(k-1), T_k], so their mean is the
specific force at the window's middle (for a constant rate exactly its direction: the mean of a vector turning at
a constant rate over an arc points at the arc's middle), while the filter's yaw word is the yaw at the tick's end
T_k.  Pairing the two puts A half a tick's rotation off while the string turns (71 deg/s at 1.9 Hz: 18.7 deg).  The
survey therefore pairs the tick's accelerometer with the yaw at the window's middle, the midpoint of the previous
and this tick's yaw words on the circle (our first-principles choice; the thesis does not say how its firmware
pairs them):

    psi_mid = (psi_(k-1) + round_he(wrap32(psi_k - psi_(k-1)) / 2)) mod 2^32        (psi_mid = psi_k at the first tick)

exact for a constant rate (the filter's predict advances psi by (rate - bias) dt per tick) and unambiguous while
the string turns less than half a turn per tick: the thesis's own Nyquist condition for its 1.9 Hz firmware
(rotation <= 0.95 Hz, thesis sec 4.2.3); beyond it the pairing aliases, as the survey itself does.  An update at
tick k moves psi_mid by half its correction (the interpolation between the two posterior estimates).

Alignment offset (thesis sec 4.2.3, digest 5.2: during the slow calibration rotation "the maximum and minimum pitch
and roll measurements are determined, added and divided by two for subtraction from each subsequent pitch and roll
reading").  A residual tilt of the sensor frame (thesis table 4.20, sigma 0.0422 deg) adds a constant
g cos(I) (b, -a) to f'_x, f'_y while the inclination's g sin(I) (cos tau', sin tau') turns with the string; over a
full turn (max + min) / 2 of each transverse axis is that constant.  In the firmware, over the ticks the driver marks
``aligning`` (the alignment window):

    m_x = round_he(f'_x 2^8 / n)                      the tick's mean count, Q8 LSB per sample (also m_y)
    M_x = round_he(sum of the last N m_x / N)        the firmware's N-point moving average (the thesis reads its
                                                     pitch and roll after its moving-average filter, sec 4.2.3),
                                                     started empty at the window's first tick
    max_x, min_x over the ticks whose average is full (N samples; the filling-up averages are noisier)
    off_x = round_he((max_x + min_x) / 2)            at the first tick after the window (Q8 LSB per sample)
    f'_x <- f'_x - round_he(off_x n / 2^8)           on that tick and every later one, before the resolution

(likewise y; the 32-point average reduces the noise on the extremes 5.7-fold, the 60-deg arc it spans shrinks the
swing by sinc, which leaves the midpoint unbiased).  A window with no full average leaves the offset 0.  Limits:
|f'_x|, |f'_y| <= 2^40 on the window's ticks and |off| n < 2^62 after it (FirmwareError beyond).

Survey state (int64 words, :data:`MA_STATE`, then the rings of I, A, M_x, M_y, N words each; C twin:
firmware_model/c/survey.c, same words bit for bit).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numba.cpython.unsafe.numbers import trailing_zeros

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
MA_STATE = ("count", "head", "sum_i", "prev_yaw", "align", "al_count", "al_head", "al_sum_x", "al_sum_y",
            "max_x", "min_x", "max_y", "min_y", "off_x", "off_y")
"""The survey's state words: the I/A moving average (count, head, sum of I), the previous yaw (ba32, -1 before the
first tick), the alignment (ALIGN_* phase, its average's count, head and sums, the extremes, the offsets in Q8 LSB
per sample); the rings of I, A, M_x, M_y (N words each) follow."""
(MA_COUNT, MA_HEAD, MA_SUM_I, MA_PREV_YAW, AL_PHASE, AL_COUNT, AL_HEAD, AL_SUM_X, AL_SUM_Y, AL_MAX_X, AL_MIN_X,
 AL_MAX_Y, AL_MIN_Y, AL_OFF_X, AL_OFF_Y) = range(len(MA_STATE))
MA_RING = len(MA_STATE)
ALIGN_IDLE, ALIGN_COLLECTING, ALIGN_APPLIED = 0, 1, 2  # AL_PHASE: no full average yet, extremes held, offset applied
ALIGN_FRAC = 8  # fraction bits of the tick-mean counts, their average, extremes and offsets (LSB per sample)
ALIGN_MAX_SUM = (1 << 40)  # |f'_x|, |f'_y| limit on an alignment tick: |m| <= 2^48, a ring sum of N <= 2^14 < 2^62
W_FX, W_FY, W_FZ, W_YAW32, W_INC, W_AZI, W_SHIFT = range(7)  # rows of resolve_cordic_lanes' work array
WORK_ROWS = 7
BLOCK = 64  # fixed_surveys resolves this many ticks at once (lanes of resolve_cordic_lanes)


def ma_state_size(points: int) -> int:
    return MA_RING + 4 * points


@njit(cache=True, inline="always")
def yaw_to_ba32(yaw_raw, yaw_frac_bits):
    """The yaw (turns, ``yaw_frac_bits`` fraction bits) as a 32-bit binary angle in [0, 2^32)."""
    if yaw_frac_bits <= 32:
        y = yaw_raw << (32 - yaw_frac_bits)
    else:
        y = shift_right_round(yaw_raw, yaw_frac_bits - 32)
    return y & MASK32


@njit(cache=True, _nrt=False)
def resolve_cordic_lanes(work, iterations, lanes32=None):
    """(I, A) binary angles by integer CORDIC (module docstring) of every lane j of ``work`` (int64 (WORK_ROWS, n)):
    rows W_FX, W_FY, W_FZ the count sums and W_YAW32 the yaw binary angle in, rows W_INC, W_AZI the result out
    (the other rows and the inputs are overwritten); both vectorings run over all lanes at once
    (:func:`firmware_model.cordic.vectoring_lanes`, their micro-rotations in ``lanes32``, int32 (3, n), if given)."""
    fx, fy, fz = work[W_FX], work[W_FY], work[W_FZ]
    for j in range(fx.shape[0]):
        m = max(abs(fx[j]), abs(fy[j]), abs(fz[j]))
        if m > cordic.MAX_INPUT:
            raise FirmwareError("survey: an accelerometer sum beyond +/-(2^62 - 1)")
        if m > 0:
            s = cordic.norm_shift(m, SURVEY_NORM_BITS)
            fx[j], fy[j], fz[j] = cordic.shift(fx[j], s), cordic.shift(fy[j], s), cordic.shift(fz[j], s)
    cordic.vectoring_lanes(fx, fy, iterations, work[W_AZI], work[W_SHIFT], lanes32)  # toolface -> W_AZI, h -> W_FX
    cordic.vectoring_lanes(fz, fx, iterations, work[W_INC], work[W_SHIFT], lanes32)  # inclination -> W_INC
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
    """A node at power-up: empty averages, no previous yaw, no alignment offset."""
    for i in range(MA_RING):
        state[i] = 0
    state[MA_PREV_YAW] = -1


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
    ring = state[ra:ra + n]
    for j in range(n):
        d += np.int64(np.int32(ring[j] - azi))  # wrap32: the int32 truncation is the same two's complement value,
        # and the loop over a view of the ring runs ~1.6x faster (38 -> 24 ns a push of 32 points, 2026-12-06)
    return _div_round_count(state[MA_SUM_I], n), (azi + _div_round_count(d, n)) & MASK32


@njit(cache=True, inline="always")
def _div_round_count(x, n):
    """``div_round(x, n)`` for an average's count n >= 1: by a power of two (the default 32 points once full) a
    rounding shift (:func:`~firmware_model.fixed_kernel.shift_right_round`, also half to even: the same value for
    |x| < 2^62, and the sums here are below n 2^32) instead of an int64 division, ~11 ns each on this host."""
    if n & (n - 1) == 0:
        s = trailing_zeros(n)
        return x if s == 0 else shift_right_round(x, s)
    return div_round(x, n)


@njit(cache=True, inline="always")
def _times_exceeds(n, a, limit):
    """Whether n a > ``limit`` for n, a >= 1, i.e. ``n > limit // a`` (the same test: n > floor(L / a) exactly when
    n a > L), by one multiplication where n a cannot overflow (n < 2^14, a < 2^48: the alignment's offsets and a
    tick's samples), else by that division."""
    if n < (1 << 14) and a < (1 << 48):
        return n * a > limit
    return n > limit // a


@njit(cache=True, _nrt=False)
def mid_yaw(state, yaw32):
    """The yaw at the middle of this tick's sample window from the previous and this tick's yaw words (module
    docstring); remembers this one."""
    prev = state[MA_PREV_YAW]
    state[MA_PREV_YAW] = yaw32
    if prev < 0:
        return yaw32
    return (prev + shift_right_round(wrap32(yaw32 - prev), 1)) & MASK32


@njit(cache=True, _nrt=False)
def align_collect(state, points, fx, fy, n):
    """One alignment-window tick: push the tick-mean x, y counts into the alignment's N-point average and, once it
    is full, into its extremes (module docstring)."""
    if abs(fx) > ALIGN_MAX_SUM or abs(fy) > ALIGN_MAX_SUM:
        raise FirmwareError("survey alignment: an accelerometer sum beyond +/-2^40 in the alignment window")
    mx, my = div_round(fx * (1 << ALIGN_FRAC), n), div_round(fy * (1 << ALIGN_FRAC), n)
    head = state[AL_HEAD]
    rx, ry = MA_RING + 2 * points, MA_RING + 3 * points
    if state[AL_COUNT] == points:
        state[AL_SUM_X] -= state[rx + head]
        state[AL_SUM_Y] -= state[ry + head]
    else:
        state[AL_COUNT] += 1
    state[rx + head], state[ry + head] = mx, my
    state[AL_SUM_X] += mx
    state[AL_SUM_Y] += my
    state[AL_HEAD] = (head + 1) % points
    if state[AL_COUNT] < points:
        return
    ax, ay = div_round(state[AL_SUM_X], points), div_round(state[AL_SUM_Y], points)
    if state[AL_PHASE] == ALIGN_IDLE:
        state[AL_MAX_X], state[AL_MIN_X], state[AL_MAX_Y], state[AL_MIN_Y] = ax, ax, ay, ay
        state[AL_PHASE] = ALIGN_COLLECTING
    else:
        state[AL_MAX_X], state[AL_MIN_X] = max(state[AL_MAX_X], ax), min(state[AL_MIN_X], ax)
        state[AL_MAX_Y], state[AL_MIN_Y] = max(state[AL_MAX_Y], ay), min(state[AL_MIN_Y], ay)


@njit(cache=True, _nrt=False)
def align_correction(state, n):
    """(x, y) count-sum corrections round_he(off n / 2^8) of a tick after the window (0 without an offset); the
    first such tick turns the extremes into the offsets (module docstring)."""
    if state[AL_PHASE] == ALIGN_COLLECTING:
        state[AL_OFF_X] = shift_right_round(state[AL_MAX_X] + state[AL_MIN_X], 1)
        state[AL_OFF_Y] = shift_right_round(state[AL_MAX_Y] + state[AL_MIN_Y], 1)
        state[AL_PHASE] = ALIGN_APPLIED
    if state[AL_PHASE] != ALIGN_APPLIED:
        return np.int64(0), np.int64(0)
    ox, oy = state[AL_OFF_X], state[AL_OFF_Y]
    if ((ox != 0 and _times_exceeds(n, abs(ox), cordic.MAX_INPUT))
            or (oy != 0 and _times_exceeds(n, abs(oy), cordic.MAX_INPUT))):
        raise FirmwareError("survey alignment: offset x samples beyond 2^62")
    return shift_right_round(ox * n, ALIGN_FRAC), shift_right_round(oy * n, ALIGN_FRAC)


@njit(cache=True, _nrt=False)
def survey_prepare(state, points, fx, fy, fz, n, yaw32, aligning):
    """The tick's resolver inputs: the count sums of n >= 1 samples after the alignment offset (collected in the
    window, subtracted after it) and the mid-window yaw (ba32) -> (f'_x, f'_y, f'_z, psi_mid) (module docstring)."""
    if n < 1:
        raise FirmwareError("survey: a tick with no sample (n < 1)")
    psi = mid_yaw(state, yaw32)
    if aligning:
        align_collect(state, points, fx, fy, n)
    else:
        cx, cy = align_correction(state, n)
        fx, fy = fx - cx, fy - cy
    return fx, fy, fz, psi


@njit(cache=True)
def survey_tick(state, points, fx, fy, fz, n, yaw32, aligning, mode, iterations):
    """One tick of the survey (the C reference's ``survey_tick``): the count sums of n >= 1 samples, the tick's
    yaw (ba32) and whether it lies in the alignment window -> the moving-averaged (I, A) words (module
    docstring: alignment offset, mid-window yaw, eqs 1.1-1.3, N-point average); :func:`fixed_surveys` runs the
    same three steps with the resolution of 64 ticks at once."""
    fx, fy, fz, psi = survey_prepare(state, points, fx, fy, fz, n, yaw32, aligning)
    i_raw, a_raw = resolve(fx, fy, fz, psi, mode, iterations)
    return ma_push(state, points, i_raw, a_raw)


@njit(cache=True, nogil=True)
def fixed_surveys(accel_counts, yaw_raw, samples, align_lo, align_hi, points, mode, iterations, inc_raw_out,
                  azi_raw_out, yaw_frac_bits=32):
    """``accel_counts`` (R, K, 3) int64 count sums of ``samples`` (K,) samples, ``yaw_raw`` (R, K) int64 yaw
    words, the alignment window ``align_lo <= k < align_hi`` (empty: no offset) -> the moving-averaged I and A
    binary angles (R, K) into ``inc_raw_out`` and ``azi_raw_out`` (:func:`survey_tick`); each realization starts
    from :func:`ma_reset` at k = 0 (:func:`fixed_surveys_window` over all ticks)."""
    states = np.zeros((yaw_raw.shape[0], MA_RING + 4 * points), dtype=np.int64)  # ma_state_size(points)
    fixed_surveys_window(accel_counts, yaw_raw, samples, 0, align_lo, align_hi, points, mode, iterations, states,
                         inc_raw_out, azi_raw_out, yaw_frac_bits)


@njit(cache=True, nogil=True)
def fixed_surveys_window(accel_counts, yaw_raw, samples, k_base, align_lo, align_hi, points, mode, iterations, states,
                         inc_raw_out, azi_raw_out, yaw_frac_bits=32):
    """:func:`fixed_surveys` of a window of a node's ticks, the arrays' tick k being the node's tick k_base + k (the
    alignment window is in the node's ticks), each realization's moving-average and alignment state ``states[r]``
    carried from the window before (reset at k_base = 0): windows give the words of all ticks at once."""
    if points < 1:
        raise FirmwareError("survey: points must be >= 1")
    if mode == MODE_CORDIC and (iterations < cordic.MIN_ITERATIONS or iterations > cordic.MAX_ITERATIONS):
        raise FirmwareError("survey: cordic iterations outside MIN_ITERATIONS..MAX_ITERATIONS")
    R, K = yaw_raw.shape
    work = np.zeros((WORK_ROWS, BLOCK), dtype=np.int64)
    lanes32 = np.zeros((3, BLOCK), dtype=np.int32)  # the CORDIC's micro-rotations (cordic.vectoring_lanes)
    for r in range(R):
        state = states[r]
        if k_base == 0:
            ma_reset(state)
        for k0 in range(0, K, BLOCK):  # BLOCK ticks prepared in order, resolved at once (CORDIC lanes), then averaged
            n = min(BLOCK, K - k0)
            for j in range(n):
                k = k0 + j
                fx, fy, fz, psi = survey_prepare(state, points, accel_counts[r, k, 0], accel_counts[r, k, 1],
                                                 accel_counts[r, k, 2], samples[k],
                                                 yaw_to_ba32(yaw_raw[r, k], yaw_frac_bits),
                                                 align_lo <= k_base + k < align_hi)
                if mode == MODE_CORDIC:
                    work[W_FX, j], work[W_FY, j], work[W_FZ, j], work[W_YAW32, j] = fx, fy, fz, psi
                else:
                    work[W_INC, j], work[W_AZI, j] = resolve(fx, fy, fz, psi, mode, iterations)
            if mode == MODE_CORDIC:
                work[:W_YAW32 + 1, n:] = 0  # a last, partial block: zero vectors in the unused lanes
                resolve_cordic_lanes(work, iterations, lanes32)
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
