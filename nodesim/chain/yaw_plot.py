"""Yaw error and bias estimate of every node against time, one realization (like thesis figs 4.14 and 4.18).

Drawn from per-node traces of the run's ``timeseries`` rows (:func:`nodesim.chain.run_tables.timeseries_columns`):
:func:`node_trace` makes one from a node's rows, a streamed run makes them node by node while it writes the rows
(:mod:`nodesim.chain.streaming`), :func:`traces_of_table` from a whole table, so a run loaded from its directory
plots the same figure as the run that wrote it.  A trace keeps every tick up to :data:`TRACE_POINTS`; a longer
node keeps, per bin of consecutive ticks, the ticks of its smallest and largest yaw error (min-max decimation:
the envelope a line plot at the figure's width shows, without drawing every tick of a day).  With more than
:data:`LEGEND_MAX_NODES` nodes the figure draws that many of them (evenly spread, the top and the bottom node
among them) over a grey band: the smallest to largest yaw error of all nodes per time bin.  Built on
:class:`matplotlib.figure.Figure` (no pyplot, no backend change); matplotlib is imported only when a figure is
drawn.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np

LEGEND_MAX_NODES = 12
TRACE_POINTS = 4000  # ticks a node's trace keeps before min-max decimation
BAND_BINS = 1000  # time bins of the all-nodes band


@dataclass(frozen=True)
class NodeTrace:
    """What the figure draws of one node: its ticks (t NaN where its filter is not running: not drawn)."""

    node_id: int
    t_s: np.ndarray
    yaw_error_deg: np.ndarray
    bias_est_deg_s: np.ndarray
    bias_true_deg_s: np.ndarray


def node_trace(rows: Mapping[str, np.ndarray], max_points: int = TRACE_POINTS) -> NodeTrace:
    """The trace of one node's timeseries ``rows`` (module docstring): all of them up to ``max_points``, else per bin
    of b = ceil(2 K / max_points) ticks the ticks of the bin's smallest and largest yaw error, in time order."""
    show = np.asarray(rows["running"]).astype(bool)
    t = np.where(show, np.asarray(rows["t_s"], dtype=float), np.nan)
    err = np.asarray(rows["yaw_error_deg"], dtype=float)
    est, true = np.asarray(rows["bias_est_deg_s"], dtype=float), np.asarray(rows["bias_true_deg_s"], dtype=float)
    K = t.size
    if K > max_points:
        b = -(-2 * K // max_points)
        starts = np.arange(0, K, b)
        key = np.where(np.isnan(err), 0.0, err)
        pad = (-K) % b
        blocks = np.concatenate([key, np.full(pad, key[-1])]).reshape(-1, b)
        lo, hi = starts + blocks.argmin(axis=1), starts + blocks.argmax(axis=1)
        keep = np.zeros(K, dtype=bool)
        keep[np.minimum(lo, K - 1)] = True
        keep[np.minimum(hi, K - 1)] = True
        t, err, est, true = t[keep], err[keep], est[keep], true[keep]
    return NodeTrace(int(np.asarray(rows["node"])[0]), t, err, est, true)


def traces_of_table(timeseries: Mapping[str, np.ndarray], max_points: int = TRACE_POINTS) -> list[NodeTrace]:
    """One :func:`node_trace` per node of a whole timeseries table, in table order (top node first)."""
    node = np.asarray(timeseries["node"])
    if not node.size:
        return []
    starts = np.flatnonzero(np.concatenate([[True], node[1:] != node[:-1]]))
    ends = np.concatenate([starts[1:], [node.size]])
    keys = ("node", "t_s", "running", "yaw_error_deg", "bias_est_deg_s", "bias_true_deg_s")
    cols = {k: np.asarray(timeseries[k]) for k in keys}
    return [node_trace({k: v[a:b] for k, v in cols.items()}, max_points) for a, b in zip(starts, ends)]


def _shown(traces: Sequence[NodeTrace]) -> list[NodeTrace]:
    """Every trace, or LEGEND_MAX_NODES of them evenly spread (the first and the last among them)."""
    if len(traces) <= LEGEND_MAX_NODES:
        return list(traces)
    pick = np.unique(np.round(np.linspace(0, len(traces) - 1, LEGEND_MAX_NODES)).astype(int))
    return [traces[i] for i in pick]


def _band(traces: Sequence[NodeTrace]) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """(bin centres, smallest, largest yaw error) of all traces per time bin (bins without a point: NaN)."""
    t = np.concatenate([x.t_s for x in traces])
    e = np.concatenate([x.yaw_error_deg for x in traces])
    ok = np.isfinite(t) & np.isfinite(e)
    if not ok.any():
        return None
    t, e = t[ok], e[ok]
    edges = np.linspace(t.min(), t.max() + 1e-9, BAND_BINS + 1)
    idx = np.clip(np.searchsorted(edges, t, side="right") - 1, 0, BAND_BINS - 1)
    lo, hi = np.full(BAND_BINS, np.inf), np.full(BAND_BINS, -np.inf)
    np.minimum.at(lo, idx, e)
    np.maximum.at(hi, idx, e)
    empty = ~np.isfinite(lo)
    lo[empty], hi[empty] = np.nan, np.nan
    return 0.5 * (edges[:-1] + edges[1:]), lo, hi


def yaw_figure(traces: Sequence[NodeTrace], rotation_end_s: float, title: str):
    """Top: yaw error [deg]; bottom: bias estimate [deg/s] with the true bias dashed, per node (module docstring);
    the end of the last rotation as a dotted line.  Ticks where a node's filter is not running are not drawn."""
    import matplotlib
    from matplotlib.figure import Figure

    fig = Figure(figsize=(10, 7))
    axes = fig.subplots(2, 1, sharex=True)
    colors = matplotlib.rcParams["axes.prop_cycle"].by_key()["color"]
    lo, hi = np.inf, -np.inf
    shown = _shown(traces)
    if len(shown) < len(traces):
        band = _band(traces)
        if band is not None:
            axes[0].fill_between(band[0], band[1], band[2], color="0.8", lw=0, label=f"all {len(traces)} nodes")
    for i, x in enumerate(shown):
        c = colors[i % len(colors)]
        label = f"node {x.node_id}"
        axes[0].plot(x.t_s, x.yaw_error_deg, lw=0.7, color=c, label=label)
        axes[1].plot(x.t_s, x.bias_est_deg_s, lw=0.7, color=c, label=label)
        axes[1].plot(x.t_s, x.bias_true_deg_s, lw=0.7, ls="--", color=c)
        show = np.isfinite(x.t_s)
        if show.any():
            both = np.concatenate([x.bias_est_deg_s[show], x.bias_true_deg_s[show]])
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
    if shown and len(shown) <= LEGEND_MAX_NODES:
        axes[0].legend(loc="best", fontsize=7, ncol=2)
    fig.suptitle(title)
    fig.tight_layout()
    return fig
