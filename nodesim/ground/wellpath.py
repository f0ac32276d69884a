"""Wellpath from a survey: minimum curvature and balanced tangential, vectorised over stations.

Positions are N, E, TVD (TVD positive down) in the local frame, relative to the first station.

Balanced tangential (thesis eqs 2.1-2.3, App. IV; SV eq 33)::

    dr_k = (MD_k - MD_{k-1}) / 2 * (t_{k-1} + t_k),   t = (sinI cosA, sinI sinA, cosI)

Minimum curvature multiplies each course by the ratio factor RF = (2/DL) tan(DL/2), with the dogleg
DL = arccos(t_{k-1} . t_k) computed as 2 asin(|t_k - t_{k-1}| / 2) (accurate for tiny doglegs) and
RF = 1 + DL^2/12 + DL^4/120 below DL = 1e-4 rad (the series; no 0/0).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nodesim.errors import NodesimError
from nodesim.ground.survey import Survey
from nodesim.units import DEG

SMALL_DOGLEG_RAD = 1e-4


def unit_tangent(inc_rad, azi_rad) -> np.ndarray:
    """Unit vectors (N, E, V) along the hole, shape (..., 3)."""
    inc = np.asarray(inc_rad, dtype=float)
    azi = np.asarray(azi_rad, dtype=float)
    s = np.sin(inc)
    return np.stack([s * np.cos(azi), s * np.sin(azi), np.cos(inc)], axis=-1)


def dogleg_rad(inc1, azi1, inc2, azi2) -> np.ndarray:
    """Dogleg angle between two survey directions [rad] (chord form, exact down to 0)."""
    chord = np.linalg.norm(unit_tangent(inc2, azi2) - unit_tangent(inc1, azi1), axis=-1)
    return 2.0 * np.arcsin(np.clip(chord / 2.0, 0.0, 1.0))


def ratio_factor(dogleg) -> np.ndarray:
    """Minimum-curvature ratio factor (2/DL) tan(DL/2); series 1 + DL^2/12 + DL^4/120 for tiny DL."""
    dl = np.asarray(dogleg, dtype=float)
    small = dl < SMALL_DOGLEG_RAD
    safe = np.where(small, 1.0, dl)
    exact = 2.0 / safe * np.tan(safe / 2.0)
    series = 1.0 + dl**2 / 12.0 + dl**4 / 120.0
    return np.where(small, series, exact)


@dataclass(frozen=True, eq=False)
class Wellpath:
    """Station positions [m]: n_m, e_m, tvd_m (relative to the first station) and the survey."""

    survey: Survey
    n_m: np.ndarray
    e_m: np.ndarray
    tvd_m: np.ndarray
    method: str

    @property
    def nev_m(self) -> np.ndarray:
        return np.stack([self.n_m, self.e_m, self.tvd_m], axis=-1)


def course_displacements(survey: Survey, method: str = "minimum_curvature") -> np.ndarray:
    """Displacement of each course k-1 -> k, shape (n-1, 3)."""
    return displacements(survey.md_m, survey.inc_rad, survey.azi_rad, method)


def displacements(md_m, inc_rad, azi_rad, method: str = "minimum_curvature") -> np.ndarray:
    """Course displacements for arrays with leading batch axes: inc/azi (..., n) -> (..., n-1, 3).

    The batched form serves Monte Carlo runs (one survey per replication, same MDs)."""
    inc, azi = np.broadcast_arrays(np.asarray(inc_rad, dtype=float), np.asarray(azi_rad, dtype=float))
    t = unit_tangent(inc, azi)
    dmd = np.diff(np.asarray(md_m, dtype=float), axis=-1)
    half = 0.5 * dmd[..., :, None] * (t[..., :-1, :] + t[..., 1:, :])
    if method == "balanced_tangential":
        return half
    if method == "minimum_curvature":
        dl = dogleg_rad(inc[..., :-1], azi[..., :-1], inc[..., 1:], azi[..., 1:])
        return half * ratio_factor(dl)[..., None]
    raise NodesimError(f"wellpath method '{method}' unknown; allowed: minimum_curvature, balanced_tangential")


def wellpath(survey: Survey, method: str = "minimum_curvature", start_nev_m=(0.0, 0.0, 0.0)) -> Wellpath:
    """Positions of every station by cumulative course displacements (vectorised)."""
    d = course_displacements(survey, method)
    pos = np.vstack([np.zeros((1, 3)), np.cumsum(d, axis=0)]) + np.asarray(start_nev_m, dtype=float)
    return Wellpath(survey, pos[:, 0], pos[:, 1], pos[:, 2], method)


def interpolate_md(path: Wellpath, md_m) -> np.ndarray:
    """N, E, TVD at arbitrary MDs on the minimum-curvature arc (shape (m, 3)).

    Within the course k-1 -> k with dogleg DL, the point at fraction f of the course lies on the circular
    arc; its direction is t(f) = [sin((1-f)DL) t0 + sin(f DL) t1] / sin DL (slerp), and its offset from
    station k-1 is the minimum-curvature course from t0 to t(f) over f*dMD (dogleg f*DL), which lies
    exactly on the arc.  Balanced-tangential paths are interpolated linearly between stations.
    """
    md = np.atleast_1d(np.asarray(md_m, dtype=float))
    s = path.survey
    if np.any(~np.isfinite(md)) or md.min() < s.md_m[0] or md.max() > s.md_m[-1]:
        raise NodesimError(f"interpolation MD must lie within [{s.md_m[0]:g}, {s.md_m[-1]:g}] m")
    k = np.clip(np.searchsorted(s.md_m, md, side="right"), 1, len(s) - 1)
    pos = path.nev_m
    if path.method == "balanced_tangential":
        f = (md - s.md_m[k - 1]) / (s.md_m[k] - s.md_m[k - 1])
        return pos[k - 1] + f[:, None] * (pos[k] - pos[k - 1])
    inc, azi = interpolate_direction(s, md, k)
    t0 = unit_tangent(s.inc_rad[k - 1], s.azi_rad[k - 1])
    tf = unit_tangent(inc, azi)
    dl = 2.0 * np.arcsin(np.clip(np.linalg.norm(tf - t0, axis=-1) / 2.0, 0.0, 1.0))
    dmd = md - s.md_m[k - 1]
    return pos[k - 1] + (0.5 * dmd * ratio_factor(dl))[:, None] * (t0 + tf)


def interpolate_direction(survey: Survey, md: np.ndarray, k: np.ndarray):
    """Inclination and azimuth [rad] at MDs inside courses k-1 -> k (slerp along the dogleg)."""
    t0 = unit_tangent(survey.inc_rad[k - 1], survey.azi_rad[k - 1])
    t1 = unit_tangent(survey.inc_rad[k], survey.azi_rad[k])
    dl = dogleg_rad(survey.inc_rad[k - 1], survey.azi_rad[k - 1], survey.inc_rad[k], survey.azi_rad[k])
    f = (md - survey.md_m[k - 1]) / (survey.md_m[k] - survey.md_m[k - 1])
    small = dl < SMALL_DOGLEG_RAD
    sdl = np.where(small, 1.0, np.sin(dl))
    w0 = np.where(small, 1.0 - f, np.sin((1.0 - f) * dl) / sdl)
    w1 = np.where(small, f, np.sin(f * dl) / sdl)
    t = w0[:, None] * t0 + w1[:, None] * t1
    t /= np.linalg.norm(t, axis=-1, keepdims=True)
    inc = np.arccos(np.clip(t[:, 2], -1.0, 1.0))
    azi = np.remainder(np.arctan2(t[:, 1], t[:, 0]), 2 * np.pi)
    return inc, azi


def vertical_section(path: Wellpath, azimuth_deg: float, origin_ne_m=(0.0, 0.0)) -> np.ndarray:
    """Horizontal displacement projected on the vertical-section azimuth [m]."""
    a = azimuth_deg * DEG
    dn = path.n_m - origin_ne_m[0]
    de = path.e_m - origin_ne_m[1]
    return dn * np.cos(a) + de * np.sin(a)


def rotate_horizontal(n_m, e_m, angle_deg: float):
    """Coordinates (x, y) in horizontal axes rotated by ``angle_deg`` clockwise from (N, E).

    x = N cos a + E sin a, y = -N sin a + E cos a.  The thesis field data use axes A and B with
    N = -B and E = +A (thesis table 4.1, digest section 1.2): see :func:`ne_to_ab`.
    """
    a = angle_deg * DEG
    n = np.asarray(n_m, dtype=float)
    e = np.asarray(e_m, dtype=float)
    return n * np.cos(a) + e * np.sin(a), -n * np.sin(a) + e * np.cos(a)


def ne_to_ab(n_m, e_m):
    """Thesis field axes: A = E, B = -N (reproduces table 4.1: Az = atan2(A, -B))."""
    return np.asarray(e_m, dtype=float), -np.asarray(n_m, dtype=float)


def ab_to_ne(a_m, b_m):
    """Inverse of :func:`ne_to_ab`: N = -B, E = A."""
    return -np.asarray(b_m, dtype=float), np.asarray(a_m, dtype=float)


def survey_angles_from_ab(a_m, b_m, course_m: float = 2.0, cumulative: bool = True):
    """Inclination and azimuth [deg] of the thesis field data from A/B displacements (eqs 4.1-4.2).

    I_A = asin(d_A / L), I_B = asin(d_B / L), I = sqrt(I_A^2 + I_B^2), Az = atan2(A, -B) (digest 1.2).
    ``cumulative=True`` applies eq 4.1 to the tabulated displacements as printed (they are cumulative
    from the top, which reproduces table 4.1 but overstates I, digest section 9 #4); ``False`` uses the
    increment over each course of length L instead.
    """
    a = np.asarray(a_m, dtype=float)
    b = np.asarray(b_m, dtype=float)
    if not cumulative:
        a = np.diff(a, prepend=0.0)
        b = np.diff(b, prepend=0.0)
    ratio = np.stack([a, b]) / course_m
    if np.any(np.abs(ratio) > 1):
        raise NodesimError(f"A/B displacement larger than the course length {course_m} m")
    i_a, i_b = np.degrees(np.arcsin(ratio))
    inc = np.hypot(i_a, i_b)
    azi = np.remainder(np.degrees(np.arctan2(a, -b)), 360.0)
    return inc, azi
