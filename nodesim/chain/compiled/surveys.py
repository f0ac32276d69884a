"""The surveys a chain run (and a replay) reports, resolved and moving-averaged in one compiled pass per node.

For every realization r and tick k (thesis eqs 1.1-1.3, :func:`firmware_model.survey_resolution.resolve`):
    tau' = atan2(f'_y, f'_x),  I = atan2(h, f'_z) with h = sqrt(f'_x^2 + f'_y^2),  A = (tau' + psi) mod 2 pi,
then the firmware's trailing N-point moving average of I and the circular one of A (through cos A and sin A),
the first N - 1 outputs averaging what has arrived (:func:`firmware_model.survey_resolution.trailing_moving_average`,
:func:`~firmware_model.survey_resolution.circular_moving_average`), as running sums (the window as the difference of two
of them, as ``cumsum`` forms them).  The unit vector of A comes from rotating the sensor-frame one by psi
(eq 1.1), without forming A:
    cos A = (f'_x cos psi - f'_y sin psi) / h,   sin A = (f'_y cos psi + f'_x sin psi) / h
(one atan2 and one remainder fewer per tick: ~30 % of this pass).  So I is the numpy functions' value bit for
bit, the averaged A agrees with them to rounding (an angle error of ~1e-16 / |mean unit vector|), and chain
runs and replays, which both call this, agree bit for bit: tests/nodesim/chain/test_surveys.py.

Before the resolution, the float form of the fixed firmware's two steps (:mod:`firmware_model.node_survey`, its
docstring gives the reasons): psi is the yaw at the middle of the tick's sample window,
    psi_mid = psi_(k-1) + remainder(psi_k - psi_(k-1), 2 pi) / 2      (psi_k at the first tick),
and, with an alignment window align_lo <= k < align_hi (thesis sec 4.2.3), the offset (max + min) / 2 of the
N-point moving average of f'_x and of f'_y over the window's full averages is subtracted from f'_x, f'_y on every
tick after the window.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from firmware_model.cordic import angle_rad_into
from firmware_model.node_survey import fixed_surveys_window
from nodesim import threads
from nodesim.chain.compiled.angles import mod_two_pi


@njit(cache=True, inline="always")
def _unit_azimuth(fx: float, fy: float, h: float, psi: float) -> tuple[float, float]:
    """(cos A, sin A) of A = atan2(f'_y, f'_x) + psi (module docstring); h = sqrt(f'_x^2 + f'_y^2)."""
    c, s = math.cos(psi), math.sin(psi)
    if h > 0.0:
        return (fx * c - fy * s) / h, (fy * c + fx * s) / h
    a = np.remainder(np.arctan2(fy, fx) + psi, 2.0 * math.pi)  # no horizontal component: atan2's convention
    return math.cos(a), math.sin(a)


@njit(cache=True, nogil=True)
def averaged_surveys(force: np.ndarray, yaw_rad: np.ndarray, align_lo: int, align_hi: int, points: int,
                     inc_out: np.ndarray, azi_out: np.ndarray) -> None:
    """``force`` (R, K, 3) sensor-frame specific force, ``yaw_rad`` (R, K) tick-end yaw, the alignment window
    ``align_lo <= k < align_hi`` (empty: no offset) -> moving-averaged inclination and azimuth (R, K) [rad] into
    ``inc_out`` and ``azi_out`` (module docstring): :func:`averaged_surveys_window` over all ticks."""
    R = yaw_rad.shape[0]
    state = (np.zeros((R, SURVEY_FLOATS)), np.zeros((R, SURVEY_INTS), np.int64), np.empty((R, 2, points)),
             np.empty((R, 3, points)))
    averaged_surveys_window(force, yaw_rad, 0, align_lo, align_hi, points, *state, inc_out, azi_out)


SURVEY_FLOATS = 10
"""A realization's float survey state (:func:`averaged_surveys_window`): the running sums of I, cos A, sin A, the
alignment's sums of f'_x and f'_y, the max and min of its averages of f'_x and of f'_y, the yaw of the tick
before."""
SURVEY_INTS = 3
"""Its integers: the alignment average's count and ring head, and whether the alignment is full."""


