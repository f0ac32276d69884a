"""Thesis-replica position uncertainty: the propagation that the thesis's wellbore tables imply.

The thesis says it applies the ISCWSA error model (sec 2.3, App. I), but its wellbore tables (4.5, 4.8,
4.11, 4.14, 4.17 for wellbore 1) do not follow the standard propagation of :mod:`covariance`.  This
module computes what the tables look like they were computed with, so the two can be compared.  It is a
replica for validation, not a better model: the standard ISCWSA method stays the default everywhere.

Per-station contribution.  Every station k of the survey gets one error vector per error term,

    e_k = lever_k * (dt/dI(k) * dI_k  +  L_k * dA_k  +  t_k * dD_k)          [m, N/E/V]

with the station's lever the half courses on either side of it,
``lever_k = (MD_k - MD_{k-1})/2 + (MD_{k+1} - MD_k)/2`` (2 m on wellbore 1), only the half course above it
at the last station (1 m: the e* of eq I.13, which the tables show applied once, to the last station of
the well), and no error at the top station (thesis 4.1.2: "no errors at station one").  dt/dI =
(cosI cosA, cosI sinA, -sinI); L_k = sinI (-sinA, cosA, 0) is dt/dA (the balanced-tangential
derivatives of App. I), or (-sinA, cosA, 0) without the sin I for the gyro terms of the tools whose
tables show it (below); t_k is the hole direction at k and dD_k a depth error per metre of lever.

Row K.  The uncertainty reported at station K is a running sum over the stations down to K of those
per-station vectors, per axis (B = |N|, A = |E|, TVD):

    random terms:      sigma_R(K) = sqrt( sum_{k<=K} sum_i e_{i,k}^2 )          (eq I.15, root sum square)
    systematic terms:  sigma_S(K) = sum_{k<=K} sum_i |e_{i,k}|                   (eqs I.14, I.16, arithmetic)
    reported:          sigma(K)   = sqrt( sigma_R(K)^2 + sigma_S(K)^2 )          (eq I.18, C = C_rand + C_syst)

Every row uses the levers of the complete survey, so only the last row has the half lever: the step from
the second-last to the last station collapses (wellbore 1, SS9 -> SS10: to 22-30 % of the step before on
the leading axis of every table), where the standard method adds a half lever at every row's own station.
The systematic sum adds magnitudes, as the thesis reports them (its worked gyro example, sec 4.1.2, prints
dN = +1.141e-3 m where the derivative gives -1.141e-3 m); on wellbore 1 every station lies in one quadrant,
so signed and unsigned sums agree.

Error terms (thesis 4.1.1 - 4.1.3 and tables 4.4, 4.7, 4.10, 4.13, 4.16):

* accelerometer x/y bias f: an inclination error only, dI = asin(f/g) (eq 4.12; 4.1.1: the bias "is
  factored into ... the inclination error at each respective survey station"; the worked example of 4.1.2
  uses an inclination error only).  The tables give one f_xy, which the tool files carry twice (ISCWSA
  TI1 and TI2): it is counted once.
* accelerometer z bias: the tables derive f_z from the same tilt as f_xy (eq 4.7), so that tilt is not
  counted twice; f_z keeps its first-order effect at the station's inclination, dI = sinI f_z / g.
* scale factor s: dI = s sinI cosI (one term; the tool files repeat it as TI1/TI2/TI3/Z), except for
  the DIP, whose table 4.4 states the resolution as an angle (5.73e-4 deg) like its accuracy: dI = asin(s).
* misalignment m: dI = m, dA = m / sinI (one term), always with the sin I lever (so e = lever m).
* gyro drift G: dA_k = G t_k; angle random walk N: dA_k = N sqrt(t_k) (eqs 2.4-2.7), t_k = time of
  station k (60 s per station, 4.1.3).
* a direct azimuth error (the filtered node's 0.25 deg, sec 4.2.4, which replaces "the product of the
  weighting function and the error magnitude" of the gyro terms): dA = value, with the gyro lever, in its
  own propagation mode (random for ``mpu6500_filtered``, as the curves of fig 4.24 level off).
* depth scale factor s (the DIP's cable stretch, m/m): the station's lever of cable stretches by
  s lever_k along the hole, dD_k = s, in the depth mode of the tool's rules.  (Table 4.5's TVD column is
  2.1 cm sqrt(k), and 2.1 cm sqrt(9.25) at SS10: a random term proportional to the lever.  The standard
  DSF term, s MD_k through the two courses' depth derivatives, cancels at interior stations.)

Which terms are random and which systematic, and which tools drop the sin I, the thesis does not say; the
rules per tool (:data:`TOOL_RULES`) are read off the tables and each says what it rests on.  They are
hypotheses, and the validation rows built on them are labelled so.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from nodesim.errors import NodesimError
from nodesim.ground.covariance import Site, propagate, with_survey_sigmas
from nodesim.ground.errormodel import ErrorModel, ErrorSource
from nodesim.ground.survey import Survey
from nodesim.ground.wellpath import Wellpath, unit_tangent, wellpath

MODES = ("R", "S")
PROPAGATIONS = ("iscwsa", "thesis")
"""Position-uncertainty methods: standard ISCWSA (:func:`nodesim.ground.covariance.propagate`, the default)
and the thesis replica (:func:`propagate_thesis`)."""
THESIS_GRAVITY_M_S2 = 9.81  # thesis 4.1.1: "The value of acceleration due to gravity was taken as 9.81m/s2"


@dataclass(frozen=True)
class ThesisRules:
    """How the replica propagates one tool (see the module doc)."""

    sensor_mode: str = "R"  # accelerometer bias, scale factor and misalignment: R random or S systematic
    gyro_mode: str = "S"  # gyro drift and angle random walk
    gyro_lever_sin_i: bool = True  # azimuth lever of the gyro (and direct azimuth) terms: lever sinI, or lever
    scale_factor_as_angle: bool = False  # scale factor read as an inclination error asin(s) (DIP table 4.4)
    depth_mode: str | None = None  # depth scale factor: R, S, or None for the source's own propagation
    basis: str = "default rules: accelerometer terms random, gyro terms systematic, standard sin I lever"

    def __post_init__(self):
        for name in ("sensor_mode", "gyro_mode", "depth_mode"):
            if getattr(self, name) not in MODES + ((None,) if name == "depth_mode" else ()):
                raise NodesimError(f"thesis rules: {name} must be one of {MODES}, got {getattr(self, name)!r}")


TOOL_RULES: dict[str, ThesisRules] = {
    "dip": ThesisRules(
        sensor_mode="S",
        scale_factor_as_angle=True,
        depth_mode="R",
        basis="table 4.5: A grows linearly with the station (steps 0.032-0.044 cm), so the inclination terms "
        "add arithmetically; TVD is 2.1 cm sqrt(k) (a random term); table 4.4 states the resolution as an angle",
    ),
    "vn100t": ThesisRules(
        gyro_lever_sin_i=False,
        basis="table 4.8: B steps grow ~linearly with the station (2.1, 2.9, 3.9, 4.8, 5.8, 6.9 cm): a drift "
        "dA = G t summed arithmetically over a lever without sin I (with sin I they would grow with k sinI_k)",
    ),
    "stim300": ThesisRules(
        gyro_lever_sin_i=False,
        basis="table 4.11: B steps grow ~linearly with the station (0.22 ... 0.56 cm), as for the VN-100T",
    ),
    "ipst_rqh": ThesisRules(
        basis="table 4.14: A variance steps are ~constant (0.030-0.040 cm^2): one random inclination term; "
        "the gyro terms are too small to show their lever",
    ),
    "mpu6500": ThesisRules(
        basis="table 4.17: A2/A1 = 1.45 (random accelerometer term; systematic would give ~2); B steps from "
        "SS4 on are ~50 k sinI_k cm (a systematic drift over the sin I lever)",
    ),
    "mpu6500_filtered": ThesisRules(
        basis="thesis 4.2.4: the MPU6500 rules with the gyro terms replaced by a 0.25 deg azimuth error "
        "at each station (random: fig 4.24 levels off)",
    ),
}
"""Replica rules of the bundled thesis tools; any other tool gets ``ThesisRules()``."""

_ACCEL_XY = ("ABXY-TI1", "ABXY-TI2")
_SCALE = ("ASXY-TI1", "ASXY-TI2", "ASXY-TI3", "ASZ")
_MISALIGN = ("XYM1", "XYM2", "XYM3", "XYM4", "XYM3E", "XYM4E")
_FAMILIES = {"accelerometer x/y bias": _ACCEL_XY, "scale factor": _SCALE, "misalignment": _MISALIGN}
SUPPORTED_WEIGHTS = (
    _ACCEL_XY + ("ABZ",) + _SCALE + _MISALIGN + ("GYRO-DRIFT", "GYRO-RW", "AZ", "INC", "SURVEY-INC", "SURVEY-AZ", "DSF")
)


def rules_for(model: ErrorModel) -> ThesisRules:
    return TOOL_RULES.get(model.name, ThesisRules())


@dataclass(frozen=True, eq=False)
class ThesisTerm:
    """One error term of the replica: its per-station measurement errors and position contributions."""

    code: str
    mode: str  # "R" or "S"
    d_inc_rad: np.ndarray  # (n,) inclination error per station
    d_azi_rad: np.ndarray  # (n,) azimuth error per station
    d_md_m: np.ndarray  # (n,) depth error per metre of lever
    e_nev_m: np.ndarray  # (n, 3) contribution of each station (zero at the top station)


@dataclass(frozen=True, eq=False)
class ThesisUncertainty:
    """Result of :func:`propagate_thesis`: per-axis 1-sigma uncertainties (n, 3) in N/E/V [m].

    The replica sums per axis, so it has no cross-covariances: :attr:`cov_nev_m2` is diagonal."""

    path: Wellpath
    model: ErrorModel
    rules: ThesisRules
    terms: tuple[ThesisTerm, ...]
    skipped: tuple[tuple[str, str], ...]  # (code, why it is not a term of its own)
    random_nev_m: np.ndarray
    systematic_nev_m: np.ndarray

    @property
    def sigma_nev_m(self) -> np.ndarray:
        return np.hypot(self.random_nev_m, self.systematic_nev_m)

    @property
    def cov_nev_m2(self) -> np.ndarray:
        s = self.sigma_nev_m
        return np.einsum("ni,ij->nij", s**2, np.eye(3))


def station_levers(md_m) -> np.ndarray:
    """Half courses either side of every station: 0 at the top, a half course at the last station."""
    dmd = np.diff(np.asarray(md_m, dtype=float))
    lever = np.zeros(dmd.size + 1)
    lever[1:] += dmd / 2.0
    lever[:-1] += dmd / 2.0
    lever[0] = 0.0
    return lever


def running_sum(terms) -> tuple[np.ndarray, np.ndarray]:
    """(random, systematic) per-axis sums down to every station, each (n, 3) in m (module doc)."""
    terms = list(terms)
    if not terms:
        raise NodesimError("thesis propagation: no error terms")
    n = terms[0].e_nev_m.shape[0]
    rand_sq = np.zeros((n, 3))
    syst = np.zeros((n, 3))
    for t in terms:
        if t.mode == "R":
            rand_sq += t.e_nev_m**2
        else:
            syst += np.abs(t.e_nev_m)
    return np.sqrt(np.cumsum(rand_sq, axis=0)), np.cumsum(syst, axis=0)


def _mode_of(source: ErrorSource) -> str:
    return "R" if source.random else "S"


def thesis_terms(survey: Survey, model: ErrorModel, site: Site, rules: ThesisRules):
    """The replica's error terms of ``model`` on ``survey`` and the sources it folds into another term."""
    n = len(survey)
    inc, azi, t = survey.inc_rad, survey.azi_rad, survey.time_s
    si, ci, sa, ca = np.sin(inc), np.cos(inc), np.sin(azi), np.cos(azi)
    g = site.gravity_m_s2
    lever = station_levers(survey.md_m)
    dt_di = np.stack([ci * ca, ci * sa, -si], axis=-1)
    lateral = np.stack([-sa, ca, np.zeros(n)], axis=-1)
    tangent = unit_tangent(inc, azi)

    def term(code, mode, d_i=0.0, d_a=0.0, d_d=0.0, sin_i_lever=True):
        d_i, d_a, d_d = (np.broadcast_to(np.asarray(x, dtype=float), (n,)).copy() for x in (d_i, d_a, d_d))
        lat = lateral * (si[:, None] if sin_i_lever else 1.0)
        e = lever[:, None] * (dt_di * d_i[:, None] + lat * d_a[:, None] + tangent * d_d[:, None])
        e[0] = 0.0
        return ThesisTerm(code, mode, d_i, d_a, d_d, e)

    terms, skipped, seen = [], [], {}
    for s in model.sources:
        w, v = s.weight, s.value
        family = next((f for f, members in _FAMILIES.items() if w in members), None)
        if family is not None:
            if family in seen:
                skipped.append((s.code, f"the table's one {family}, already counted as {seen[family]}"))
                continue
            seen[family] = s.code
        if w in _ACCEL_XY:
            if v > g:
                raise NodesimError(f"thesis propagation: {s.code} = {s.magnitude} {s.unit} exceeds g")
            terms.append(term(s.code, rules.sensor_mode, d_i=math.asin(v / g)))
        elif w == "ABZ":
            terms.append(term(s.code, rules.sensor_mode, d_i=si * v / g))
        elif w in _SCALE:
            d_i = math.asin(min(v, 1.0)) if rules.scale_factor_as_angle else v * si * ci
            terms.append(term(s.code, rules.sensor_mode, d_i=d_i))
        elif w in _MISALIGN:
            terms.append(term(s.code, rules.sensor_mode, d_i=v, d_a=v * _inv_sin(si)))
        elif w == "GYRO-DRIFT":
            terms.append(term(s.code, rules.gyro_mode, d_a=v * t, sin_i_lever=rules.gyro_lever_sin_i))
        elif w == "GYRO-RW":
            terms.append(term(s.code, rules.gyro_mode, d_a=v * np.sqrt(np.maximum(t, 0.0)),
                              sin_i_lever=rules.gyro_lever_sin_i))  # fmt: skip
        elif w == "AZ":
            terms.append(term(s.code, _mode_of(s), d_a=v, sin_i_lever=rules.gyro_lever_sin_i))
        elif w == "INC":
            terms.append(term(s.code, _mode_of(s), d_i=v))
        elif w == "SURVEY-INC":
            terms.append(term(s.code, "R", d_i=survey.sigma_inc_rad * v))
        elif w == "SURVEY-AZ":
            terms.append(term(s.code, "R", d_a=survey.sigma_azi_rad * v))
        elif w == "DSF":
            terms.append(term(s.code, rules.depth_mode or _mode_of(s), d_d=v))
        else:
            raise NodesimError(
                f"thesis propagation: error source {s.code} (weight {w}) has no thesis rule; "
                f"supported weights: {', '.join(SUPPORTED_WEIGHTS)}"
            )
    return tuple(terms), tuple(skipped)


