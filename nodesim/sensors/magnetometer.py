"""Magnetometer triad and geomagnetic reference: a conventional magnetic survey tool as a baseline.

Frames (thesis digest 1.2): navigation frame NEU (north, east, up); the tube axis z_b points up-hole.
For a hole of inclination I and azimuth A (descending toward A) the high-side frame is

    z_h = (-sinI cosA, -sinI sinA, cosI)   (up-hole)        x_h = (cosI cosA, cosI sinA, sinI)   (high side)
    y_h = z_h x x_h = (-sinA, cosA, 0)

and the body axes are x_h, y_h rotated about z_h by the sensor toolface tau' = A - psi (psi = yaw from
reference north), so that the specific force is f_b = g (sinI cos tau', sinI sin tau', cosI): exactly the
model of :func:`nodesim.sensors.sample_truth.sensor_force` and the inverse of the firmware's survey resolution (eqs
1.1-1.3).  The geomagnetic field with total intensity F, dip D (positive down) and declination delta is
B_NEU = F (cosD cos delta, cosD sin delta, -sinD).

Magnetometer output (per axis): m = (1 + s) B_b + b + w, with white noise of sigma per sample.

Magnetic azimuth from accelerometer and magnetometer (derived here from the frames above): with
(m1, m2, m3) the field in the high-side frame, the horizontal field direction is at A + atan2(m2, m1 cosI -
m3 sinI) from true north, and it must equal delta, so  A = delta - atan2(m2, m1 cosI - m3 sinI).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from nodesim.errors import NodesimError
from nodesim.units import G0_M_S2


@dataclass(frozen=True)
class GeomagneticReference:
    """Local geomagnetic field: total intensity (nT), dip (deg, positive down) and declination (deg, east)."""

    total_field_nt: float = 49_000.0
    dip_deg: float = 67.0
    declination_deg: float = 3.0

    def __post_init__(self):
        if not (math.isfinite(self.total_field_nt) and self.total_field_nt > 0.0):
            raise NodesimError(f"geomagnetic reference: total_field_nt = {self.total_field_nt} must be > 0")
        if not -90.0 <= self.dip_deg <= 90.0:
            raise NodesimError(f"geomagnetic reference: dip_deg = {self.dip_deg} must lie in [-90, 90]")
        if not -180.0 <= self.declination_deg <= 180.0:
            raise NodesimError(f"geomagnetic reference: declination_deg = {self.declination_deg} must lie in [-180, 180]")

    def field_neu_t(self) -> np.ndarray:
        """Field vector in NEU (tesla)."""
        f = self.total_field_nt * 1e-9
        d, dec = math.radians(self.dip_deg), math.radians(self.declination_deg)
        return np.array([f * math.cos(d) * math.cos(dec), f * math.cos(d) * math.sin(dec), -f * math.sin(d)])


def body_to_neu(inclination_rad, azimuth_rad, yaw_rad) -> np.ndarray:
    """Rotation matrices C (..., 3, 3) whose columns are the body axes in NEU (see module doc)."""
    inc, azi, yaw = np.broadcast_arrays(*(np.asarray(x, dtype=float) for x in (inclination_rad, azimuth_rad, yaw_rad)))
    si, ci, sa, ca = np.sin(inc), np.cos(inc), np.sin(azi), np.cos(azi)
    zero = np.zeros_like(inc)
    x_h = np.stack([ci * ca, ci * sa, si], axis=-1)
    y_h = np.stack([-sa, ca, zero], axis=-1)
    z_h = np.stack([-si * ca, -si * sa, ci], axis=-1)
    tau = azi - yaw  # sensor toolface: body x is x_h rotated by -tau about z_h
    ct, st = np.cos(tau)[..., None], np.sin(tau)[..., None]
    x_b = ct * x_h - st * y_h
    y_b = st * x_h + ct * y_h
    return np.stack([x_b, y_b, z_h], axis=-1)


def specific_force_body(inclination_rad, azimuth_rad, yaw_rad) -> np.ndarray:
    """Noise-free specific force in the body frame (m/s^2): C^T (0, 0, g)."""
    c = body_to_neu(inclination_rad, azimuth_rad, yaw_rad)
    return G0_M_S2 * c[..., 2, :]


def field_body(reference: GeomagneticReference, inclination_rad, azimuth_rad, yaw_rad) -> np.ndarray:
    """Noise-free geomagnetic field in the body frame (tesla): C^T B_NEU."""
    c = body_to_neu(inclination_rad, azimuth_rad, yaw_rad)
    return np.einsum("...ji,j->...i", c, reference.field_neu_t())


@dataclass(frozen=True)
class MagnetometerModel:
    """Per-axis scale error and bias, white noise per sample (tesla)."""

    scale_error: tuple[float, float, float] = (0.0, 0.0, 0.0)
    bias_t: tuple[float, float, float] = (0.0, 0.0, 0.0)
    noise_sigma_t: float = 0.0

    def __post_init__(self):
        if not (math.isfinite(self.noise_sigma_t) and self.noise_sigma_t >= 0.0):
            raise NodesimError(f"magnetometer: noise_sigma_t = {self.noise_sigma_t} must be >= 0")
        if any(not math.isfinite(s) or s <= -1.0 for s in self.scale_error):
            raise NodesimError(f"magnetometer: scale_error = {self.scale_error} must be finite and > -1 per axis")
        if any(not math.isfinite(b) for b in self.bias_t):
            raise NodesimError(f"magnetometer: bias_t = {self.bias_t} must be finite")

    def measure(self, field_body_t, rng: np.random.Generator) -> np.ndarray:
        b = np.asarray(field_body_t, dtype=float)
        return (1.0 + np.asarray(self.scale_error)) * b + np.asarray(self.bias_t) + self.noise_sigma_t * rng.standard_normal(b.shape)


def magnetic_survey(specific_force, field, declination_deg: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Inclination and true azimuth (rad, azimuth in [0, 2 pi)) from body-frame accelerometer and magnetometer.

    Tilt from f (I = atan2(|f_xy|, f_z), high side along f_xy), then the azimuth formula of the module doc.
    """
    f = np.asarray(specific_force, dtype=float)
    m = np.asarray(field, dtype=float)
    fxy = np.hypot(f[..., 0], f[..., 1])
    inc = np.arctan2(fxy, f[..., 2])
    tau = np.arctan2(f[..., 1], f[..., 0])  # high side angle in the body frame (sensor toolface)
    ct, st = np.cos(tau), np.sin(tau)
    m1 = ct * m[..., 0] + st * m[..., 1]
    m2 = -st * m[..., 0] + ct * m[..., 1]
    m3 = m[..., 2]
    azi = math.radians(declination_deg) - np.arctan2(m2, m1 * np.cos(inc) - m3 * np.sin(inc))
    return inc, np.remainder(azi, 2.0 * math.pi)
