"""Covariance to geometry: HLA frame, ellipsoid semi-axes and orientation, confidence scaling.

HLA: H high side, L lateral (right, looking down-hole), A along hole; unit vectors in N/E/V
(ISCWSA workbooks; covariance-method thesis eq 49 corrected, digest msa 9.7)::

    H = (cosI cosA, cosI sinA, -sinI),  L = (-sinA, cosA, 0),  A = (sinI cosA, sinI sinA, cosI)

and C_HLA = M^T C_NEV M with M = [H L A] (columns).
"""

from __future__ import annotations

import numpy as np
from scipy import stats

from nodesim.errors import NodesimError

SIGMA_LEVELS = ("1", "2", "95")


def hla_matrix(inc_rad, azi_rad) -> np.ndarray:
    """(n, 3, 3) matrices whose columns are H, L, A in N/E/V."""
    i = np.asarray(inc_rad, dtype=float)
    a = np.asarray(azi_rad, dtype=float)
    ci, si, ca, sa = np.cos(i), np.sin(i), np.cos(a), np.sin(a)
    h = np.stack([ci * ca, ci * sa, -si], axis=-1)
    lat = np.stack([-sa, ca, np.zeros_like(a)], axis=-1)
    along = np.stack([si * ca, si * sa, ci], axis=-1)
    return np.stack([h, lat, along], axis=-1)


def nev_to_hla(cov_nev, inc_rad, azi_rad) -> np.ndarray:
    """C_HLA = M^T C_NEV M for every station."""
    m = hla_matrix(inc_rad, azi_rad)
    return np.einsum("nji,njk,nkl->nil", m, np.asarray(cov_nev, dtype=float), m)


def ellipsoid_axes(cov) -> tuple[np.ndarray, np.ndarray]:
    """1-sigma semi-axes (n, 3), largest first, and their unit vectors (n, 3, 3) as columns."""
    vals, vecs = np.linalg.eigh(np.asarray(cov, dtype=float))
    vals = np.clip(vals[..., ::-1], 0.0, None)
    return np.sqrt(vals), vecs[..., ::-1]


def horizontal_ellipse(cov_nev) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """1-sigma horizontal ellipse: semi-major, semi-minor [m] and azimuth of the major axis [rad, 0..pi)."""
    c = np.asarray(cov_nev, dtype=float)[..., :2, :2]
    axes, vecs = ellipsoid_axes(c)
    major = vecs[..., :, 0]
    azi = np.remainder(np.arctan2(major[..., 1], major[..., 0]), np.pi)
    return axes[..., 0], axes[..., 1], azi


def confidence_scale(level: str | float, dof: int = 1) -> float:
    """Factor on 1-sigma axes: '1' -> 1, '2' -> 2, '95' -> the 95 % quantile for ``dof`` dimensions
    (sqrt of the chi-square quantile: 1.960 per axis, 2.448 for a horizontal ellipse, 2.796 for the
    ellipsoid).  A float in (0, 1) is a probability."""
    key = str(level)
    if key in ("1", "1.0"):
        return 1.0
    if key in ("2", "2.0"):
        return 2.0
    if key == "95":
        p = 0.95
    else:
        try:
            p = float(level)
        except (TypeError, ValueError):
            raise NodesimError(f"sigma level '{level}' unknown; allowed: 1, 2, 95 or a probability in (0, 1)") from None
        if not 0.0 < p < 1.0:
            raise NodesimError(f"sigma level '{level}' unknown; allowed: 1, 2, 95 or a probability in (0, 1)")
    if dof not in (1, 2, 3):
        raise NodesimError(f"dof must be 1, 2 or 3, got {dof}")
    return float(np.sqrt(stats.chi2.ppf(p, dof)))
