"""ISCWSA covariance propagation with running sums (cost linear in the number of stations).

For error source i with magnitude sigma_i and weighting function w_i (thesis eq 2.32, I.13)::

    e_k   = sigma_i * sum_x w_x(k) * (d dr_k/dx_k + d dr_{k+1}/dx_k)       (every station k)
    e*_K  = sigma_i * sum_x w_x(K) *  d dr_K/dx_K                         (station of interest K)

and the covariance at station K (thesis eqs I.16-I.18, single survey leg)::

    random (R):          C_K = sum_{k<K} e_k e_k^T + e*_K e*_K^T
    systematic (S/W/G):  C_K = (sum_{k<K} e_k + e*_K)(sum_{k<K} e_k + e*_K)^T

Both sums are prefix sums over k (``cumsum``), so every station's covariance comes out of one pass:
O(n) per source instead of the O(n^2) station-pair form.  The total covariance is the plain sum over
sources (independent sources, no cross terms).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nodesim.ground.derivatives import survey_derivatives
from nodesim.ground.errormodel import ErrorModel, ErrorSource
from nodesim.ground.survey import Survey
from nodesim.ground.weighting import Context, Weights, weighting
from nodesim.ground.wellpath import Wellpath, wellpath


@dataclass(frozen=True)
class Site:
    """Constants the weighting functions need beyond the survey (ISCWSA wellpath-sheet header)."""

    gravity_m_s2: float = 9.80665
    dip_deg: float = 72.0
    b_total_nt: float = 50000.0
    declination_deg: float = 0.0
    tortuosity_rad_per_m: float = 0.000572614583987641
    min_course_m: float = 10.0
    vertical_limit_deg: float = 1e-4


@dataclass(frozen=True, eq=False)
class Uncertainty:
    """Result of a propagation: the wellpath, the total NEV covariance (n, 3, 3) in m^2 (1 sigma) and,
    when requested, the per-source covariances (S, n, 3, 3) in the order of ``model.sources``."""

    path: Wellpath
    model: ErrorModel
    cov_nev_m2: np.ndarray
    per_source_m2: np.ndarray | None

    def source_cov(self, code: str) -> np.ndarray:
        if self.per_source_m2 is None:
            raise ValueError("propagate(..., per_source=True) keeps the per-source covariances")
        idx = [s.code for s in self.model.sources].index(code)
        return self.per_source_m2[idx]


def make_context(survey: Survey, path: Wellpath, model: ErrorModel, site: Site) -> Context:
    deg = np.pi / 180.0
    return Context(
        md_m=survey.md_m,
        tvd_m=path.tvd_m,
        inc_rad=survey.inc_rad,
        azi_rad=survey.azi_rad,
        time_s=survey.time_s,
        gravity_m_s2=site.gravity_m_s2,
        dip_rad=site.dip_deg * deg,
        b_total_nt=site.b_total_nt,
        declination_rad=site.declination_deg * deg,
        magnetic_azimuth=model.magnetic_azimuth,
        tortuosity_rad_per_m=site.tortuosity_rad_per_m,
        min_course_m=site.min_course_m,
        vertical_limit_rad=site.vertical_limit_deg * deg,
        sigma_inc_rad=survey.sigma_inc_rad,
        sigma_azi_rad=survey.sigma_azi_rad,
    )


def with_survey_sigmas(survey: Survey, model: ErrorModel) -> ErrorModel:
    """The model plus random direct terms for the survey's own per-station angle sigmas, if it has any."""
    extra = []
    if survey.sigma_inc_rad is not None:
        extra.append(ErrorSource("SURVEY-INC", "SURVEY-INC", 1.0, "rad", "R", "per-station inclination sigma of the survey"))
    if survey.sigma_azi_rad is not None:
        extra.append(ErrorSource("SURVEY-AZ", "SURVEY-AZ", 1.0, "rad", "R", "per-station azimuth sigma of the survey"))
    return model.with_sources(*extra) if extra else model


