"""True motion of the drill string: the thesis lab rotation profile.

The miniature lab drill string (thesis 4.2.2-4.2.3) sits at a fixed inclination and azimuth and rotates
about its own axis.  The profile is piecewise constant in rate, so the true yaw is piecewise linear:

    static (bias estimation) -> slow calibration rotation -> pause -> fast rotation -> static

Yaw psi is the angle of the body x axis from reference north, positive counter-clockwise seen from
above (thesis digest section 9 item 2).  All quantities are SI inside (rad, rad/s, s).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from nodesim.units import DEG


@dataclass(frozen=True)
class RotationPhase:
    """One constant-rate phase: from ``start_s`` to ``end_s`` at ``rate_rad_s``."""

    name: str
    start_s: float
    end_s: float
    rate_rad_s: float


@dataclass(frozen=True)
class LabRotationProfile:
    """Thesis lab profile with its timings as parameters (defaults: 50 s static, 2 turns at 3.6 deg/s,
    10 s pause, 20 turns at 71 deg/s, static to the end)."""

    inclination_rad: float
    azimuth_rad: float
    stationary_s: float = 50.0
    slow_rate_rad_s: float = 3.6 * DEG
    slow_turns: float = 2.0
    pause_s: float = 10.0
    fast_rate_rad_s: float = 71.0 * DEG
    fast_turns: float = 20.0

    @property
    def phases(self) -> tuple[RotationPhase, ...]:
        """The rotating phases in time order (the gaps between them are static)."""
        slow_end = self.stationary_s + self.slow_turns * 2 * math.pi / self.slow_rate_rad_s
        fast_start = slow_end + self.pause_s
        fast_end = fast_start + self.fast_turns * 2 * math.pi / self.fast_rate_rad_s
        return (
            RotationPhase("slow_rotation", self.stationary_s, slow_end, self.slow_rate_rad_s),
            RotationPhase("fast_rotation", fast_start, fast_end, self.fast_rate_rad_s),
        )

    @property
    def motion_start_s(self) -> float:
        """Time the first rotation starts (end of the static bias window)."""
        return self.stationary_s

    @property
    def rotation_end_s(self) -> float:
        """Time the last rotation stops."""
        return self.phases[-1].end_s

    def rate_rad_s(self, t_s) -> np.ndarray:
        """True rotation rate about the string axis at times ``t_s`` (rad/s)."""
        t = np.asarray(t_s, dtype=float)
        rate = np.zeros_like(t)
        for ph in self.phases:
            rate = np.where((t >= ph.start_s) & (t < ph.end_s), ph.rate_rad_s, rate)
        return rate

    def yaw_rad(self, t_s) -> np.ndarray:
        """True yaw (unwrapped, rad) at times ``t_s``: the integral of :meth:`rate_rad_s` from 0."""
        t = np.asarray(t_s, dtype=float)
        yaw = np.zeros_like(t)
        for ph in self.phases:
            yaw = yaw + ph.rate_rad_s * np.clip(t - ph.start_s, 0.0, ph.end_s - ph.start_s)
        return yaw

    def mean_rate_rad_s(self, t0_s, t1_s) -> np.ndarray:
        """Mean rate over [t0, t1]: what an ideal integrating gyro reports for that interval."""
        t0 = np.asarray(t0_s, dtype=float)
        t1 = np.asarray(t1_s, dtype=float)
        return (self.yaw_rad(t1) - self.yaw_rad(t0)) / (t1 - t0)
