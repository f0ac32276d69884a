"""Magnetic surveys: (toolface, inclination, azimuth) <-> accelerometer and magnetometer triads.

Tool frame of the MSA theses (HV Fig 1-2, SV Fig 2; digest section 1): x = high side rotated by the
toolface T, y = high-side-right rotated by T, z = downhole.  The readings are the gravity vector G
(g = 1, pointing down) and the field B (uT), both in that frame (HV eq 3.6 with the By typo corrected,
SV eq 2)::

    Gx = -cosT sinI      Gy = sinT sinI      Gz = cosI
    Bx = Bh( cosT cosI cosA - sinT sinA) - Bv cosT sinI
    By = Bh(-sinT cosI cosA - cosT sinA) + Bv sinT sinI
    Bz = Bh sinI cosA + Bv cosI                        (Bh = B cos dip, Bv = B sin dip)

The forward model is not a second magnetometer model: it is the body frame of
:mod:`nodesim.sensors.magnetometer` (z up-hole, sensor toolface tau' = A - yaw) with z reversed, i.e.
tool = (x_b, y_b, -z_b), with T = -tau' (yaw = A + T) and G = -f/g (gravity, not specific force).
Declination is zero: every azimuth here is magnetic (HV/SV leave declination out of scope).

Inverse (HV eqs 3.7-3.9, digest section 3), with atan2 everywhere::

    T = atan2(Gy, -Gx)          I = atan2(sqrt(Gx^2 + Gy^2), Gz)
    A = atan2(-(Bx sinT + By cosT), (Bx cosT - By sinT) cosI + Bz sinI)   wrapped to [0, 360)
    B = |B|                     dip = 90 deg - acos(G.B / (|G||B|))

Sensor errors (HV 3.1-3.2): B_m = s * B_c + b (+ noise); correction B = (B_m - b) / s.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nodesim.errors import NodesimError
from nodesim.sensors.magnetometer import GeomagneticReference, field_body, specific_force_body
from nodesim.units import DEG, G0_M_S2

TOOL_FROM_BODY = np.array([1.0, 1.0, -1.0])
"""Tool axes (HS+T, HSR+T, downhole) = body axes (x_b, y_b, -z_b) of :mod:`nodesim.sensors.magnetometer`."""

UT_PER_T = 1e6


@dataclass(frozen=True)
class FieldReference:
    """Geomagnetic reference of the MSA theses: total field ``b_total_ut`` (uT) and dip ``dip_deg`` (positive down)."""

    b_total_ut: float
    dip_deg: float

    def __post_init__(self):
        if not (np.isfinite(self.b_total_ut) and self.b_total_ut > 0.0):
            raise NodesimError(f"field reference: b_total_ut = {self.b_total_ut} must be a finite number > 0")
        if not (np.isfinite(self.dip_deg) and -90.0 < self.dip_deg < 90.0):
            raise NodesimError(f"field reference: dip_deg = {self.dip_deg} must lie in (-90, 90)")

    @property
    def bh_ut(self) -> float:
        return float(self.b_total_ut * np.cos(self.dip_deg * DEG))

    @property
    def bv_ut(self) -> float:
        return float(self.b_total_ut * np.sin(self.dip_deg * DEG))

    def geomagnetic(self) -> GeomagneticReference:
        """The sensor package's reference (nT, declination 0: magnetic azimuths)."""
        return GeomagneticReference(total_field_nt=self.b_total_ut * 1e3, dip_deg=self.dip_deg, declination_deg=0.0)


@dataclass(frozen=True, eq=False)
class MagneticSurvey:
    """Angles from triads (radians; azimuth magnetic in [0, 2 pi)), total field (uT) and dip (rad)."""

    toolface_rad: np.ndarray
    inc_rad: np.ndarray
    azi_rad: np.ndarray
    b_total_ut: np.ndarray
    dip_rad: np.ndarray


