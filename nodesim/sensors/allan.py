"""Overlapping Allan variance and the automatic reading of its noise terms (thesis appendix V).

Estimator (thesis eqs V.24-V.29, IEEE Std 952-1997 C.1, the overlapping "cluster" form).  From rate
samples y_k at interval t0 the integrated angle x_k = t0 sum_{i<k} y_i (x_0 = 0) is built once with a
cumulative sum; for a cluster of n samples (tau = n t0)

    sigma^2(tau) = sum_{k=0}^{N-2n} (x_{k+2n} - 2 x_{k+n} + x_k)^2 / (2 tau^2 (N - 2n + 1))

over the N + 1 angle points, i.e. 1/2 <(ybar_{k+n} - ybar_k)^2> with ybar_k the mean of y over the
cluster starting at k.  Each tau costs one vectorised pass, so a 2 h record at 65 Hz (468 000 samples)
and ~100 cluster sizes takes well under a second.  Estimation error of one value
delta = 1 / sqrt(2 (N/n - 1)) (V.30).

Reading of the curve (thesis appendix V and 3.x: "fitting a straight line through the slope and reading
its value at tau = 1 ... the bias instability ... is the minimum value"):

* angle random walk N: the -1/2 slope line sigma = N / sqrt(tau) fitted (in log space, slope fixed)
  over the points below the minimum whose local log-log slope is within 0.05 of -1/2, read at tau = 1 s
  (reading sigma(1 s) directly would include the bias-instability part where the two terms cross);
* bias instability: the flat minimum of the curve, i.e. the points within 20 % of the minimum sigma_min
  (searched where the V.30 estimation error is below ``max_relative_error``), averaged in variance with
  the fitted white-noise part N^2 / tau removed (averaging the flat region instead of taking the single
  lowest point avoids the low bias of a minimum over noisy estimates);
  the IEEE coefficient is B = floor / 0.664 (eq V.34 plateau sqrt(2 ln 2 / pi) = 0.6643 B).  The thesis
  (table V.1) quotes the minimum itself as "bias stability"; both are reported.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from nodesim.errors import NodesimError

if TYPE_CHECKING:
    from matplotlib.figure import Figure

FLICKER_FLOOR_FACTOR = math.sqrt(2.0 * math.log(2.0) / math.pi)
"""Allan-deviation plateau of bias instability per unit B (eq V.34): 0.6643."""


@dataclass(frozen=True)
class AllanCurve:
    """Allan deviation ``adev`` at averaging times ``tau_s``, with cluster sizes and the V.30 error."""

    tau_s: np.ndarray
    adev: np.ndarray
    clusters: np.ndarray  # cluster size n of each tau
    n_samples: int

    @property
    def relative_error(self) -> np.ndarray:
        """Estimation error of each value, eq V.30: 1 / sqrt(2 (N/n - 1))."""
        return 1.0 / np.sqrt(2.0 * (self.n_samples / self.clusters - 1.0))


@dataclass(frozen=True)
class AllanNoise:
    """Noise terms read from an Allan curve (rate units of the input, e.g. rad/s -> N in rad/sqrt(s))."""

    arw: float  # angle (or velocity) random walk N, Allan deviation of the -1/2 line at tau = 1 s
    allan_minimum: float  # the minimum deviation (thesis table V.1 "bias stability")
    bias_instability: float  # IEEE coefficient B = floor / 0.664
    tau_at_minimum_s: float  # thesis: read as the bias correlation time
    arw_fit_tau_range_s: tuple[float, float]


def cluster_sizes(n_samples: int, points_per_decade: int = 20, max_fraction: float = 0.5) -> np.ndarray:
    """Log-spaced distinct cluster sizes from 1 to ``max_fraction`` N (V.29 requires n <= N/2)."""
    top = max(1, int(n_samples * max_fraction))
    sizes = np.unique(np.round(np.logspace(0, math.log10(top), int(points_per_decade * math.log10(top)) + 1)).astype(int))
    return sizes[(sizes >= 1) & (sizes <= top)]


def overlapping_adev(rate, dt_s: float, clusters: np.ndarray | None = None) -> AllanCurve:
    """Overlapping Allan deviation of a rate series sampled every ``dt_s`` (see module doc)."""
    y = np.asarray(rate, dtype=float)
    if y.ndim != 1:
        raise NodesimError(f"Allan variance: rate series must be one-dimensional (got shape {y.shape})")
    if y.size < 3:
        raise NodesimError(f"Allan variance: need at least 3 samples (got {y.size})")
    if not np.all(np.isfinite(y)):
        bad = int(np.flatnonzero(~np.isfinite(y))[0])
        raise NodesimError(f"Allan variance: sample {bad} is not finite ({y[bad]})")
    if not dt_s > 0.0:
        raise NodesimError(f"Allan variance: sample interval dt_s = {dt_s} must be > 0")
    n = y.size
    sizes = cluster_sizes(n) if clusters is None else np.asarray(clusters, dtype=int)
    if sizes.size == 0 or sizes.min() < 1 or sizes.max() > n // 2:
        raise NodesimError(f"Allan variance: cluster sizes must lie in 1..{n // 2} (N/2, eq V.29)")
    x = np.concatenate([[0.0], np.cumsum(y - y.mean())]) * dt_s  # removing the mean does not change sigma
    avar = np.empty(sizes.size)
    for i, m in enumerate(sizes):
        d = x[2 * m :] - 2.0 * x[m:-m] + x[: -2 * m]
        avar[i] = np.dot(d, d) / (2.0 * (m * dt_s) ** 2 * d.size)
    return AllanCurve(tau_s=sizes * dt_s, adev=np.sqrt(avar), clusters=sizes, n_samples=n)


def naive_overlapping_adev(rate, dt_s: float, clusters) -> np.ndarray:
    """Reference implementation with explicit cluster means (pure Python loops): tests and benchmark only."""
    y = [float(v) for v in rate]
    out = []
    for m in clusters:
        means = [sum(y[k : k + m]) / m for k in range(len(y) - m + 1)]
        diffs = [(means[k + m] - means[k]) ** 2 for k in range(len(means) - m)]
        out.append(math.sqrt(sum(diffs) / (2.0 * len(diffs))))
    return np.array(out)


def local_slopes(curve: AllanCurve) -> np.ndarray:
    """d log(adev) / d log(tau) by central differences."""
    return np.gradient(np.log(curve.adev), np.log(curve.tau_s))


def read_noise(
    curve: AllanCurve, max_relative_error: float = 0.1, slope_tolerance: float = 0.05, flat_band: float = 0.2
) -> AllanNoise:
    """Angle random walk (slope -1/2 line at tau = 1 s) and bias instability (flat minimum) of a curve.

    ``slope_tolerance``: how far from -1/2 the local slope of a point used for the ARW line may be.
    ``flat_band``: the flat minimum is every trusted point within this fraction above the minimum; its
    level is the RMS of those points after removing the fitted white noise N^2 / tau in quadrature.
    """
    trusted = curve.relative_error <= max_relative_error
    if not trusted.any():
        raise NodesimError("Allan variance: record too short for any trusted cluster size (eq V.30 error > "
                           f"{max_relative_error})")
    idx = np.flatnonzero(trusted)[np.argmin(curve.adev[trusted])]
    sigma_min = float(curve.adev[idx])
    tau_min = float(curve.tau_s[idx])
    slopes = local_slopes(curve)
    white = (np.abs(slopes + 0.5) <= slope_tolerance) & (curve.tau_s <= tau_min)
    if white.sum() < 2:
        raise NodesimError(
            "Allan variance: no -1/2 slope region below the minimum (white rate noise not visible; "
            f"shortest-tau slope {slopes[0]:.2f})"
        )
    log_n = float(np.mean(np.log(curve.adev[white]) + 0.5 * np.log(curve.tau_s[white])))
    arw = math.exp(log_n)
    flat = trusted & (curve.adev <= sigma_min * (1.0 + flat_band))
    excess = curve.adev[flat] ** 2 - arw**2 / curve.tau_s[flat]
    floor = math.sqrt(max(float(np.mean(excess)), 0.0))
    return AllanNoise(
        arw=arw,
        allan_minimum=sigma_min,
        bias_instability=floor / FLICKER_FLOOR_FACTOR,
        tau_at_minimum_s=tau_min,
        arw_fit_tau_range_s=(float(curve.tau_s[white].min()), float(curve.tau_s[white].max())),
    )


def adev_figure(curves: dict[str, AllanCurve], title: str = "Allan deviation", unit: str = "deg/s",
                scale: float = 1.0) -> Figure:
    """Log-log Allan deviation plot of one or more curves (values multiplied by ``scale``)."""
    from matplotlib.figure import Figure  # lazy: the estimator does not need matplotlib

    fig = Figure(figsize=(7, 5))
    ax = fig.subplots()
    for label, c in curves.items():
        ax.loglog(c.tau_s, c.adev * scale, label=label, lw=1.0)
    ax.set_xlabel("averaging time tau [s]")
    ax.set_ylabel(f"Allan deviation [{unit}]")
    ax.grid(True, which="both", lw=0.3)
    ax.legend(loc="best")
    ax.set_title(title)
    fig.tight_layout()
    return fig


def plot_adev(curves: dict[str, AllanCurve], path: Path, title: str = "Allan deviation", unit: str = "deg/s", scale: float = 1.0) -> None:
    """Write :func:`adev_figure` to ``path`` as PNG, atomically."""
    from nodesim.io.rundir import write_png

    fig = adev_figure(curves, title, unit, scale)
    write_png(path, fig)
