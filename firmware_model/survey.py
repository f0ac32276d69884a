"""Survey resolution and the firmware's moving-average filter.

Resolution of the accelerometer vector by the estimated yaw (thesis eqs 1.1-1.3, reconstructed in the
thesis digest 1.2):
    (1.1) f = Rz(psi) f'
    (1.2) I = atan2(sqrt(f_x^2 + f_y^2), f_z)
    (1.3) A = atan2(f_y, f_x) mod 2 pi = tau' + psi,   tau' = atan2(f'_y, f'_x)
so a yaw error becomes the same azimuth error and inclination does not depend on yaw.
"""

from __future__ import annotations

import math

import numpy as np


def resolve_survey(specific_force_sensor: np.ndarray, yaw_rad: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Inclination and azimuth (rad) from sensor-frame specific force (..., 3) and yaw (...)."""
    fx_s, fy_s, fz = specific_force_sensor[..., 0], specific_force_sensor[..., 1], specific_force_sensor[..., 2]
    c, s = np.cos(yaw_rad), np.sin(yaw_rad)
    fx = fx_s * c - fy_s * s
    fy = fx_s * s + fy_s * c
    inclination = np.arctan2(np.hypot(fx, fy), fz)
    azimuth = np.remainder(np.arctan2(fy, fx), 2.0 * math.pi)
    return inclination, azimuth


def trailing_moving_average(x: np.ndarray, points: int, axis: int = -1) -> np.ndarray:
    """N-point trailing moving average along ``axis`` (the firmware MAF; the first N-1 outputs average what
    has arrived so far, as a ring buffer that is filling up does)."""
    x = np.moveaxis(np.asarray(x, float), axis, -1)
    csum = np.cumsum(x, axis=-1)
    out = csum.copy()
    out[..., points:] = csum[..., points:] - csum[..., :-points]
    counts = np.minimum(np.arange(1, x.shape[-1] + 1), points)
    return np.moveaxis(out / counts, -1, axis)


def circular_moving_average(angle_rad: np.ndarray, points: int, axis: int = -1) -> np.ndarray:
    """Moving average of an angle through its unit vector, so 359 deg and 1 deg average to 0 deg."""
    c = trailing_moving_average(np.cos(angle_rad), points, axis)
    s = trailing_moving_average(np.sin(angle_rad), points, axis)
    return np.remainder(np.arctan2(s, c), 2.0 * math.pi)
