"""The surveys a chain run reports, resolved and moving-averaged in one compiled pass per node.

For every realization r and tick k (thesis eqs 1.1-1.3, :func:`firmware_model.survey.resolve`):
    tau' = atan2(f'_y, f'_x),  I = atan2(hypot(f'_x, f'_y), f'_z),  A = (tau' + psi) mod 2 pi,
then the firmware's trailing N-point moving average of I and the circular one of A (through cos A and sin A),
the first N - 1 outputs averaging what has arrived (:func:`firmware_model.survey.trailing_moving_average`,
:func:`~firmware_model.survey.circular_moving_average`).  The same operations in the same order as those numpy
functions (running sums as ``cumsum`` forms them, the window as the difference of two of them), without their
temporaries: tests/nodesim/test_chain_surveys.py compares the two.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True, nogil=True)
def averaged_surveys(force: np.ndarray, yaw_rad: np.ndarray, points: int, inc_out: np.ndarray,
                     azi_out: np.ndarray) -> None:
    """``force`` (R, K, 3) sensor-frame specific force, ``yaw_rad`` (R, K) -> moving-averaged inclination and
    azimuth (R, K) [rad] into ``inc_out`` and ``azi_out`` (module docstring)."""
    R, K = yaw_rad.shape
    two_pi = 2.0 * math.pi
    sums = np.empty((3, K))  # running sums of I, cos A, sin A
    for r in range(R):
        s_i = s_c = s_s = 0.0
        for k in range(K):
            fx, fy, fz = force[r, k, 0], force[r, k, 1], force[r, k, 2]
            toolface = np.arctan2(fy, fx)
            azimuth = np.remainder(toolface + yaw_rad[r, k], two_pi)
            s_i += np.arctan2(np.hypot(fx, fy), fz)
            s_c += np.cos(azimuth)
            s_s += np.sin(azimuth)
            sums[0, k], sums[1, k], sums[2, k] = s_i, s_c, s_s
            w_i, w_c, w_s = s_i, s_c, s_s
            if k >= points:
                w_i, w_c, w_s = s_i - sums[0, k - points], s_c - sums[1, k - points], s_s - sums[2, k - points]
            n = min(k + 1, points)
            inc_out[r, k] = w_i / n
            azi_out[r, k] = np.remainder(np.arctan2(w_s / n, w_c / n), two_pi)
