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
    ``inc_out`` and ``azi_out`` (module docstring)."""
    R, K = yaw_rad.shape
    two_pi = 2.0 * math.pi
    sums = np.empty((3, K))  # running sums of I, cos A, sin A
    ring = np.empty((2, points))  # the alignment's moving average of f'_x, f'_y
    for r in range(R):
        s_i = s_c = s_s = 0.0
        a_n, a_head, a_x, a_y, full = 0, 0, 0.0, 0.0, False
        max_x = min_x = max_y = min_y = 0.0
        for k in range(K):
            fx, fy, fz = force[r, k, 0], force[r, k, 1], force[r, k, 2]
            if align_lo <= k < align_hi:
                if a_n == points:
                    a_x -= ring[0, a_head]
                    a_y -= ring[1, a_head]
                else:
                    a_n += 1
                ring[0, a_head], ring[1, a_head] = fx, fy
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
            if k > 0:
                prev = yaw_rad[r, k - 1]
                psi = prev + 0.5 * (mod_two_pi(psi - prev + math.pi) - math.pi)
            h = math.sqrt(fx * fx + fy * fy)  # eq 1.2 as written (survey_resolution.resolve: not hypot)
            cos_a, sin_a = _unit_azimuth(fx, fy, h, psi)
            s_i += np.arctan2(h, fz)
            s_c += cos_a
            s_s += sin_a
            sums[0, k], sums[1, k], sums[2, k] = s_i, s_c, s_s
            w_i, w_c, w_s = s_i, s_c, s_s
            if k >= points:
                w_i, w_c, w_s = s_i - sums[0, k - points], s_c - sums[1, k - points], s_s - sums[2, k - points]
            n = min(k + 1, points)
            inc_out[r, k] = w_i / n
            azi_out[r, k] = mod_two_pi(np.arctan2(w_s / n, w_c / n))
