"""Drilling process kinematics: tube insertions along a wellpath, true attitude of every node at any time.

A pure model (no SimPy): the chain simulation consumes it.  The process, per tube length L (default
2 m, the DSM survey spacing, thesis 4.1):

    drill (rotation ramps up, holds, ramps down; the bit advances L at the rate of penetration)
    -> survey stop (string static, every node surveys)
    -> tube insertion (string in the slips, static; a new tube with its node is screwed on at the top)

Tube k (k = 0 at the bit) carries node k at ``node_offset_m`` above its lower end.  Tubes 0 .. M - 1
(``initial_tubes`` = M, default 1) are in the hole at t = 0; node k >= M joins the chain when its insertion
ends.  With the bit at measured depth D(t), node k sits at MD_k(t) = D(t) - k L - node_offset_m (negative =
still above ground, where the attitude of the first station applies).  The bit starts at
D(0) = MD_0 + (M - 1) L (MD_0 the first wellpath station), so the top initial tube sits where tube 0 sits for
M = 1; the programme drills tube M - 1 (the top initial one), stops for its survey, inserts tube M, ... up to
tube N - 1 drilled and surveyed: N - M + 1 drills and survey stops, N - M insertions, so its length is

    T = (N - M + 1) (L / ROP + t_survey) + (N - M) t_insertion.  All tubes turn together (rigid, torsion-free string): the spin about the
tube axis is the same for every node, the string angle theta(t) is the integral of the rate profile.

Yaw of node k (angle of body x from reference north, thesis digest 1.2):
    psi_k(t) = psi_k0 + theta(t) - theta(t_k) + Gamma(MD_k(t)) - Gamma(MD_k(t_k))
where psi_k0 is the mounting yaw at its insertion time t_k and Gamma(s) = int_0^s (1 - cos I) dA is the
geometric twist of a non-spinning frame carried along the path (derived from the body rate of
R = Rz(A) Ry(I) Rz(psi - A): omega_z = psi' - A' (1 - cos I); it vanishes for a vertical or straight hole).
Sensor toolface tau' = A - psi (eq 1.3), z-gyro true rate = theta'(t).

Wellpath stations (MD, inclination, azimuth) are interpolated by minimum curvature: the unit tangent
moves along the great circle between station tangents (slerp), the standard form of thesis App. IV.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from nodesim.errors import NodesimError
from nodesim.motion.rotation import RateProfile
from nodesim.units import DEG

TWIST_STEP_M = 0.05
ATTITUDE_STEP_M = 0.01
AZIMUTH_MARGIN_RAD = 1e-9
"""Distance of the azimuth grid from 0 and 2 pi beyond which :meth:`Wellpath.attitude_along` needs no remainder."""


@dataclass(frozen=True)
class Wellpath:
    """Survey stations: measured depth (m, strictly increasing), inclination and azimuth (rad)."""

    md_m: np.ndarray
    inclination_rad: np.ndarray
    azimuth_rad: np.ndarray

    def __post_init__(self):
        md, inc, azi = (np.asarray(x, dtype=float) for x in (self.md_m, self.inclination_rad, self.azimuth_rad))
        if not (md.ndim == 1 and md.shape == inc.shape == azi.shape and md.size >= 1):
            raise NodesimError(f"wellpath: md, inclination and azimuth must be equal-length 1-D arrays (got {md.shape}, {inc.shape}, {azi.shape})")
        for name, arr in (("md_m", md), ("inclination", inc), ("azimuth", azi)):
            if not np.all(np.isfinite(arr)):
                raise NodesimError(f"wellpath: station {int(np.flatnonzero(~np.isfinite(arr))[0])} has a non-finite {name}")
        if np.any(np.diff(md) <= 0):
            k = int(np.flatnonzero(np.diff(md) <= 0)[0]) + 1
            raise NodesimError(f"wellpath: station {k} MD {md[k]} m is not greater than the previous ({md[k - 1]} m)")
        if np.any((inc < 0) | (inc > math.pi)):
            k = int(np.flatnonzero((inc < 0) | (inc > math.pi))[0])
            raise NodesimError(f"wellpath: station {k} inclination {math.degrees(inc[k]):.3g} deg outside [0, 180] deg")
        object.__setattr__(self, "md_m", md)
        object.__setattr__(self, "inclination_rad", inc)
        object.__setattr__(self, "azimuth_rad", azi)

    @classmethod
    def from_degrees(cls, stations) -> "Wellpath":
        """From rows (MD m, inclination deg, azimuth deg)."""
        a = np.asarray(stations, dtype=float).reshape(-1, 3)
        return cls(a[:, 0], a[:, 1] * DEG, a[:, 2] * DEG)

    @staticmethod
    def _tangent(inc, azi) -> np.ndarray:
        return np.stack([np.sin(inc) * np.cos(azi), np.sin(inc) * np.sin(azi), np.cos(inc)], axis=-1)

    @cached_property
    def _intervals(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Station unit tangents (S, 3), and per interval between stations the angle beta between its end
        tangents and sin(beta) (S - 1,): computed once per wellpath."""
        tangents = self._tangent(self.inclination_rad, self.azimuth_rad)
        t1, t2 = tangents[:-1], tangents[1:]
        beta = np.arccos(np.clip(np.sum(t1 * t2, axis=-1), -1.0, 1.0))
        return tangents, beta, np.sin(beta)

    def attitude_at(self, md_m) -> tuple[np.ndarray, np.ndarray]:
        """(inclination, azimuth) in rad at measured depths (clipped to the station range); on an interval whose two
        stations have one inclination and azimuth (a straight one) exactly theirs, not their round trip through the
        unit tangent (a few ulp off)."""
        md = np.clip(np.asarray(md_m, dtype=float), self.md_m[0], self.md_m[-1])
        if self.md_m.size == 1:
            return np.full_like(md, self.inclination_rad[0]), np.full_like(md, self.azimuth_rad[0])
        k = np.clip(np.searchsorted(self.md_m, md, side="right") - 1, 0, self.md_m.size - 2)
        u = (md - self.md_m[k]) / (self.md_m[k + 1] - self.md_m[k])
        tangents, betas, sines = self._intervals
        t1, t2 = tangents[k], tangents[k + 1]
        beta, sb = betas[k], sines[k]
        small = sb < 1e-12
        w1 = np.where(small, 1.0 - u, np.sin((1.0 - u) * beta) / np.where(small, 1.0, sb))
        w2 = np.where(small, u, np.sin(u * beta) / np.where(small, 1.0, sb))
        t = w1[..., None] * t1 + w2[..., None] * t2
        t /= np.linalg.norm(t, axis=-1, keepdims=True)
        inc = np.arccos(np.clip(t[..., 2], -1.0, 1.0))
        horizontal = np.hypot(t[..., 0], t[..., 1]) > 1e-12
        azi_station = np.where(u < 0.5, self.azimuth_rad[k], self.azimuth_rad[k + 1])
        azi = np.where(horizontal, np.arctan2(t[..., 1], t[..., 0]), azi_station)
        inc_k, azi_k = self.inclination_rad[k], self.azimuth_rad[k]
        straight = (inc_k == self.inclination_rad[k + 1]) & (azi_k == self.azimuth_rad[k + 1])
        return np.where(straight, inc_k, inc), np.remainder(np.where(straight, azi_k, azi), 2.0 * math.pi)

    @cached_property
    def _attitude_grid(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(MD grid, inclination, unwrapped azimuth): :meth:`attitude_at` on a grid of at most ATTITUDE_STEP_M steps
        with every station on it (computed once per wellpath)."""
        parts = [np.linspace(a, b, max(2, int(math.ceil((b - a) / ATTITUDE_STEP_M)) + 1))[:-1]
                 for a, b in zip(self.md_m[:-1], self.md_m[1:])]  # every station a grid point (the kinks)
        grid = np.concatenate(parts + [self.md_m[-1:]])
        inc, azi = self.attitude_at(grid)
        return grid, inc, np.unwrap(azi)

    def attitude_along(self, md_m) -> tuple[np.ndarray, np.ndarray]:
        """(inclination, azimuth) in rad at measured depths, linear between the 1 cm grid points of
        :meth:`attitude_at` (clipped to the station range): the nodes' truth at every sensor sample (a day of 1000
        nodes at 65 Hz is ~5e9 of them; the slerp of :meth:`attitude_at` costs ~70 ns each, this ~5 ns).  On a
        minimum-curvature interval the inclination and azimuth are smooth in MD (the stations, where the curvature
        jumps, are grid points), so the error is h^2/8 max|f''| with h <= 1 cm: measured (tests/nodesim/motion)
        below 3e-9 rad on the field scenario's path and 3e-8 rad on doglegs of ~1 deg/m; an interval passing
        within a degree of vertical (where the inclination has a V and the azimuth swings) up to 1e-5 rad, the
        azimuth error weighted by sin I (what reaches the sensors) likewise.  Both engines and every truth of a
        node (its sensors, its errors) use this one function."""
        md = np.asarray(md_m, dtype=float)
        if self.md_m.size == 1:
            return np.full_like(md, self.inclination_rad[0]), np.full_like(md, self.azimuth_rad[0])
        if self._constant_attitude is not None:  # a straight hole: the interpolations' values, without the searches
            inc0, azi0 = self._constant_attitude
            return _constant_like(md, inc0), _constant_like(md, azi0)
        grid, inc, azi = self._attitude_grid
        a = np.interp(md, grid, azi)
        return np.interp(md, grid, inc), (a if self._azimuth_grid_wrapped else np.remainder(a, 2.0 * math.pi))

    @cached_property
    def _constant_attitude(self) -> tuple[float, float] | None:
        """(I, A) where the attitude grid holds one inclination and one azimuth (a straight hole), else None.  A
        linear interpolation between equal values is that value exactly (slope 0; outside the grid its end values),
        so :meth:`attitude_along` returns it without interpolating: the same bits (tested), ~2 s less CPU for the
        drilling day, whose 1000 nodes ask for their attitude at every tick."""
        _, inc, azi = self._attitude_grid
        if inc.min() != inc.max() or azi.min() != azi.max():
            return None
        a = azi[:1] if self._azimuth_grid_wrapped else np.remainder(azi[:1], 2.0 * math.pi)
        return float(inc[0]), float(a[0])

    @cached_property
    def _azimuth_grid_wrapped(self) -> bool:
        """Whether the unwrapped azimuth grid of :meth:`attitude_along` lies in [AZIMUTH_MARGIN_RAD, 2 pi -
        AZIMUTH_MARGIN_RAD]: then every value interpolated on it is in (0, 2 pi) (a linear interpolation leaves
        its neighbours' range by a few ulp at most), where np.remainder(a, 2 pi) returns a itself (fmod is exact,
        no sign to fix), so the remainder, a third of the cost, can be skipped with the same bits."""
        azi = self._attitude_grid[2]
        return bool(azi.min() >= AZIMUTH_MARGIN_RAD and azi.max() <= 2.0 * math.pi - AZIMUTH_MARGIN_RAD)

    @cached_property
    def _twist_grid(self) -> tuple[np.ndarray, np.ndarray]:
        """(MD grid, Gamma on it): trapezoids of (1 - cos I) dA on a TWIST_STEP_M grid (computed once per wellpath)."""
        n = max(2, int(math.ceil((self.md_m[-1] - self.md_m[0]) / TWIST_STEP_M)) + 1)
        grid = np.linspace(self.md_m[0], self.md_m[-1], n)
        inc, azi = self.attitude_at(grid)
        a = np.unwrap(azi)
        w = 1.0 - np.cos(inc)
        gamma = np.concatenate([[0.0], np.cumsum(0.5 * (w[1:] + w[:-1]) * np.diff(a))])
        return grid, gamma

    def twist_rad(self, md_m) -> np.ndarray:
        """Gamma(MD) = int (1 - cos I) dA from the first station (see module doc), linear on a 5 cm grid."""
        grid, gamma = self._twist_grid
        md = np.asarray(md_m, dtype=float)
        if gamma.min() == gamma.max():  # no twist (a straight hole): the interpolation's value, without the search
            return _constant_like(md, float(gamma[0]))
        return np.interp(md, grid, gamma)


def _constant_like(md: np.ndarray, value: float):
    """What ``np.interp(md, grid, values)`` returns when every one of ``values`` is ``value``: ``value`` for every
    depth (NaN where ``md`` is NaN), a scalar for a scalar ``md``."""
    return np.where(np.isnan(md), md, value)[()]


@dataclass(frozen=True)
class Phase:
    name: str  # "drill", "survey" or "insertion"
    tube: int  # tube being drilled down / surveyed with / inserted
    start_s: float
    end_s: float


@dataclass(frozen=True)
class NodeTruth:
    """True state of nodes at times t: arrays (N nodes, K times) from :meth:`DrillingProcess.truth`, (K,) for one
    node from :meth:`DrillingProcess.node_truth`; NaN where a node is not yet inserted."""

    t_s: np.ndarray
    present: np.ndarray
    md_m: np.ndarray
    inclination_rad: np.ndarray
    azimuth_rad: np.ndarray
    yaw_rad: np.ndarray  # unwrapped
    toolface_rad: np.ndarray  # sensor toolface A - psi, wrapped to [0, 2 pi)
    spin_rate_rad_s: np.ndarray  # (K,) what every z gyro measures


@dataclass(frozen=True)
class DrillingProcess:
    """Drilling with tube insertions along ``wellpath`` (see module doc); SI units, angles in rad."""

    wellpath: Wellpath
    tube_length_m: float = 2.0
    rop_m_s: float = 0.01
    drilling_rate_rad_s: float = 60.0 * DEG
    ramp_s: float = 5.0
    survey_stop_s: float = 30.0
    insertion_s: float = 60.0
    node_offset_m: float = 1.0
    n_tubes: int | None = None
    mount_yaw_rad: tuple[float, ...] | None = None  # per node; default 0
    initial_tubes: int = 1  # tubes 0 .. initial_tubes - 1 in the hole at t = 0

    def __post_init__(self):
        for key in ("tube_length_m", "rop_m_s", "survey_stop_s", "insertion_s"):
            v = getattr(self, key)
            if not (math.isfinite(v) and v > 0.0):
                raise NodesimError(f"drilling: {key} = {v} must be > 0")
        if not (math.isfinite(self.ramp_s) and self.ramp_s >= 0.0):
            raise NodesimError(f"drilling: ramp_s = {self.ramp_s} must be >= 0")
        drill_s = self.tube_length_m / self.rop_m_s
        if 2.0 * self.ramp_s >= drill_s:
            raise NodesimError(
                f"drilling: two ramps of {self.ramp_s} s do not fit in one tube's drilling time {drill_s:.4g} s "
                f"(allowed: ramp_s < {drill_s / 2:.4g})"
            )
        if not 0.0 <= self.node_offset_m <= self.tube_length_m:
            raise NodesimError(f"drilling: node_offset_m = {self.node_offset_m} must lie in [0, tube_length_m]")
        if self.n_tubes is not None and self.n_tubes < 1:
            raise NodesimError(f"drilling: n_tubes = {self.n_tubes} must be >= 1")
        if not (isinstance(self.initial_tubes, numbers.Integral) and 1 <= self.initial_tubes <= self.tubes):
            raise NodesimError(
                f"drilling: initial_tubes = {self.initial_tubes} must be an integer in [1, {self.tubes}] (the tubes drilled)")
        if self.mount_yaw_rad is not None and len(self.mount_yaw_rad) < self.tubes:
            raise NodesimError(f"drilling: mount_yaw_rad has {len(self.mount_yaw_rad)} values, need one per tube ({self.tubes})")

    @property
    def tubes(self) -> int:
        """Number of tubes drilled: n_tubes, or enough to reach the last wellpath station."""
        if self.n_tubes is not None:
            return self.n_tubes
        return max(1, int(math.ceil((self.wellpath.md_m[-1] - self.wellpath.md_m[0]) / self.tube_length_m - 1e-9)))

    @cached_property
    def _phases(self) -> tuple[Phase, ...]:
        out, t = [], 0.0
        drill_s = self.tube_length_m / self.rop_m_s
        for k in range(self.initial_tubes - 1, self.tubes):
            out.append(Phase("drill", k, t, t + drill_s))
            t += drill_s
            out.append(Phase("survey", k, t, t + self.survey_stop_s))
            t += self.survey_stop_s
            if k + 1 < self.tubes:
                out.append(Phase("insertion", k + 1, t, t + self.insertion_s))
                t += self.insertion_s
        return tuple(out)

    def phases(self) -> tuple[Phase, ...]:
        """Drill, survey stop and insertion phases in time order, from tube ``initial_tubes - 1`` on (module doc;
        computed once per process)."""
        return self._phases

    @property
    def duration_s(self) -> float:
        return self._phases[-1].end_s

    @cached_property
    def _insertion_times_s(self) -> np.ndarray:
        t_in = np.concatenate([np.zeros(self.initial_tubes), [p.end_s for p in self._phases if p.name == "insertion"]])
        t_in.setflags(write=False)
        return t_in

    def insertion_times_s(self) -> np.ndarray:
        """Time node k joins: 0 for the initial nodes k < initial_tubes, the end of its tube's insertion otherwise
        (read-only, computed once per process)."""
        return self._insertion_times_s

    def survey_windows_s(self) -> list[tuple[float, float]]:
        return [(p.start_s, p.end_s) for p in self._phases if p.name == "survey"]

    @cached_property
    def _rate_profile(self) -> RateProfile:
        phases, w = [], self.drilling_rate_rad_s
        drill_s = self.tube_length_m / self.rop_m_s
        for p in self._phases:
            if p.name == "drill":
                if self.ramp_s > 0:
                    phases += [("ramp", self.ramp_s, w), ("hold", drill_s - 2 * self.ramp_s, w), ("ramp", self.ramp_s, 0.0)]
                else:
                    phases.append(("constant", drill_s, w))
            else:
                phases.append(("stop", p.end_s - p.start_s, 0.0))
        return RateProfile.from_phases(phases, t0_s=0.0)

    def rate_profile(self) -> RateProfile:
        """Spin of the string: ramps and holds while drilling, zero otherwise (computed once per process)."""
        return self._rate_profile

    @property
    def bit_start_md_m(self) -> float:
        """Bit depth at t = 0: MD_0 + (initial_tubes - 1) L (module doc)."""
        return float(self.wellpath.md_m[0] + (self.initial_tubes - 1) * self.tube_length_m)

    @cached_property
    def _bit_knots(self) -> tuple[np.ndarray, np.ndarray]:
        depth = self.bit_start_md_m
        knots_t, knots_d = [0.0], [depth]
        for p in self._phases:
            if p.name == "drill":
                depth += self.tube_length_m
            knots_t.append(p.end_s)
            knots_d.append(depth)
        return np.array(knots_t), np.array(knots_d)

    def bit_md_m(self, t_s) -> np.ndarray:
        """Bit depth: from :attr:`bit_start_md_m`, advances at the rate of penetration while drilling, constant
        otherwise (piecewise linear in t; knots computed once per process)."""
        knots_t, knots_d = self._bit_knots
        return np.interp(np.asarray(t_s, dtype=float), knots_t, knots_d)

    def node_md_m(self, k, bit_md_m) -> np.ndarray:
        """MD of node(s) ``k`` with the bit at ``bit_md_m``: MD_k = D - (k L + node_offset_m) (module doc);
        broadcasts ``k`` against ``bit_md_m``."""
        return bit_md_m - (np.asarray(k) * self.tube_length_m + self.node_offset_m)

    def node_count(self, t_s) -> np.ndarray:
        """Nodes in the chain at times t."""
        return np.searchsorted(self._insertion_times_s, np.asarray(t_s, dtype=float), side="right")

    @cached_property
    def _node_starts(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Per node k, at its insertion time t_k: (t_k, theta(t_k), Gamma(MD_k(t_k)), mounting yaw psi_k0)."""
        n, wp, t_in = self.tubes, self.wellpath, self._insertion_times_s
        md_in = self.node_md_m(np.arange(n), self.bit_md_m(t_in))
        gamma_in = wp.twist_rad(np.maximum(md_in, wp.md_m[0]))
        mount = np.zeros(n) if self.mount_yaw_rad is None else np.asarray(self.mount_yaw_rad[:n], dtype=float)
        return t_in, self._rate_profile.angle_rad(t_in), gamma_in, mount

    def _pose(self, k: int, bit: np.ndarray, theta: np.ndarray):
        """Node k's (md, inclination, azimuth, yaw) with the bit at D(t) and the string at theta(t) (module doc), as if
        inserted."""
        wp = self.wellpath
        _, theta_in, gamma_in, mount = self._node_starts
        md = self.node_md_m(k, bit)
        md_clipped = np.maximum(md, wp.md_m[0])
        inc, azi = wp.attitude_along(md_clipped)
        yaw = mount[k] + theta - theta_in[k] + (wp.twist_rad(md_clipped) - gamma_in[k])
        return md, inc, azi, yaw

    def _node_state(self, k: int, t: np.ndarray, bit: np.ndarray, theta: np.ndarray):
        """Node k's (present, md, inclination, azimuth, yaw, toolface) at times t, the bit depth D(t) and the string
        angle theta(t) given (module doc; NaN where not yet inserted): O(K) for K times."""
        present = t >= self._node_starts[0][k]
        md, inc, azi, yaw = self._pose(k, bit, theta)
        nan = np.where(present, 1.0, np.nan)
        return present, md * nan, inc * nan, azi * nan, yaw * nan, np.remainder(azi - yaw, 2.0 * math.pi) * nan

    def node_truth(self, k: int, t_s) -> NodeTruth:
        """True state of node ``k`` (0 = bit) at times ``t_s``: arrays (K,) (module doc); equals ``truth(t_s)``'s
        row k bit for bit, at O(K) cost (the process's phases, rate profile, insertion states and the wellpath's
        twist grid are computed once per process)."""
        if not 0 <= k < self.tubes:
            raise NodesimError(f"drilling: node {k} does not exist (allowed: 0..{self.tubes - 1})")
        t = np.atleast_1d(np.asarray(t_s, dtype=float))
        rp = self._rate_profile
        state = self._node_state(k, t, self.bit_md_m(t), rp.angle_rad(t))
        return NodeTruth(t, *state, spin_rate_rad_s=rp.rate_rad_s(t))

    def node_attitude(self, k: int, t_s) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(yaw, inclination, azimuth) of node ``k`` at times ``t_s`` from its insertion on: :meth:`node_truth` without
        the spin rate, the presence mask and the toolface (the sensors ask for it at every sample)."""
        t = np.atleast_1d(np.asarray(t_s, dtype=float))
        if (t < self._node_starts[0][k]).any():
            raise NodesimError(f"drilling: node {k} asked for its attitude before its insertion")
        _, inc, azi, yaw = self._pose(k, self.bit_md_m(t), self._rate_profile.angle_rad(t))
        return yaw, inc, azi

    def truth(self, t_s) -> NodeTruth:
        """True MD, inclination, azimuth, yaw and toolface of every node at times ``t_s`` (see module doc): arrays
        (N, K), row k that of :meth:`node_truth`."""
        t = np.atleast_1d(np.asarray(t_s, dtype=float))
        rp = self._rate_profile
        bit, theta = self.bit_md_m(t), rp.angle_rad(t)
        rows = [self._node_state(k, t, bit, theta) for k in range(self.tubes)]
        present, md, inc, azi, yaw, toolface = (np.stack(col) for col in zip(*rows))
        return NodeTruth(t, present, md, inc, azi, yaw, toolface, rp.rate_rad_s(t))