def _inv_sin(si: np.ndarray) -> np.ndarray:
    return np.where(si > 1e-12, 1.0 / np.where(si > 1e-12, si, 1.0), 0.0)


def propagate_thesis(
    survey: Survey,
    model: ErrorModel,
    site: Site | None = None,
    method: str = "balanced_tangential",
    rules: ThesisRules | None = None,
) -> ThesisUncertainty:
    """Wellpath (``method``) and the thesis-replica uncertainty of every station (1 sigma, per axis).

    ``rules`` default to the tool's :data:`TOOL_RULES` entry and ``site`` to the thesis's g = 9.81 m/s^2.
    A survey's own per-station angle sigmas are added as random terms, as in
    :func:`nodesim.ground.covariance.propagate`."""
    model = with_survey_sigmas(survey, model)
    site = site or Site(gravity_m_s2=THESIS_GRAVITY_M_S2)
    rules = rules or rules_for(model)
    path = wellpath(survey, method)
    terms, skipped = thesis_terms(survey, model, site, rules)
    if not terms:
        zeros = np.zeros((len(survey), 3))
        return ThesisUncertainty(path, model, rules, terms, skipped, zeros, zeros.copy())
    rand, syst = running_sum(terms)
    return ThesisUncertainty(path, model, rules, terms, skipped, rand, syst)


