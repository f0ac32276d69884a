"""Weighting functions dp/de of the error sources: how one unit of error changes (MD, I, A).

Each function takes a :class:`Context` (per-station arrays and site constants) and returns a
:class:`Weights`:

* ``w`` (n, 3): the ISCWSA weighting function over (MD, I, A) (Williamson SPE-67616 table 1; Rev 5.1
  model table; thesis eqs 2.4-2.7 for the time-based gyro terms);
* ``sing`` (n, 3) or None: the N/E/V vector that replaces the I/A part at near-vertical stations
  (inclination below ``vertical_limit_rad``) where the azimuth weight is singular; it is multiplied by
  the same half-course lengths as dr/dI (ISCWSA "singularity" columns);
* ``direct`` (n, 3) or None: the error vector itself (the "tangential" XCL terms of SPE-187249, which
  act on the course ending at the station only, e_k = e*_k).

Magnetic terms use the magnetic azimuth AzM = A - declination and the field (dip, total field).
For a tool whose azimuth comes from gyros (``Context.magnetic_azimuth = False``) the tan(Dip) terms of
the accelerometer functions vanish, which leaves the gravity-only inclination/toolface forms.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from nodesim.errors import NodesimError


@dataclass(frozen=True, eq=False)
class Context:
    """Per-station arrays (length n) and site constants used by the weighting functions."""

    md_m: np.ndarray
    tvd_m: np.ndarray
    inc_rad: np.ndarray
    azi_rad: np.ndarray  # true (local-frame) azimuth
    time_s: np.ndarray  # time since the start of the gyro integration
    gravity_m_s2: float = 9.80665
    dip_rad: float = 0.0
    b_total_nt: float = 50000.0
    declination_rad: float = 0.0
    magnetic_azimuth: bool = True
    tortuosity_rad_per_m: float = 0.000572614583987641  # 1 deg / 100 ft (ISCWSA Rev 5 XCL)
    min_course_m: float = 10.0  # XYM3E/XYM4E short-course scaling (Rev 5.1)
    vertical_limit_rad: float = 1e-4 * np.pi / 180.0
    sigma_inc_rad: np.ndarray | None = None  # per-station 1-sigma survey errors (filter / fusion output)
    sigma_azi_rad: np.ndarray | None = None

    @property
    def n(self) -> int:
        return int(self.md_m.size)

    @property
    def azm_rad(self) -> np.ndarray:
        return self.azi_rad - self.declination_rad

    @property
    def tan_dip(self) -> float:
        return float(np.tan(self.dip_rad)) if self.magnetic_azimuth else 0.0

    @property
    def b_horizontal_nt(self) -> float:
        return self.b_total_nt * float(np.cos(self.dip_rad))

    @property
    def dmd_prev_m(self) -> np.ndarray:
        return np.concatenate([[0.0], np.diff(self.md_m)])

    @property
    def vertical(self) -> np.ndarray:
        return self.inc_rad < self.vertical_limit_rad


@dataclass(frozen=True, eq=False)
class Weights:
    w: np.ndarray | None = None
    sing: np.ndarray | None = None
    direct: np.ndarray | None = None


def _w(c: Context, d=0.0, i=0.0, a=0.0) -> Weights:
    n = c.n
    return Weights(w=np.stack([np.broadcast_to(np.asarray(x, float), (n,)) for x in (d, i, a)], axis=-1))


def _lateral(c: Context, scale) -> np.ndarray:
    """N/E/V vector (-sinA, cosA, 0) * scale: the right-hand horizontal direction."""
    s = np.broadcast_to(np.asarray(scale, float), (c.n,))
    return np.stack([-np.sin(c.azi_rad) * s, np.cos(c.azi_rad) * s, np.zeros(c.n)], axis=-1)


def _safe_div_sin(c: Context, num) -> np.ndarray:
    """num / sin(I), set to 0 at near-vertical stations (their ``sing`` vector takes over)."""
    s = np.sin(c.inc_rad)
    return np.where(c.vertical, 0.0, np.asarray(num, float) / np.where(c.vertical, 1.0, s))


def _short_course(c: Context) -> np.ndarray:
    """Max(1, sqrt(min_course / dMD)) of the Rev 5.1 XYM3E/XYM4E terms (1 at the first station)."""
    dmd = c.dmd_prev_m
    return np.where(dmd > 0, np.sqrt(np.maximum(1.0, c.min_course_m / np.where(dmd > 0, dmd, 1.0))), 1.0)


def _azimuth_change(c: Context) -> np.ndarray:
    """|A_k - A_{k-1}| wrapped into [0, pi]; 0 at the first station and after a vertical station, whose
    azimuth is arbitrary (the kick-off from vertical is not an azimuth change)."""
    da = np.abs(np.diff(c.azi_rad))
    da = np.minimum(da, 2 * np.pi - da)
    da = np.where(c.vertical[:-1], 0.0, da)
    return np.concatenate([[0.0], da])


# ---- depth ------------------------------------------------------------------------------------------
def dref(c):  # depth reference: one unit of MD at every station
    return _w(c, d=1.0)


def dsf(c):  # depth scale factor
    return _w(c, d=c.md_m)


def dst(c):  # depth stretch (ISCWSA): MD * TVD, magnitude per metre
    return _w(c, d=c.md_m * c.tvd_m)


# ---- accelerometers (toolface-independent forms, SPE-67616 table 1 + SPE-63275) -----------------
def abxy_ti1(c):
    ci = np.cos(c.inc_rad)
    return _w(c, i=-ci / c.gravity_m_s2, a=c.tan_dip * ci * np.sin(c.azm_rad) / c.gravity_m_s2)


def abxy_ti2(c):
    ci = np.cos(c.inc_rad)
    a = _safe_div_sin(c, ci) - c.tan_dip * np.cos(c.azm_rad)
    base = _w(c, a=a / c.gravity_m_s2).w
    return Weights(w=base, sing=_lateral(c, 1.0 / c.gravity_m_s2))


def abz(c):
    si = np.sin(c.inc_rad)
    return _w(c, i=-si / c.gravity_m_s2, a=c.tan_dip * si * np.sin(c.azm_rad) / c.gravity_m_s2)


def _as_inc(c, factor):
    si, ci = np.sin(c.inc_rad), np.cos(c.inc_rad)
    return _w(c, i=factor * si * ci, a=-factor * c.tan_dip * si * ci * np.sin(c.azm_rad))


def asxy_ti1(c):
    return _as_inc(c, 1.0 / np.sqrt(2.0))


def asxy_ti2(c):
    return _as_inc(c, 0.5)


def asxy_ti3(c):
    si, ci = np.sin(c.inc_rad), np.cos(c.inc_rad)
    return _w(c, a=(c.tan_dip * si * np.cos(c.azm_rad) - ci) / 2.0)


def asz(c):
    return _as_inc(c, -1.0)


# ---- magnetometers, declination, interference (SPE-67616; Rev 5.1 model table) -----------------
def mbxy_ti1(c):
    return _w(c, a=-np.cos(c.inc_rad) * np.sin(c.azm_rad) / c.b_horizontal_nt)


def mbxy_ti2(c):
    return _w(c, a=np.cos(c.azm_rad) / c.b_horizontal_nt)


def mbz(c):
    return _w(c, a=-np.sin(c.inc_rad) * np.sin(c.azm_rad) / c.b_horizontal_nt)


def msxy_ti1(c):
    si, ci, sa, ca = np.sin(c.inc_rad), np.cos(c.inc_rad), np.sin(c.azm_rad), np.cos(c.azm_rad)
    return _w(c, a=si * sa * (c.tan_dip * ci + si * ca) / np.sqrt(2.0))


def msxy_ti2(c):
    si, ci, sa, ca = np.sin(c.inc_rad), np.cos(c.inc_rad), np.sin(c.azm_rad), np.cos(c.azm_rad)
    return _w(c, a=sa * (c.tan_dip * si * ci - ci * ci * ca - ca) / 2.0)


def msxy_ti3(c):
    si, ci, sa, ca = np.sin(c.inc_rad), np.cos(c.inc_rad), np.sin(c.azm_rad), np.cos(c.azm_rad)
    return _w(c, a=(ci * ca * ca - ci * sa * sa - c.tan_dip * si * ca) / 2.0)


def msz(c):
    si, ci, sa, ca = np.sin(c.inc_rad), np.cos(c.inc_rad), np.sin(c.azm_rad), np.cos(c.azm_rad)
    return _w(c, a=-(si * ca + c.tan_dip * ci) * si * sa)


def dbh(c):
    return _w(c, a=1.0 / c.b_horizontal_nt)


def amil(c):
    return _w(c, a=np.sin(c.inc_rad) * np.sin(c.azm_rad) / c.b_horizontal_nt)


# ---- direct angle terms -----------------------------------------------------------------------
def az(c):  # azimuth reference / direct azimuth error (thesis 4.2.4: the filtered 0.25 deg term)
    return _w(c, a=1.0)


def inc(c):  # direct inclination error (thesis 4.1.2 first-principles route)
    return _w(c, i=1.0)


def survey_inc(c):  # per-station inclination sigma carried by the survey (magnitude 1 rad)
    return _w(c, i=0.0 if c.sigma_inc_rad is None else c.sigma_inc_rad)


def survey_az(c):  # per-station azimuth sigma carried by the survey, e.g. a simulated filter's
    return _w(c, a=0.0 if c.sigma_azi_rad is None else c.sigma_azi_rad)


# ---- alignment -----------------------------------------------------------------------------------
def sage(c):
    return _w(c, i=np.sin(c.inc_rad) ** 0.25)


def xym1(c):
    return _w(c, i=np.abs(np.sin(c.inc_rad)))


def xym2(c):
    return _w(c, a=-1.0)


def _xym34(c, coeff, which):
    ci, sa, ca = np.abs(np.cos(c.inc_rad)), np.sin(c.azi_rad), np.cos(c.azi_rad)
    if which == 3:  # N at vertical
        w = _w(c, i=ci * ca * coeff, a=-_safe_div_sin(c, ci * sa) * coeff).w
        sing = np.stack([np.ones(c.n), np.zeros(c.n), np.zeros(c.n)], axis=-1)
    else:  # E at vertical
        w = _w(c, i=ci * sa * coeff, a=_safe_div_sin(c, ci * ca) * coeff).w
        sing = np.stack([np.zeros(c.n), np.ones(c.n), np.zeros(c.n)], axis=-1)
    return Weights(w=w, sing=sing * np.broadcast_to(coeff, (c.n,))[:, None])


def xym3(c):  # SPE-90408 table 9, alt. 3 (Rev 4, systematic)
    return _xym34(c, 1.0, 3)


def xym4(c):
    return _xym34(c, 1.0, 4)


def xym3e(c):  # Rev 5.1: random, scaled up on courses shorter than min_course_m
    return _xym34(c, _short_course(c), 3)


def xym4e(c):
    return _xym34(c, _short_course(c), 4)


# ---- long course length (tangential, SPE-187249) -------------------------------------------------
def xcla(c):
    """e_k = dMD_k * max(|dA| sinI, tortuosity * dMD_k) * (-sinA, cosA, 0)."""
    dmd = c.dmd_prev_m
    ang = np.maximum(_azimuth_change(c) * np.sin(c.inc_rad), c.tortuosity_rad_per_m * dmd)
    return Weights(direct=_lateral(c, dmd * ang))


def xclh(c):
    """e_k = dMD_k * max(|dI|, tortuosity * dMD_k) * dt/dI(k)."""
    dmd = c.dmd_prev_m
    di = np.abs(np.diff(c.inc_rad, prepend=c.inc_rad[0]))
    ang = np.maximum(di, c.tortuosity_rad_per_m * dmd) * dmd
    ci, si = np.cos(c.inc_rad), np.sin(c.inc_rad)
    vec = np.stack([ci * np.cos(c.azi_rad), ci * np.sin(c.azi_rad), -si], axis=-1)
    return Weights(direct=vec * ang[:, None])


# ---- gyro terms over time (thesis eqs 2.4-2.7) ---------------------------------------------------
def gyro_drift(c):  # bias [rad/s] integrated over time: dA = t * bias
    return _w(c, a=c.time_s)


def gyro_random_walk(c):  # angle random walk [rad/sqrt(s)]: sigma_A = ARW * sqrt(t) (digest 1.5 [A])
    return _w(c, a=np.sqrt(np.maximum(c.time_s, 0.0)))


WEIGHTING: dict[str, Callable[[Context], Weights]] = {
    "DREF": dref, "DSF": dsf, "DST": dst,
    "ABXY-TI1": abxy_ti1, "ABXY-TI2": abxy_ti2, "ABZ": abz,
    "ASXY-TI1": asxy_ti1, "ASXY-TI2": asxy_ti2, "ASXY-TI3": asxy_ti3, "ASZ": asz,
    "MBXY-TI1": mbxy_ti1, "MBXY-TI2": mbxy_ti2, "MBZ": mbz,
    "MSXY-TI1": msxy_ti1, "MSXY-TI2": msxy_ti2, "MSXY-TI3": msxy_ti3, "MSZ": msz,
    "AZ": az, "INC": inc, "SURVEY-INC": survey_inc, "SURVEY-AZ": survey_az, "DBH": dbh, "AMIL": amil,
    "SAGE": sage, "XYM1": xym1, "XYM2": xym2, "XYM3": xym3, "XYM4": xym4, "XYM3E": xym3e, "XYM4E": xym4e,
    "XCLA": xcla, "XCLH": xclh,
    "GYRO-DRIFT": gyro_drift, "GYRO-RW": gyro_random_walk,
}  # fmt: skip
"""Every weighting function by name (the ``weight`` field of an error source)."""

MAGNETIC_WEIGHTS = frozenset({"MBXY-TI1", "MBXY-TI2", "MBZ", "MSXY-TI1", "MSXY-TI2", "MSXY-TI3", "MSZ", "DBH", "AMIL"})


def weighting(name: str) -> Callable[[Context], Weights]:
    try:
        return WEIGHTING[name]
    except KeyError:
        raise NodesimError(f"unknown weighting function '{name}'; allowed: {', '.join(sorted(WEIGHTING))}") from None
