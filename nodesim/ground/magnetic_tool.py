"""A conventional magnetic MWD survey tool for simulation runs: attitude -> triads -> surveys (+/- MSA).

The pure-model piece a scenario uses to compare the chain's azimuth errors with a magnetic MWD tool.
Inputs are the true attitude of each survey station in the sensor package's frame (inclination, azimuth,
yaw of :func:`nodesim.sensors.magnetometer.body_to_neu`) and the sensor models of that package
(:class:`GeomagneticReference`, :class:`MagnetometerModel`); nothing here is a second sensor model.

Magnetic interference (ISCWSA, as quoted in the drill-string thesis sec 4.2.4, Fig 4.23: "of the order of
0.25 deg + 0.6 deg x sinI x sinA"): per run one draw e1, e2 ~ N(0, 1) gives

* an axial drill-string field B_axial = e1 * 0.6 deg * B_h along body z (up-hole): to first order it turns
  the azimuth by +B_axial sinI sinA / B_h (the ISCWSA MBZ/AMIL weighting, written for z downhole with the
  opposite sign), i.e. e1 * 0.6 deg sinI sinA; MSA can estimate it because it is a bias on one sensor axis;
* a residual azimuth offset e2 * 0.25 deg that no sensor calibration removes.

:func:`interference_sigma_deg` gives the quoted 1-sigma term itself, e.g. as the survey's per-station
``sigma_azi_deg`` for the ISCWSA propagation (:func:`nodesim.ground.survey.make_survey`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nodesim.errors import NodesimError
from nodesim.ground.magnetic_survey import FieldReference
from nodesim.ground.msa import MsaResult, msa
from nodesim.sensors.magnetometer import (
    GeomagneticReference,
    MagnetometerModel,
    field_body,
    magnetic_survey,
    specific_force_body,
)
from nodesim.units import DEG

INTERFERENCE_CONST_DEG = 0.25
INTERFERENCE_AXIAL_DEG = 0.6
T_PER_UT = 1e-6


def interference_sigma_deg(inc_rad, azi_rad) -> np.ndarray:
    """ISCWSA magnetic-interference azimuth term 0.25 + 0.6 |sinI sinA| deg (magnetic azimuth A)."""
    return INTERFERENCE_CONST_DEG + INTERFERENCE_AXIAL_DEG * np.abs(np.sin(inc_rad) * np.sin(azi_rad))


@dataclass(frozen=True, eq=False)
class ToolSurveys:
    """Per-station inclination and true azimuth [rad] without and (if run) with MSA, and the MSA result."""

    inc_rad: np.ndarray
    azi_rad: np.ndarray
    azi_msa_rad: np.ndarray | None
    msa: MsaResult | None
    sigma_azi_deg: np.ndarray


@dataclass(frozen=True)
class MagneticMwdTool:
    """Accelerometer + magnetometer survey tool; ``use_msa`` runs MSA over the stations of the run."""

    reference: GeomagneticReference = GeomagneticReference()
    magnetometer: MagnetometerModel = MagnetometerModel()
    accel_noise_m_s2: float = 0.0
    interference: bool = True
    use_msa: bool = True
    msa_starts: int = 4

    def __post_init__(self):
        if not (np.isfinite(self.accel_noise_m_s2) and self.accel_noise_m_s2 >= 0.0):
            raise NodesimError(f"magnetic tool: accel_noise_m_s2 = {self.accel_noise_m_s2} must be >= 0")
        if self.msa_starts < 1:
            raise NodesimError(f"magnetic tool: msa_starts = {self.msa_starts} must be >= 1")

    def readings(self, inc_rad, azi_rad, yaw_rad, rng: np.random.Generator):
        """Body-frame specific force (m/s^2) and magnetometer output (T) per station, with interference.

        Returns (f, m, residual_azimuth_offset_rad)."""
        inc, azi, yaw = np.broadcast_arrays(*(np.atleast_1d(np.asarray(x, dtype=float)) for x in (inc_rad, azi_rad, yaw_rad)))
        for name, arr in (("inclination", inc), ("azimuth", azi), ("yaw", yaw)):
            bad = np.flatnonzero(~np.isfinite(arr))
            if bad.size:
                raise NodesimError(f"magnetic tool: station {bad[0] + 1}: {name} is not finite")
        e1, e2 = rng.standard_normal(2)  # interference draws first (drawn even when off: same stream)
        f = specific_force_body(inc, azi, yaw)
        f = f + self.accel_noise_m_s2 * rng.standard_normal(f.shape)
        b = field_body(self.reference, inc, azi, yaw)
        offset = 0.0
        if self.interference:
            bh_t = self.reference.total_field_nt * 1e-9 * np.cos(self.reference.dip_deg * DEG)
            b = b.copy()
            b[..., 2] += e1 * INTERFERENCE_AXIAL_DEG * DEG * bh_t
            offset = e2 * INTERFERENCE_CONST_DEG * DEG
        return f, self.magnetometer.measure(b, rng), offset

    def survey(self, inc_rad, azi_rad, yaw_rad, rng: np.random.Generator) -> ToolSurveys:
        """Surveys of all stations of a run: inclination, azimuth without MSA and (``use_msa``) with MSA."""
        f, m, offset = self.readings(inc_rad, azi_rad, yaw_rad, rng)
        dec = self.reference.declination_deg
        inc, azi = magnetic_survey(f, m, dec)
        azi_msa, result = None, None
        if self.use_msa:
            ref = FieldReference(self.reference.total_field_nt * 1e-3, self.reference.dip_deg)
            # MSA is frame-agnostic: gravity direction -f and the field, both in body axes (uT)
            result = msa(-f, m / T_PER_UT, ref, n_starts=self.msa_starts)
            theta = result.theta
            corrected = (m / T_PER_UT - theta[:3]) / theta[3:]
            azi_msa = np.remainder(magnetic_survey(f, corrected, dec)[1] + offset, 2.0 * np.pi)
        sigma = interference_sigma_deg(inc, azi - dec * DEG) if self.interference else np.zeros_like(inc)
        return ToolSurveys(inc, np.remainder(azi + offset, 2.0 * np.pi), azi_msa, result, sigma)
