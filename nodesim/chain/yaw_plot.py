"""Yaw error and bias estimate of every node against time, one realization (like thesis figs 4.14 and 4.18).

Drawn from the run's ``timeseries`` table (:func:`nodesim.chain.run_tables.timeseries_columns`), so a run
loaded from its directory plots the same figure as the run that wrote it.  Built on
:class:`matplotlib.figure.Figure` (no pyplot, no backend change); matplotlib is imported only when a figure
is drawn.
"""

from __future__ import annotations

from typing import Mapping

import numpy as np

LEGEND_MAX_NODES = 12


def yaw_figure(timeseries: Mapping[str, np.ndarray], rotation_end_s: float, title: str):
    """Top: yaw error [deg]; bottom: bias estimate [deg/s] with the true bias dashed, per node; the end of
    the last rotation as a dotted line.  Ticks where a node's filter is not running are not drawn."""
    import matplotlib
    from matplotlib.figure import Figure

    cols = {k: np.asarray(timeseries[k]) for k in ("node", "t_s", "running", "yaw_error_deg", "bias_est_deg_s",
                                                     "bias_true_deg_s")}
    fig = Figure(figsize=(10, 7))
    axes = fig.subplots(2, 1, sharex=True)
    colors = matplotlib.rcParams["axes.prop_cycle"].by_key()["color"]
    lo, hi = np.inf, -np.inf
    node_ids = list(dict.fromkeys(cols["node"].tolist()))  # in table order (top node first)
    for i, node_id in enumerate(node_ids):
        rows = cols["node"] == node_id
        c = colors[i % len(colors)]
        show = cols["running"][rows].astype(bool)
        t = np.where(show, cols["t_s"][rows], np.nan)
        est, true = cols["bias_est_deg_s"][rows], cols["bias_true_deg_s"][rows]
        label = f"node {node_id}"
        axes[0].plot(t, cols["yaw_error_deg"][rows], lw=0.7, color=c, label=label)
        axes[1].plot(t, est, lw=0.7, color=c, label=label)
        axes[1].plot(t, true, lw=0.7, ls="--", color=c)
        if show.any():
            both = np.concatenate([est[show], true[show]])
            lo, hi = min(lo, both.min()), max(hi, both.max())
    axes[0].set_ylabel("yaw error [deg]")
    axes[1].set_ylabel("z-gyro bias [deg/s]\n(dashed: true)")
    axes[1].set_xlabel("time [s]")
    if np.isfinite(lo):
        pad = 0.1 * (hi - lo) + 1e-3
        axes[1].set_ylim(lo - pad, hi + pad)
    for ax in axes:
        ax.axvline(rotation_end_s, color="0.3", lw=0.6, ls=":")
        ax.grid(True, lw=0.3)
    if len(node_ids) <= LEGEND_MAX_NODES:
        axes[0].legend(loc="best", fontsize=7, ncol=2)
    fig.suptitle(title)
    fig.tight_layout()
    return fig
