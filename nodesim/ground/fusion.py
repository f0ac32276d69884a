"""Station fusion at the ground station (thesis 3.6 and 4.3).

Repeated measurements of one survey station (the sensors of one tube's cluster, and the clusters of
later tubes passing the station) are combined:

* recursively by inverse variance (Bayes with Gaussian prior and likelihood, thesis eqs 3.33-3.41)::

      x_k = (s2_{k-1} y_k + s2_y x_{k-1}) / (s2_{k-1} + s2_y),     1/s2_k = 1/s2_{k-1} + 1/s2_y

  angles (azimuth) are fused on the circle: each new value is unwrapped against the prior first [A];
* within a cluster by normalised inverse-variance weights (eq 3.42, without the printed 1/N, digest
  section 9 #21);
* across clusters (oldest to newest) by a weighting scheme (eq 3.43, table 4.30): equal, linear (j),
  quadratic (j^2), cubic (j^3) or the cubic row as printed (1, 8, 81, 64 / 154).  A station with M
  clusters uses the first M coefficients, renormalised (digest 3.4); the fused value is
  sum w_j x_j with variance sum w_j^2 s2_j [A];
* the two-sigma change rule (thesis 3.6): a new cluster value within 2 sigma of the fused value joins
  the history; outside, if a neighbouring station (m-1 or m+1) shows a change at the same time, the
  history is reset to the new value (weight 1, all older 0); an isolated outlier is rejected [A].
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from nodesim.errors import NodesimError

_PRINTED_CUBIC = np.array([1.0, 8.0, 81.0, 64.0])  # thesis table 4.30 as printed (likely a slip for 27)
SCHEMES = ("equal", "linear", "quadratic", "cubic", "cubic_printed")


def bayes_update(mean, var, y, var_y, circular: bool = False):
    """One recursive inverse-variance update (thesis eqs 3.40-3.41); vectorised.  Returns (mean, var)."""
    mean = np.asarray(mean, dtype=float)
    y = np.asarray(y, dtype=float)
    var = np.asarray(var, dtype=float)
    var_y = np.asarray(var_y, dtype=float)
    if np.any(var <= 0) or np.any(var_y <= 0):
        raise NodesimError("fusion variances must be > 0")
    if circular:
        y = mean + np.remainder(y - mean + np.pi, 2 * np.pi) - np.pi
    new_mean = (var * y + var_y * mean) / (var + var_y)
    new_var = var * var_y / (var + var_y)
    if circular:
        new_mean = np.remainder(new_mean, 2 * np.pi)
    return new_mean, new_var


def fuse_recursive(values, variances, circular: bool = False):
    """Fuse measurements one by one (axis 0 is the measurement order).  Returns (mean, var)."""
    values = np.asarray(values, dtype=float)
    variances = np.broadcast_to(np.asarray(variances, dtype=float), values.shape)
    if values.shape[0] == 0:
        raise NodesimError("fusion needs at least one measurement")
    mean, var = values[0], variances[0]
    for y, v in zip(values[1:], variances[1:]):
        mean, var = bayes_update(mean, var, y, v, circular)
    return mean, var


def cluster_weights(variances) -> np.ndarray:
    """Within-cluster inverse-variance weights w_i = s_i^-2 / sum s_j^-2 (eq 3.42)."""
    inv = 1.0 / np.asarray(variances, dtype=float)
    return inv / inv.sum(axis=0, keepdims=True)


def scheme_weights(scheme: str, m: int) -> np.ndarray:
    """Across-cluster weights for m clusters ordered oldest -> newest (table 4.30, renormalised)."""
    if m < 1:
        raise NodesimError(f"weighting needs at least one cluster, got {m}")
    j = np.arange(1, m + 1, dtype=float)
    if scheme == "equal":
        w = np.ones(m)
    elif scheme == "linear":
        w = j
    elif scheme == "quadratic":
        w = j**2
    elif scheme == "cubic":
        w = j**3
    elif scheme == "cubic_printed":
        if m > 4:
            raise NodesimError("the printed cubic row (1, 8, 81, 64) has 4 coefficients; use 'cubic' for more clusters")
        w = _PRINTED_CUBIC[:m].copy()
    else:
        raise NodesimError(f"weighting scheme '{scheme}' unknown; allowed: {', '.join(SCHEMES)}")
    return w / w.sum()


def combine_clusters(means, variances, scheme: str = "equal"):
    """Fused value and variance of M cluster estimates (axis 0, oldest first): sum w x, sum w^2 s2."""
    means = np.asarray(means, dtype=float)
    variances = np.broadcast_to(np.asarray(variances, dtype=float), means.shape)
    w = scheme_weights(scheme, means.shape[0]).reshape((-1,) + (1,) * (means.ndim - 1))
    return (w * means).sum(axis=0), (w**2 * variances).sum(axis=0)


def error_decrease_ratio(scheme: str, m: int) -> float:
    """Error of a scheme relative to equal weights after a change seen only by the newest of m
    clusters: (1 - w_newest) / (1 - 1/m) (thesis fig 4.35, digest 3.5)."""
    if m < 2:
        raise NodesimError("the ratio needs at least 2 clusters")
    return float((1.0 - scheme_weights(scheme, m)[-1]) / (1.0 - 1.0 / m))


@dataclass
class StationHistory:
    """Cluster estimates of one station, oldest first (mutable: the ground station appends)."""

    means: list = field(default_factory=list)
    variances: list = field(default_factory=list)

    def fused(self, scheme: str = "equal"):
        if not self.means:
            raise NodesimError("station has no measurement yet")
        return combine_clusters(np.array(self.means), np.array(self.variances), scheme)


def update_stations(histories: list[StationHistory], new: dict, scheme: str = "equal", n_sigma: float = 2.0) -> dict:
    """Apply one round of new cluster values ``{station index: (value, variance)}`` with the two-sigma rule.

    Returns ``{station: "first" | "accepted" | "reset" | "rejected"}``.  A value is *outside* when
    |y - x_fused| > n_sigma * sqrt(s2_fused + s2_y).  Outside values reset the station's history when
    a neighbour (m-1 or m+1) in the same round is also outside, else they are rejected.
    """
    outside = {}
    for m, (y, vy) in new.items():
        if not 0 <= m < len(histories):
            raise NodesimError(f"station index {m} outside [0, {len(histories) - 1}]")
        h = histories[m]
        if not h.means:
            outside[m] = None
            continue
        x, vx = h.fused(scheme)
        outside[m] = bool(abs(y - x) > n_sigma * np.sqrt(vx + vy))
    status = {}
    for m, (y, vy) in new.items():
        h = histories[m]
        if outside[m] is None:
            h.means.append(y)
            h.variances.append(vy)
            status[m] = "first"
        elif not outside[m]:
            h.means.append(y)
            h.variances.append(vy)
            status[m] = "accepted"
        elif outside.get(m - 1) or outside.get(m + 1):
            h.means[:] = [y]
            h.variances[:] = [vy]
            status[m] = "reset"
        else:
            status[m] = "rejected"
    return status


def stale_increment_error(old, new, clusters, scheme: str = "equal", method: str = "balanced_tangential") -> np.ndarray:
    """Error of the fused course increments after a trajectory change seen only by the newest cluster.

    Thesis 4.3 (tables 4.26-4.29, digest 3.5): each cluster measures the increment (dN, dE, dTVD) of the
    course ending at station m; station m holds ``clusters[m]`` measurements of which only the newest
    sees the changed survey ``new``.  The fused increment is sum w_j dr_j, so its error is
    (1 - w_newest) (dr_new - dr_old).  Returns (n, 3) [m], zero at the tie-on station.
    """
    from nodesim.ground.wellpath import course_displacements

    if len(old) != len(new) or not np.array_equal(old.md_m, new.md_m):
        raise NodesimError("old and new surveys must have the same stations")
    counts = np.asarray(clusters, dtype=int)
    if counts.shape != (len(old),):
        raise NodesimError(f"clusters needs one count per station ({len(old)}), got shape {counts.shape}")
    delta = course_displacements(new, method) - course_displacements(old, method)
    out = np.zeros((len(old), 3))
    for m in range(1, len(old)):
        if counts[m] >= 1:
            out[m] = (1.0 - scheme_weights(scheme, counts[m])[-1]) * delta[m - 1]
    return out
