"""Straightforward O(n^2) station-pair covariance: the oracle for the running sums and the benchmark
baseline.  For every station K it sums the error vectors of all stations above K explicitly
(thesis eqs I.16-I.18), exactly as the equations are printed."""

from __future__ import annotations

import numpy as np

from nodesim.ground.covariance import Site, error_vectors, prepare
from nodesim.ground.errormodel import ErrorModel
from nodesim.ground.survey import Survey


def propagate_pairwise(survey: Survey, model: ErrorModel, site: Site | None = None, method: str = "minimum_curvature") -> np.ndarray:
    """Total NEV covariance (n, 3, 3) by explicit sums over the stations above each station."""
    model, _, ctx, deriv = prepare(survey, model, site, method)
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