def scale_to_match(u: ThesisUncertainty, code: str, station: int, axis: int, target_m: float) -> float:
    """The factor on term ``code``'s magnitude that makes ``u``'s 1-sigma ``axis`` at ``station`` equal
    ``target_m``, every other term unchanged (the per-axis sums are linear in a systematic term's magnitude
    and quadratic in a random one's); nan when no factor >= 0 reaches it.  Diagnostic for the validation
    notes ("needs N x the printed value")."""
    own = [t for t in u.terms if t.code == code]
    if not own:
        raise NodesimError(f"thesis propagation: no term {code!r}; has {', '.join(t.code for t in u.terms)}")
    others = [t for t in u.terms if t.code != code]
    r_o, s_o = running_sum(others) if others else (np.zeros_like(u.random_nev_m),) * 2
    r_t, s_t = running_sum(own)
    r_o, s_o, r_t, s_t = (x[station, axis] for x in (r_o, s_o, r_t, s_t))
    if own[0].mode == "S":
        rest = target_m**2 - r_o**2
        c = (math.sqrt(rest) - s_o) / s_t if rest >= 0 and s_t > 0 else math.nan
    else:
        rest = target_m**2 - r_o**2 - s_o**2
        c = math.sqrt(rest) / r_t if rest >= 0 and r_t > 0 else math.nan
    return c if c >= 0 else math.nan


def position_uncertainty(
    survey: Survey,
    model: ErrorModel,
    propagation: str = "iscwsa",
    method: str = "minimum_curvature",
    site: Site | None = None,
):
    """Wellpath and uncertainty by ``propagation`` ("iscwsa": :func:`~nodesim.ground.covariance.propagate`;
    "thesis": :func:`propagate_thesis`).  Both results have ``path``, ``model`` and ``cov_nev_m2``."""
    if propagation == "iscwsa":
        return propagate(survey, model, site, method=method)
    if propagation == "thesis":
        return propagate_thesis(survey, model, site, method=method)
    raise NodesimError(f"propagation {propagation!r} unknown; allowed: {', '.join(PROPAGATIONS)}")