@njit(cache=True, nogil=True)
def averaged_surveys_window(force, yaw_rad, k_base, align_lo, align_hi, points, floats, ints, ring, history, inc_out,
                            azi_out) -> None:
    """:func:`averaged_surveys` of a window of a node's ticks, the arrays' tick k being its tick k_base + k (the
    alignment window in its ticks), each realization's state carried from the window before (``floats`` (R,
    :data:`SURVEY_FLOATS`), ``ints`` (R, :data:`SURVEY_INTS`), the alignment's ring (R, 2, points), the last
    ``points`` running sums (R, 3, points), slot k mod points; all reset at k_base = 0): windows give what all
    ticks give at once, bit for bit (the same operations on the same values)."""
    R, K = yaw_rad.shape
    for r in range(R):
        st, it, ring_r, hist = floats[r], ints[r], ring[r], history[r]
        if k_base == 0:
            st[:] = 0.0
            it[:] = 0
        s_i, s_c, s_s, a_x, a_y = st[0], st[1], st[2], st[3], st[4]
        a_n, a_head, full = it[0], it[1], it[2] != 0
        max_x, min_x, max_y, min_y = st[5], st[6], st[7], st[8]
        slot = k_base % points  # the history's slot of tick ka: the running sums of tick ka - points, then ka's
        for k in range(K):
            ka = k_base + k
            fx, fy, fz = force[r, k, 0], force[r, k, 1], force[r, k, 2]
            if align_lo <= ka < align_hi:
                if a_n == points:
                    a_x -= ring_r[0, a_head]
                    a_y -= ring_r[1, a_head]
                else:
                    a_n += 1
                ring_r[0, a_head], ring_r[1, a_head] = fx, fy
                a_x += fx
                a_y += fy
                a_head = (a_head + 1) % points
                if a_n == points:
                    mx, my = a_x / points, a_y / points
                    if not full:
                        max_x, min_x, max_y, min_y, full = mx, mx, my, my, True
                    else:
                        max_x, min_x = max(max_x, mx), min(min_x, mx)
                        max_y, min_y = max(max_y, my), min(min_y, my)
            elif full:
                fx, fy = fx - 0.5 * (max_x + min_x), fy - 0.5 * (max_y + min_y)
            psi = yaw_rad[r, k]
            if ka > 0:
                prev = yaw_rad[r, k - 1] if k > 0 else st[9]
                psi = prev + 0.5 * (mod_two_pi(psi - prev + math.pi) - math.pi)
            h = math.sqrt(fx * fx + fy * fy)  # eq 1.2 as written (survey_resolution.resolve: not hypot)
            cos_a, sin_a = _unit_azimuth(fx, fy, h, psi)
            s_i += np.arctan2(h, fz)
            s_c += cos_a
            s_s += sin_a
            w_i, w_c, w_s = s_i, s_c, s_s
            if ka >= points:
                w_i, w_c, w_s = s_i - hist[0, slot], s_c - hist[1, slot], s_s - hist[2, slot]
            hist[0, slot], hist[1, slot], hist[2, slot] = s_i, s_c, s_s
            slot = slot + 1 if slot + 1 < points else 0
            n = min(ka + 1, points)
            inc_out[r, k] = w_i / n
            azi_out[r, k] = mod_two_pi(np.arctan2(w_s / n, w_c / n))
        st[0], st[1], st[2], st[3], st[4] = s_i, s_c, s_s, a_x, a_y
        st[5], st[6], st[7], st[8] = max_x, min_x, max_y, min_y
        if K > 0:
            st[9] = yaw_rad[r, K - 1]
        it[0], it[1], it[2] = a_n, a_head, 1 if full else 0


def fixed_survey_words(config, accel_counts, yaw_raw, samples, a: int, base: int, align: tuple[int, int],
                       points: int, states, inc_out, azi_out) -> tuple[np.ndarray, np.ndarray]:
    """The fixed firmware's survey (:func:`firmware_model.node_survey.fixed_surveys_window`: from the accelerometer
    count sums (R, K, 3) and the yaw words (R, K), CORDIC or float32 as ``config`` builds it) of ticks ``a`` .. K - 1
    of the arrays, the node's ticks ``base`` on (its first: its moving average and alignment ``align`` start there,
    in ``states``), on ranges of realizations; their I and A in radians into ``inc_out[:, a:]``, ``azi_out[:, a:]``
    (:func:`firmware_model.cordic.angle_rad_into`); returns the words (R, K - a) (the survey frames')."""
    R, K = yaw_raw.shape
    inc_raw, azi_raw = np.zeros((R, K - a), np.int64), np.zeros((R, K - a), np.int64)
    n = np.ascontiguousarray(samples[a:])
    lo, hi = align

    def run(r0: int, r1: int) -> None:
        fixed_surveys_window(np.ascontiguousarray(accel_counts[r0:r1, a:]), np.ascontiguousarray(yaw_raw[r0:r1, a:]),
                             n, base, lo, hi, points, config.survey_mode, config.cordic_iterations, states[r0:r1],
                             inc_raw[r0:r1], azi_raw[r0:r1], config.formats.yaw.frac_bits)

    threads.map_chunks(run, R)
    angle_rad_into(inc_raw, inc_out[:, a:])  # survey.inclination_rad / azimuth_rad, in place (same bits)
    angle_rad_into(azi_raw, azi_out[:, a:])
    return inc_raw, azi_raw
