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
from functools import cached_property

import numpy as np
from numba import njit

from nodesim.errors import NodesimError
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

    def rate_profile(self) -> "RateProfile":
        """The same motion as a general :class:`RateProfile` (steps in rate, no ramps)."""
        segs = [RateSegment(ph.start_s, ph.end_s, ph.rate_rad_s, ph.rate_rad_s) for ph in self.phases]
        return RateProfile(tuple(segs))


@dataclass(frozen=True)
class RateSegment:
    """Rotation rate changing linearly from ``rate0_rad_s`` at ``start_s`` to ``rate1_rad_s`` at ``end_s``."""

    start_s: float
    end_s: float
    rate0_rad_s: float
    rate1_rad_s: float


@dataclass(frozen=True)
class RateProfile:
    """Piecewise-linear rotation rate about the string axis (zero outside the segments); exact angle.

    Segments are sorted and do not overlap; gaps are stationary.  The angle is the exact integral of the
    rate (piecewise quadratic), so a ramp from 0 to w over T turns w T / 2.
    """

    segments: tuple[RateSegment, ...]

    def __post_init__(self):
        prev_end = -math.inf
        for i, s in enumerate(self.segments):
            if not (math.isfinite(s.start_s) and math.isfinite(s.end_s) and s.end_s > s.start_s):
                raise NodesimError(f"rate profile: segment {i} has end_s ({s.end_s}) <= start_s ({s.start_s})")
            if s.start_s < prev_end:
                raise NodesimError(f"rate profile: segment {i} starts at {s.start_s} s before the previous one ends ({prev_end} s)")
            prev_end = s.end_s

    @classmethod
    def from_phases(cls, phases, t0_s: float = 0.0) -> "RateProfile":
        """Build from consecutive phases ``(kind, duration_s, rate_rad_s)``, starting at rest at ``t0_s``.

        kinds: ``"hold"`` (keep the current rate; ``rate_rad_s`` ignored), ``"ramp"`` (linear to
        ``rate_rad_s``), ``"constant"`` (jump to ``rate_rad_s`` and hold), ``"stop"`` (jump to 0, stay for
        the duration).
        """
        t, rate, segs = t0_s, 0.0, []
        for i, (kind, duration, target) in enumerate(phases):
            if not duration > 0.0:
                raise NodesimError(f"rate profile: phase {i} ({kind}) duration_s = {duration} must be > 0")
            if kind == "hold":
                r0, r1 = rate, rate
            elif kind == "ramp":
                r0, r1 = rate, target
            elif kind == "constant":
                r0, r1 = target, target
            elif kind == "stop":
                r0, r1 = 0.0, 0.0
            else:
                raise NodesimError(f"rate profile: phase {i} kind {kind!r} unknown (allowed: hold, ramp, constant, stop)")
            if r0 != 0.0 or r1 != 0.0:
                segs.append(RateSegment(t, t + duration, r0, r1))
            t, rate = t + duration, r1
        return cls(tuple(segs))

    @cached_property
    def _segment_arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(starts, ends, start rates, end rates, angle turned before each segment), computed once per profile."""
        s = np.array([g.start_s for g in self.segments])
        e = np.array([g.end_s for g in self.segments])
        r0 = np.array([g.rate0_rad_s for g in self.segments])
        r1 = np.array([g.rate1_rad_s for g in self.segments])
        full = 0.5 * (r0 + r1) * (e - s)
        before = np.concatenate([[0.0], np.cumsum(full)])
        for a in (s, e, r0, r1, before):
            a.setflags(write=False)
        return s, e, r0, r1, before

    def rate_rad_s(self, t_s) -> np.ndarray:
        t = np.asarray(t_s, dtype=float)
        if not self.segments:
            return np.zeros_like(t)
        return self._evaluate(t, _RATE)

    def angle_rad(self, t_s) -> np.ndarray:
        """Integral of the rate from -inf (the profile starts at rest with angle 0)."""
        t = np.asarray(t_s, dtype=float)
        if not self.segments:
            return np.zeros_like(t)
        return self._evaluate(t, _ANGLE)

    def _evaluate(self, t: np.ndarray, what: int) -> np.ndarray:
        """:func:`_profile_values` of ``t`` (any shape; the profile has segments)."""
        flat = np.ascontiguousarray(t, dtype=float).ravel()
        out = np.empty(flat.size)
        _profile_values(*self._segment_arrays, flat, what, out)
        return out.reshape(t.shape)


_RATE, _ANGLE = 0, 1


@njit(cache=True, nogil=True)
def _profile_values(s, e, r0, r1, before, t, what, out) -> None:
    """``out[j]``: the rate (``what`` = _RATE) or the angle (_ANGLE) of the profile with segment arrays
    (:attr:`RateProfile._segment_arrays`) at ``t[j]``, the arithmetic of the vectorised form it replaced, operation
    for operation (so the same bits):

        i = clip(searchsorted(s, t, "right") - 1, 0, S - 1)
        rate  = r0_i + (r1_i - r0_i) (t - s_i) / (e_i - s_i)  where s_i <= t < e_i, else 0
        angle = before_i + r0_i dt + 0.5 slope_i dt dt,  dt = clip(t - s_i, 0, e_i - s_i),
                slope_i = (r1_i - r0_i) / (e_i - s_i);  0 where t < s_0

    in one pass without the (K,) temporaries.  The segment index i is found by walking from the previous one
    (the starts are strictly increasing): O(1) per time for the sorted times the chain asks for (a binary search
    per time was most of the cost), and the same i for times in any order."""
    i, m = 0, s.size
    for j in range(t.size):
        x = t[j]
        if s[i] <= x:
            while i + 1 < m and s[i + 1] <= x:
                i += 1
        else:
            while i > 0 and s[i] > x:
                i -= 1
        w = e[i] - s[i]
        if what == _RATE:
            out[j] = r0[i] + (r1[i] - r0[i]) * ((x - s[i]) / w) if s[i] <= x < e[i] else 0.0
        else:
            dt = x - s[i]
            if dt < 0.0:  # np.clip, NaN passing through
                dt = 0.0
            elif dt > w:
                dt = w
            slope = (r1[i] - r0[i]) / w
            out[j] = 0.0 if x < s[0] else before[i] + (r0[i] * dt + 0.5 * slope * dt * dt)
