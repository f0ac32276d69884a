"""Survey resolution and the firmware's moving-average filter.

Resolution of the accelerometer vector by the estimated yaw into inclination, toolface and azimuth (thesis
eqs 1.1-1.3, reconstructed in the thesis digest 1.2):
    (1.1) f = Rz(psi) f'
    (1.2) I = atan2(sqrt(f_x^2 + f_y^2), f_z)
    (1.3) A = atan2(f_y, f_x) mod 2 pi = tau' + psi,   tau' = atan2(f'_y, f'_x)
so a yaw error becomes the same azimuth error and inclination does not depend on yaw.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Survey:
    """One resolved survey (rad): inclination I, sensor-frame toolface tau' and azimuth A, same shapes."""

    inclination_rad: np.ndarray
    toolface_rad: np.ndarray
    azimuth_rad: np.ndarray


def resolve(specific_force_sensor: np.ndarray, yaw_rad: np.ndarray) -> Survey:
    """Eqs 1.1-1.3: I = atan2(|f_xy|, f_z) (rotation by psi leaves |f_xy| unchanged), tau' = atan2(f'_y, f'_x),
    A = (tau' + psi) mod 2 pi, which equals atan2(f_y, f_x) of the rotated vector f = Rz(psi) f'.  |f_xy| =
    sqrt(f_x^2 + f_y^2) as eq 1.2 writes it (and the firmware's float survey computes it), not hypot: the same
    value to an ulp for any specific force (hypot only guards against overflow and underflow at magnitudes near
    1e+-154), and ~15 % of the compiled surveys' time less (:mod:`nodesim.chain.compiled.surveys` computes this)."""
    f = np.asarray(specific_force_sensor, dtype=float)
    fx_s, fy_s, fz = f[..., 0], f[..., 1], f[..., 2]
    toolface = np.arctan2(fy_s, fx_s)
    inclination = np.arctan2(np.sqrt(fx_s * fx_s + fy_s * fy_s), fz)
    azimuth = np.remainder(toolface + yaw_rad, 2.0 * math.pi)
    return Survey(inclination, np.remainder(toolface, 2.0 * math.pi), azimuth)


def resolve_survey(specific_force_sensor: np.ndarray, yaw_rad: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Inclination and azimuth (rad) from sensor-frame specific force (..., 3) and yaw (...)."""
    s = resolve(specific_force_sensor, yaw_rad)
    return s.inclination_rad, s.azimuth_rad


def trailing_moving_average(x: np.ndarray, points: int, axis: int = -1) -> np.ndarray:
    """N-point trailing moving average along ``axis`` (the firmware MAF; the first N-1 outputs average what
    has arrived so far, as a ring buffer that is filling up does): :class:`TrailingAverage` of the whole series."""
    x = np.moveaxis(np.asarray(x, float), axis, -1)
    return np.moveaxis(TrailingAverage(points).add(x), -1, axis)


def circular_moving_average(angle_rad: np.ndarray, points: int, axis: int = -1) -> np.ndarray:
    """Moving average of an angle through its unit vector, so 359 deg and 1 deg average to 0 deg."""
    return np.moveaxis(CircularAverage(points).add(np.moveaxis(np.asarray(angle_rad, float), axis, -1)), -1, axis)


class TrailingAverage:
    """The N-point trailing moving average of a series given in consecutive pieces along the last axis (..., n):
    out_k = (S_k - S_(k-N)) / min(k + 1, N) with S the prefix sums (S_k alone for k < N), numpy's cumsum adding in
    order, the last prefix sum of the piece before carried in (and its last N kept): pieces give the bits of the
    whole series at once."""

    def __init__(self, points: int):
        self.points, self.seen = points, 0
        self.tail = None  # (..., min(seen, points)): the last prefix sums

    def add(self, x: np.ndarray) -> np.ndarray:
        n, p = x.shape[-1], self.points
        tail = np.zeros(x.shape[:-1] + (0,)) if self.tail is None else self.tail
        m = tail.shape[-1]
        csum = np.cumsum(np.concatenate([tail[..., -1:], x], axis=-1), axis=-1)[..., 1:] if m else np.cumsum(x, axis=-1)
        k = self.seen + np.arange(n)  # the series' indices of this piece
        known = np.concatenate([tail, csum], axis=-1)  # the prefix sums from index seen - m on
        out = csum.copy()
        late = k >= p
        out[..., late] = csum[..., late] - known[..., k[late] - p - (self.seen - m)]
        out /= np.minimum(k + 1, p)
        self.tail, self.seen = known[..., -p:], self.seen + n
        return out


class CircularAverage:
    """:func:`circular_moving_average` of an angle series given in consecutive pieces (:class:`TrailingAverage` of
    its cosine and sine)."""

    def __init__(self, points: int):
        self.cos, self.sin = TrailingAverage(points), TrailingAverage(points)

    def add(self, angle_rad: np.ndarray) -> np.ndarray:
        c = self.cos.add(np.cos(angle_rad))
        s = self.sin.add(np.sin(angle_rad))
        return np.remainder(np.arctan2(s, c), 2.0 * math.pi)