def tool_readings(toolface_deg, inc_deg, azi_deg, reference: FieldReference) -> tuple[np.ndarray, np.ndarray]:
    """Clean tool-frame triads (G with g = 1, B in uT), each shape (..., 3), for surveys given in degrees."""
    t, i, a = np.broadcast_arrays(*(np.asarray(x, dtype=float) * DEG for x in (toolface_deg, inc_deg, azi_deg)))
    for name, arr in (("toolface_deg", t), ("inc_deg", i), ("azi_deg", a)):
        bad = np.flatnonzero(~np.isfinite(arr.ravel()))
        if bad.size:
            raise NodesimError(f"magnetic survey: station {bad[0] + 1}: {name} is not a finite number")
    yaw = a + t  # sensor toolface tau' = A - yaw = -T (nodesim.sensors.magnetometer)
    g = -specific_force_body(i, a, yaw) / G0_M_S2 * TOOL_FROM_BODY
    b = field_body(reference.geomagnetic(), i, a, yaw) * UT_PER_T * TOOL_FROM_BODY
    return g, b


def check_triads(g, b, where: str = "magnetic survey") -> tuple[np.ndarray, np.ndarray]:
    """Validate triads (..., 3): finite, non-zero gravity and field; name the first bad station."""
    g = np.asarray(g, dtype=float)
    b = np.asarray(b, dtype=float)
    if g.shape[-1:] != (3,) or b.shape[-1:] != (3,) or g.shape != b.shape:
        raise NodesimError(f"{where}: accelerometer {g.shape} and magnetometer {b.shape} must both be (..., 3)")
    for name, arr in (("accelerometer", g), ("magnetometer", b)):
        flat = arr.reshape(-1, 3)
        bad = np.flatnonzero(~np.isfinite(flat).all(axis=1))
        if bad.size:
            raise NodesimError(f"{where}: station {bad[0] + 1}: {name} triad {flat[bad[0]].tolist()} is not finite")
        bad = np.flatnonzero(np.linalg.norm(flat, axis=1) == 0.0)
        if bad.size:
            raise NodesimError(f"{where}: station {bad[0] + 1}: {name} triad is zero; a survey needs a non-zero vector")
    return g, b


def survey_from_readings(g, b, check: bool = True) -> MagneticSurvey:
    """Toolface, inclination, magnetic azimuth, total field and dip from tool-frame triads (HV 3.7-3.9)."""
    if check:
        g, b = check_triads(g, b)
    gx, gy, gz = g[..., 0], g[..., 1], g[..., 2]
    bx, by, bz = b[..., 0], b[..., 1], b[..., 2]
    tf = np.arctan2(gy, -gx)
    inc = np.arctan2(np.hypot(gx, gy), gz)
    st, ct = np.sin(tf), np.cos(tf)
    bhsr = bx * st + by * ct
    bhs = bx * ct - by * st
    azi = np.remainder(np.arctan2(-bhsr, bhs * np.cos(inc) + bz * np.sin(inc)), 2.0 * np.pi)
    btot = np.linalg.norm(b, axis=-1)
    cosang = np.sum(g * b, axis=-1) / (np.linalg.norm(g, axis=-1) * btot)
    dip = 0.5 * np.pi - np.arccos(np.clip(cosang, -1.0, 1.0))
    return MagneticSurvey(np.remainder(tf, 2.0 * np.pi), inc, azi, btot, dip)


def params_array(scale, bias_ut) -> np.ndarray:
    """theta = (b_x, b_y, b_z, s_x, s_y, s_z) (HV ordering of the MSA parameters), shape (..., 6)."""
    s = np.asarray(scale, dtype=float)
    b = np.asarray(bias_ut, dtype=float)
    return np.concatenate(np.broadcast_arrays(b, s), axis=-1)


def apply_errors(b_clean_ut, theta) -> np.ndarray:
    """Measured field without noise, B_m = s * B_c + b (HV 3.1); theta (..., 6) broadcasts over stations."""
    th = np.asarray(theta, dtype=float)[..., None, :]
    return th[..., 3:] * np.asarray(b_clean_ut, dtype=float) + th[..., :3]


def correct(b_measured_ut, theta) -> np.ndarray:
    """Corrected field B = (B_m - b) / s (HV 3.2); theta (..., 6) broadcasts over the station axis."""
    th = np.asarray(theta, dtype=float)[..., None, :]
    return (np.asarray(b_measured_ut, dtype=float) - th[..., :3]) / th[..., 3:]
