"""Probabilistic (weighted least-squares) estimate of the magnetometer errors and covariance-method propagation.

WLS (SV Ch 4, after Hanak et al. 2015 App. A eq A-28; digest section 10)::

    dx = P H^T (H P H^T + R)^-1 dy            U = (H^T R^-1 H + P^-1)^-1

with dx = (e_xB, e_yB, e_zB, e_xS, e_yS, e_zS) (bias uT, scale error; the tables report 1 + e_S), per
station k the rows H_k = [[1,0,0,Bx_c,0,0], [0,1,0,0,By_c,0], [0,0,1,0,0,Bz_c]] (column order consistent
with dx; SV eq 20 prints the scale columns first), dy_k = B_m,k - B_c,k, the prior P = diag(sigma_B^2 x3,
sigma_S^2 x3) with sigma_B = 70 nT and sigma_S = 0.0016 (SV Table 3) and R = sigma_n^2 I with
sigma_n = 70 nT.  SV reports 3 sqrt(diag U).

Covariance method (SV Ch 5; digest 9): the six 1-sigma parameter uncertainties become ISCWSA magnetometer
error sources (bias x/y/z -> MBXY-TI1, MBXY-TI2, MBZ; scale x/y/z -> MSXY-TI1, MSXY-TI2, MSXY-TI3, the
mapping SV's eq 40 implies, digest 15 #6), all random (SV Table 10) or all systematic (SV Table 11), and
are propagated to position with the project's ISCWSA engine (:func:`nodesim.ground.covariance.propagate`,
balanced-tangential derivatives as SV uses).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nodesim.errors import NodesimError
from nodesim.ground.covariance import Site, propagate
from nodesim.ground.errormodel import ErrorModel, ErrorSource
from nodesim.ground.magnetic_survey import FieldReference, check_triads
from nodesim.ground.survey import make_survey

SV_SIGMA_BIAS_UT = 0.07
SV_SIGMA_SCALE = 0.0016
SV_NOISE_UT = 0.07
MAGNETIC_TERMS = ("MBXY-TI1", "MBXY-TI2", "MBZ", "MSXY-TI1", "MSXY-TI2", "MSXY-TI3")
"""ISCWSA weighting functions for (b_x, b_y, b_z, s_x, s_y, s_z) in the covariance method (SV eq 40)."""


@dataclass(frozen=True, eq=False)
class WlsResult:
    """dx = (e_xB, e_yB, e_zB [uT], e_xS, e_yS, e_zS) and its covariance U (6, 6)."""

    dx: np.ndarray
    cov: np.ndarray

    @property
    def bias_ut(self) -> np.ndarray:
        return self.dx[:3]

    @property
    def scale(self) -> np.ndarray:
        """1 + e_S per axis (the form SV's tables report)."""
        return 1.0 + self.dx[3:]

    @property
    def sigma(self) -> np.ndarray:
        """1-sigma of dx: sqrt(diag U)."""
        return np.sqrt(np.diag(self.cov))


def design_matrix(b_clean_ut) -> np.ndarray:
    """H (3N, 6): per station [[1,0,0,Bx,0,0],[0,1,0,0,By,0],[0,0,1,0,0,Bz]] (SV eq 20, columns as dx)."""
    b = np.asarray(b_clean_ut, dtype=float)
    n = b.shape[0]
    h = np.zeros((n, 3, 6))
    idx = np.arange(3)
    h[:, idx, idx] = 1.0
    h[:, idx, idx + 3] = b
    return h.reshape(3 * n, 6)


def wls_estimate(
    b_clean_ut,
    b_measured_ut,
    sigma_bias_ut: float = SV_SIGMA_BIAS_UT,
    sigma_scale: float = SV_SIGMA_SCALE,
    noise_ut: float = SV_NOISE_UT,
) -> WlsResult:
    """WLS estimate and covariance bound of the six magnetometer errors (SV eqs 19-21)."""
    b_c, b_m = check_triads(b_clean_ut, b_measured_ut, "WLS")
    if b_c.ndim != 2 or b_c.shape[0] < 2:
        raise NodesimError(f"WLS: needs triads of shape (stations >= 2, 3), got {b_c.shape}")
    for name, v in (("sigma_bias_ut", sigma_bias_ut), ("sigma_scale", sigma_scale), ("noise_ut", noise_ut)):
        if not (np.isfinite(v) and v > 0.0):
            raise NodesimError(f"WLS: {name} = {v} must be finite and > 0")
    h = design_matrix(b_c)
    p = np.diag([sigma_bias_ut**2] * 3 + [sigma_scale**2] * 3)
    r_var = noise_ut**2
    dy = (b_m - b_c).ravel()
    # information form U H^T R^-1 dy: equal to the gain form P H^T (H P H^T + R)^-1 dy (matrix inversion
    # lemma, checked in the tests) but a 6x6 solve, well conditioned even for a loose prior
    cov = np.linalg.inv(h.T @ h / r_var + np.linalg.inv(p))
    dx = cov @ (h.T @ dy) / r_var
    return WlsResult(dx, cov)


def parameter_error_model(sigma_theta, propagation: str, name: str = "msa") -> ErrorModel:
    """ISCWSA error model of the six 1-sigma MSA parameter uncertainties (bias uT, scale -) in one mode."""
    sig = np.asarray(sigma_theta, dtype=float)
    if sig.shape != (6,) or not np.all(np.isfinite(sig)) or np.any(sig < 0):
        raise NodesimError("covariance method: sigma_theta must be 6 finite values >= 0 (b_x, b_y, b_z uT, s_x, s_y, s_z)")
    units = ("nT",) * 3 + ("-",) * 3
    values = np.concatenate([sig[:3] * 1e3, sig[3:]])
    sources = tuple(
        ErrorSource(f"{w}-{propagation}", w, float(v), unit, propagation, "MSA parameter uncertainty")
        for w, v, unit in zip(MAGNETIC_TERMS, values, units)
    )
    return ErrorModel(f"{name}-{propagation}", sources, magnetic_azimuth=True)


def covariance_position(md_m, inc_deg, azi_deg, sigma_theta, reference: FieldReference, propagation: str = "R") -> np.ndarray:
    """NEV covariance (n, 3, 3) [m^2, 1 sigma] of every station from the MSA parameter uncertainties.

    ``propagation`` "R" (SV Table 10) or "S" (SV Table 11); balanced tangential as in SV."""
    if propagation not in ("R", "S"):
        raise NodesimError(f"covariance method: propagation '{propagation}' unknown; allowed: R, S")
    survey = make_survey(md_m, inc_deg, azi_deg, where="covariance method")
    site = Site(dip_deg=reference.dip_deg, b_total_nt=reference.b_total_ut * 1e3)
    return propagate(survey, parameter_error_model(sigma_theta, propagation), site, method="balanced_tangential").cov_nev_m2
