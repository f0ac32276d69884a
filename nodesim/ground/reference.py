"""Straightforward O(n^2) station-pair covariance: the oracle for the running sums and the benchmark
baseline.  For every station K it sums the error vectors of all stations above K explicitly
(thesis eqs I.16-I.18), exactly as the equations are printed."""

from __future__ import annotations

import numpy as np

from nodesim.ground.covariance import Site, error_vectors, make_context, with_survey_sigmas
from nodesim.ground.derivatives import survey_derivatives
from nodesim.ground.errormodel import ErrorModel
from nodesim.ground.survey import Survey
from nodesim.ground.wellpath import wellpath


def propagate_pairwise(survey: Survey, model: ErrorModel, site: Site | None = None, method: str = "minimum_curvature") -> np.ndarray:
    """Total NEV covariance (n, 3, 3) by explicit sums over the stations above each station."""
    site = site or Site()
    model = with_survey_sigmas(survey, model)
    path = wellpath(survey, method)
    ctx = make_context(survey, path, model, site)
    deriv = survey_derivatives(survey, surface_tie_on=model.surface_tie_on)
    n = len(survey)
    total = np.zeros((n, 3, 3))
    for src in model.sources:
        e, e_star = error_vectors(src, ctx, deriv)
        for big_k in range(n):
            if src.random:
                c = np.outer(e_star[big_k], e_star[big_k])
                for k in range(big_k):
                    c += np.outer(e[k], e[k])
            else:
                v = e_star[big_k].copy()
                for k in range(big_k):
                    v += e[k]
                c = np.outer(v, v)
            total[big_k] += c
    return total
