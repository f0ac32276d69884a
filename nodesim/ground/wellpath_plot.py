"""Plot of a wellpath with its uncertainty ellipses (matplotlib object-oriented API: the backend is left alone)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from matplotlib.patches import Ellipse

from nodesim.ground.covariance import Uncertainty
from nodesim.ground.ellipsoid import horizontal_ellipse
from nodesim.io.rundir import write_png


MAX_ELLIPSES = 200


def uncertainty_figure(u: Uncertainty, scale: float, title: str) -> Figure:
    """Plan view (E, N) with the horizontal ellipses and the TVD band against MD, both at ``scale`` sigma."""
    p = u.path
    major, minor, azi = horizontal_ellipse(u.cov_nev_m2)
    sd_tvd = np.sqrt(np.clip(u.cov_nev_m2[:, 2, 2], 0.0, None))
    fig = Figure(figsize=(11, 5))
    ax0, ax1 = fig.subplots(1, 2)
    ax0.plot(p.e_m, p.n_m, "-o", ms=2.5, lw=1.0, color="tab:blue", label="wellpath")
    stride = max(1, len(p.n_m) // MAX_ELLIPSES)  # long wells: draw every stride-th ellipse and the last
    for k in sorted(set(range(0, len(p.n_m), stride)) | {len(p.n_m) - 1}):
        if major[k] <= 0:
            continue
        # Ellipse angle is counter-clockwise from the x (east) axis; the major axis azimuth is clockwise from north
        ax0.add_patch(
            Ellipse(
                (p.e_m[k], p.n_m[k]),
                2 * scale * major[k],
                2 * scale * minor[k],
                angle=float(np.degrees(np.pi / 2 - azi[k])),
                fill=False,
                lw=0.7,
                color="tab:red",
            )
        )
    ax0.set_xlabel("East [m]")
    ax0.set_ylabel("North [m]")
    ax0.set_aspect("equal", adjustable="datalim")
    ax0.grid(True, lw=0.3)
    ax0.set_title(f"plan view, {scale:g} sigma ellipses")
    ax1.plot(p.survey.md_m, scale * sd_tvd, color="tab:green", label="TVD")
    ax1.plot(p.survey.md_m, scale * major, color="tab:red", label="horizontal semi-major")
    ax1.plot(p.survey.md_m, scale * minor, color="tab:orange", label="horizontal semi-minor")
    ax1.set_xlabel("MD [m]")
    ax1.set_ylabel(f"uncertainty ({scale:g} sigma) [m]")
    ax1.grid(True, lw=0.3)
    ax1.legend(loc="best")
    fig.suptitle(title)
    fig.tight_layout()
    return fig


def plot_uncertainty(u: Uncertainty, path: Path, scale: float, title: str) -> None:
    """Write :func:`uncertainty_figure` to ``path`` as PNG, atomically."""
    write_png(path, uncertainty_figure(u, scale, title))