def error_vectors(source: ErrorSource, ctx: Context, deriv, stacks=None) -> tuple[np.ndarray, np.ndarray]:
    """(e, e*) of one source, each (n, 3) in m (weighting function times derivatives times magnitude).

    ``stacks`` = (deriv.k_stack, deriv.sum_stack), precomputed once per survey when many sources share it."""
    stacks = stacks if stacks is not None else (deriv.k_stack, deriv.sum_stack)
    wts: Weights = weighting(source.weight)(ctx)
    sigma = source.value
    if wts.direct is not None:
        e = sigma * wts.direct
        e[0] = 0.0
        return e, e
    w = wts.w
    e = np.einsum("nx,nxj->nj", w, stacks[1])
    e_star = np.einsum("nx,nxj->nj", w, stacks[0])
    if wts.sing is not None:
        vert = ctx.vertical
        if vert.any():
            # the I/A part is replaced by the singular N/E/V vector times the same half-course lengths
            wd = w[:, 0][:, None]
            e_d = wd * (deriv.d_k["D"] + deriv.d_k1["D"])
            es_d = wd * deriv.d_k["D"]
            e_sing = e_d + wts.sing * (deriv.half_k + deriv.half_k1)[:, None]
            es_sing = es_d + wts.sing * deriv.half_k[:, None]
            e = np.where(vert[:, None], e_sing, e)
            e_star = np.where(vert[:, None], es_sing, e_star)
    # station 0 is the tie-on point: its position is given, so its measurements carry no error
    # (ISCWSA workbooks: the drdp of the surface row are zero; thesis 4.1.2: "no error at station 1")
    e[0] = 0.0
    e_star[0] = 0.0
    return sigma * e, sigma * e_star


def _random_cov(e: np.ndarray, e_star: np.ndarray) -> np.ndarray:
    """sum_{k<K} e_k e_k^T + e*_K e*_K^T for every K; e, e_star (..., n, 3)."""
    outer = e[..., :, None] * e[..., None, :]
    prefix = np.cumsum(outer, axis=-3)
    prev = np.zeros_like(prefix)
    prev[..., 1:, :, :] = prefix[..., :-1, :, :]
    return prev + e_star[..., :, None] * e_star[..., None, :]


def _systematic_cov(e: np.ndarray, e_star: np.ndarray) -> np.ndarray:
    """(sum_{k<K} e_k + e*_K)(...)^T for every K."""
    prefix = np.cumsum(e, axis=-2)
    v = e_star.copy()
    v[..., 1:, :] += prefix[..., :-1, :]
    return v[..., :, None] * v[..., None, :]


def prepare(survey: Survey, model: ErrorModel, site: Site | None, method: str):
    """What every propagation needs: the model with the survey's own sigmas added, the wellpath, the
    weighting context and the survey derivatives (shared by :func:`propagate` and the O(n^2) oracle)."""
    model = with_survey_sigmas(survey, model)
    path = wellpath(survey, method)
    ctx = make_context(survey, path, model, site or Site())
    deriv = survey_derivatives(survey, surface_tie_on=model.surface_tie_on)
    return model, path, ctx, deriv


def propagate(
    survey: Survey,
    model: ErrorModel,
    site: Site | None = None,
    method: str = "minimum_curvature",
    per_source: bool = False,
) -> Uncertainty:
    """Wellpath and ISCWSA covariance at every station (1 sigma, N/E/V, m^2).

    A survey carrying per-station angle sigmas adds them as random terms (:func:`with_survey_sigmas`);
    ``Uncertainty.model`` is the model actually used."""
    model, path, ctx, deriv = prepare(survey, model, site, method)
    n = len(survey)
    if not model.sources:
        zeros = np.zeros((n, 3, 3))
        return Uncertainty(path, model, zeros, np.zeros((0, n, 3, 3)) if per_source else None)
    stacks = (deriv.k_stack, deriv.sum_stack)
    vecs = [error_vectors(s, ctx, deriv, stacks) for s in model.sources]
    e = np.stack([v[0] for v in vecs])
    e_star = np.stack([v[1] for v in vecs])
    rand = np.array([s.random for s in model.sources])
    if per_source:
        out = np.empty((len(model.sources), n, 3, 3))
        if rand.any():
            out[rand] = _random_cov(e[rand], e_star[rand])
        if (~rand).any():
            out[~rand] = _systematic_cov(e[~rand], e_star[~rand])
        return Uncertainty(path, model, out.sum(axis=0), out)
    total = np.zeros((n, 3, 3))
    if rand.any():
        # sum over random sources first: sum_i e_i e_i^T is itself a prefix sum
        er, esr = e[rand], e_star[rand]
        outer = np.einsum("snj,snk->njk", er, er)
        prefix = np.cumsum(outer, axis=0)
        total[1:] += prefix[:-1]
        total += np.einsum("snj,snk->njk", esr, esr)
    if (~rand).any():
        es, ess = e[~rand], e_star[~rand]
        v = ess.copy()
        v[:, 1:, :] += np.cumsum(es, axis=1)[:, :-1, :]
        total += np.einsum("snj,snk->njk", v, v)
    return Uncertainty(path, model, total, None)
