"""Survey derivatives of the station positions (balanced tangential), the building blocks of e and e*.

For the course k-1 -> k (length dMD_k) with balanced-tangential displacement
dr_k = dMD_k/2 (t_{k-1} + t_k), the derivatives with respect to the measurements of station k are
(thesis App. I / digest 1.5; covariance-method thesis eqs 34-38)::

    d dr_k     / dD_k = +(t_{k-1} + t_k) / 2          d dr_{k+1} / dD_k = -(t_k + t_{k+1}) / 2
    d dr_k     / dI_k = dMD_k     / 2 * dt/dI(k)      d dr_{k+1} / dI_k = dMD_{k+1} / 2 * dt/dI(k)
    d dr_k     / dA_k = dMD_k     / 2 * dt/dA(k)      d dr_{k+1} / dA_k = dMD_{k+1} / 2 * dt/dA(k)

with dt/dI = (cosI cosA, cosI sinA, -sinI) and dt/dA = (-sinI sinA, sinI cosA, 0).  Williamson uses
these balanced-tangential derivatives even for minimum-curvature wellpaths (SPE 67616, "no significant
loss of accuracy").  ``surface_tie_on=True`` applies the ISCWSA Rev 5.02 rule: the first station below
the surface carries the whole first course (its dr_k/dI and dr_k/dA use dMD_1, not dMD_1/2) because
the surface tie-on point has no survey of its own.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nodesim.ground.survey import Survey
from nodesim.ground.wellpath import unit_tangent


@dataclass(frozen=True, eq=False)
class Derivatives:
    """Per-station derivative arrays, each shape (n, 3) in N, E, V.

    ``d_k`` (dict D/I/A): derivative of the course ending at station k (zero at station 0);
    ``d_k1`` (dict D/I/A): derivative of the course starting at station k (zero at the last station).
    ``half_k`` / ``half_k1``: the lengths multiplying dt/dI and dt/dA (dMD_k/2, or dMD_1 at a tie-on;
    dMD_{k+1}/2), used by the vertical-singularity forms of the weighting functions.
    """

    d_k: dict
    d_k1: dict
    half_k: np.ndarray
    half_k1: np.ndarray
    dt_di: np.ndarray
    dt_da: np.ndarray

    @property
    def k_stack(self) -> np.ndarray:
        """(n, 3, 3): [station, measurement D/I/A, N/E/V] of d dr_k / dp_k (the e* matrix)."""
        return np.stack([self.d_k[x] for x in "DIA"], axis=1)

    @property
    def sum_stack(self) -> np.ndarray:
        """(n, 3, 3): d dr_k / dp_k + d dr_{k+1} / dp_k (the e matrix)."""
        return np.stack([self.d_k[x] + self.d_k1[x] for x in "DIA"], axis=1)


def survey_derivatives(survey: Survey, surface_tie_on: bool = False) -> Derivatives:
    n = len(survey)
    inc, azi = survey.inc_rad, survey.azi_rad
    t = unit_tangent(inc, azi)
    si, ci, sa, ca = np.sin(inc), np.cos(inc), np.sin(azi), np.cos(azi)
    dt_di = np.stack([ci * ca, ci * sa, -si], axis=-1)
    dt_da = np.stack([-si * sa, si * ca, np.zeros(n)], axis=-1)
    dmd = np.diff(survey.md_m)
    half_k = np.concatenate([[0.0], 0.5 * dmd])
    if surface_tie_on:
        half_k[1] = dmd[0]
    half_k1 = np.concatenate([0.5 * dmd, [0.0]])
    dd_k = np.zeros((n, 3))
    dd_k[1:] = 0.5 * (t[:-1] + t[1:])
    dd_k1 = np.zeros((n, 3))
    dd_k1[:-1] = -0.5 * (t[:-1] + t[1:])
    d_k = {"D": dd_k, "I": half_k[:, None] * dt_di, "A": half_k[:, None] * dt_da}
    d_k1 = {"D": dd_k1, "I": half_k1[:, None] * dt_di, "A": half_k1[:, None] * dt_da}
    return Derivatives(d_k, d_k1, half_k, half_k1, dt_di, dt_da)
