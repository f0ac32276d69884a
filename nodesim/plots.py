"""Plots of a run (matplotlib, Agg backend: no display needed)."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from nodesim.results import atomic_write_with  # noqa: E402
from nodesim.simulation import LabRun  # noqa: E402
from nodesim.units import rad_to_deg, wrap_pi  # noqa: E402


def plot_lab_run(run: LabRun, path: Path, title: str) -> None:
    """Yaw error, azimuth error and bias estimate of realization 0 against time."""
    t = run.t_s
    fig, axes = plt.subplots(3, 1, figsize=(9, 8), sharex=True)
    yaw_err = rad_to_deg(wrap_pi(run.yaw_est_rad[0] - run.true_yaw_rad))
    azi_err = rad_to_deg(wrap_pi(run.azimuth_rad[0] - run.true_azimuth_rad))
    axes[0].plot(t, yaw_err, lw=0.8)
    axes[0].set_ylabel("yaw error [deg]")
    axes[1].plot(t, azi_err, lw=0.8, color="tab:green")
    axes[1].set_ylabel("azimuth error [deg]\n(moving average)")
    axes[2].plot(t, rad_to_deg(run.bias_est_rad_s[0]), lw=0.8, label="estimated")
    axes[2].plot(t, rad_to_deg(run.true_bias_rad_s[0]), lw=0.8, ls="--", label="true")
    axes[2].set_ylabel("z-gyro bias [deg/s]")
    axes[2].set_xlabel("time [s]")
    axes[2].legend(loc="best")
    updates = t[run.update_mask[0]]
    for ax in axes:
        ax.axvline(run.filter_start_s, color="0.6", lw=0.6, ls=":")
        ax.axvline(run.rotation_end_s, color="0.3", lw=0.6, ls=":")
        ax.grid(True, lw=0.3)
    if updates.size:
        axes[0].plot(updates, np.zeros_like(updates), "|", color="tab:red", ms=4, label="reference update")
        axes[0].legend(loc="best")
    # bias axis: zoom on the converged part (the turn-on bias dominates before the filter starts)
    after = t > run.filter_start_s
    if after.any():
        lo = rad_to_deg(min(run.true_bias_rad_s[0][after].min(), run.bias_est_rad_s[0][after].min()))
        hi = rad_to_deg(max(run.true_bias_rad_s[0][after].max(), run.bias_est_rad_s[0][after].max()))
        pad = 0.1 * (hi - lo) + 1e-3
        axes[2].set_ylim(lo - pad, hi + pad)
    fig.suptitle(title)
    fig.tight_layout()
    atomic_write_with(path, lambda p: fig.savefig(p, dpi=110, format="png"))
    plt.close(fig)
