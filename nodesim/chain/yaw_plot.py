"""Yaw error and bias estimate of every node against time, one realization (like thesis figs 4.14 and 4.18).

Drawn from a :class:`YawPlotData` fed node by node with the run's ``timeseries`` rows
(:func:`nodesim.chain.run_tables.timeseries_columns`): a streamed run feeds it while it writes the rows
(:mod:`nodesim.chain.streaming`), :meth:`YawPlotData.from_table` from a whole table, so a run loaded from its
directory plots the same figure as the run that wrote it.  Up to :data:`LEGEND_MAX_NODES` nodes every node is
drawn; a longer chain draws that many of them (evenly spread over the nodes the table keeps, the top and the bottom
node among them) over a grey band: the smallest to largest yaw error of all its nodes per time bin (of
:data:`BAND_BINS` over the run).  A drawn node keeps every tick up to :data:`TRACE_POINTS` (:func:`node_trace`); a
longer one keeps, per bin of consecutive ticks, the ticks of its smallest and largest yaw error (min-max decimation:
the envelope a line plot at the figure's width shows, without drawing every tick of a day).  Built on
:class:`matplotlib.figure.Figure` (no pyplot, no backend change); matplotlib is imported only when a figure is
drawn.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np
from numba import njit

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
    trace = TraceBuilder(int(np.asarray(rows["node"])[0]), len(rows["t_s"]), max_points)
    trace.add(rows)
    return trace.finish()


class TraceBuilder:
    """:func:`node_trace` of a node's ``total`` rows given piece by piece (:meth:`add`, in time order): the bins of
    the rows so far are reduced as they fill, the rest waits (the same trace, point for point)."""

    def __init__(self, node_id: int, total: int, max_points: int = TRACE_POINTS):
        self.node_id = node_id
        self.b = -(-2 * total // max_points) if total > max_points else 0  # rows a bin (0: every row kept)
        self.kept: list[tuple] = []  # (t, err, est, true) pieces kept
        self.pending: tuple | None = None  # the rows of the bin being filled

    def add(self, rows: Mapping[str, np.ndarray]) -> None:
        show = np.asarray(rows["running"]).astype(bool)
        cols = (np.where(show, np.asarray(rows["t_s"], dtype=float), np.nan),
                np.asarray(rows["yaw_error_deg"], dtype=float), np.asarray(rows["bias_est_deg_s"], dtype=float),
                np.asarray(rows["bias_true_deg_s"], dtype=float))
        if self.pending is not None:
            cols = tuple(np.concatenate([a, c]) for a, c in zip(self.pending, cols))
            self.pending = None
        if not self.b:
            self.kept.append(cols)
            return
        full = cols[0].size // self.b * self.b
        if full < cols[0].size:
            self.pending = tuple(c[full:] for c in cols)
        if full:
            self.kept.append(self._reduce(tuple(c[:full] for c in cols)))

    def _reduce(self, cols: tuple) -> tuple:
        """Per bin of b rows (the last one padded with its last row), the rows of the smallest and largest error."""
        b, err = self.b, cols[1]
        K = err.size
        starts = np.arange(0, K, b)
        key = np.where(np.isnan(err), 0.0, err)
        pad = (-K) % b
        blocks = np.concatenate([key, np.full(pad, key[-1])]).reshape(-1, b)
        lo, hi = starts + blocks.argmin(axis=1), starts + blocks.argmax(axis=1)
        keep = np.zeros(K, dtype=bool)
        keep[np.minimum(lo, K - 1)] = True
        keep[np.minimum(hi, K - 1)] = True
        return tuple(c[keep] for c in cols)

    def finish(self) -> NodeTrace:
        if self.pending is not None and self.pending[0].size:
            self.kept.append(self._reduce(self.pending) if self.b else self.pending)
            self.pending = None
        cols = [np.concatenate([k[i] for k in self.kept]) if self.kept else np.zeros(0) for i in range(4)]
        return NodeTrace(self.node_id, *cols)


@njit(cache=True, _nrt=False, nogil=True)
def band_add(t_s, running, yaw_error_deg, duration_s, lo, hi) -> None:
    """The band (``lo``, ``hi``: per time bin i = clip(floor(t / duration_s * B), 0, B - 1) of B, the smallest and
    largest yaw error so far) with one node's running ticks of finite yaw error; one compiled pass (it runs on a
    streamed run's output thread, beside phase 2: no GIL held)."""
    B = lo.size
    for k in range(t_s.size):
        e = yaw_error_deg[k]
        if running[k] == 0 or not np.isfinite(e):
            continue
        i = min(max(np.int64(t_s[k] / duration_s * B), 0), B - 1)
        lo[i] = min(lo[i], e)
        hi[i] = max(hi[i], e)


def shown_nodes(node_ids: Sequence[int]) -> list[int]:
    """The node ids the figure draws: every one of ``node_ids`` (the nodes a table keeps, in table order) up to
    LEGEND_MAX_NODES, else that many evenly spread (the first and the last among them)."""
    if len(node_ids) <= LEGEND_MAX_NODES:
        return list(node_ids)
    pick = np.unique(np.round(np.linspace(0, len(node_ids) - 1, LEGEND_MAX_NODES)).astype(int))
    return [node_ids[i] for i in pick]


class YawPlotData:
    """What the yaw figure needs of a run, fed one node's rows at a time (:meth:`add`, in table order): the traces
    of the nodes it draws (:func:`shown_nodes` of ``node_ids``) and, for a longer chain, the band of every node's
    yaw error over [0, ``duration_s``] (module docstring)."""

    def __init__(self, node_ids: Sequence[int], duration_s: float):
        self.node_ids = list(node_ids)
        self.shown = set(shown_nodes(self.node_ids))
        self.duration_s = float(duration_s)
        self._traces: dict[int, TraceBuilder] = {}  # the drawn nodes' traces (a node's rows may come in windows of
        # time, :mod:`nodesim.chain.compiled.time_windows`)
        self.band = None
        if len(self.shown) < len(self.node_ids):
            self.band = (np.full(BAND_BINS, np.inf), np.full(BAND_BINS, -np.inf))

    @classmethod
    def from_table(cls, timeseries: Mapping[str, np.ndarray], duration_s: float) -> "YawPlotData":
        """Fed with every node of a whole timeseries table (a node's rows in one block, or in blocks in time order:
        a run in windows of time writes each window's rows of every node)."""
        node = np.asarray(timeseries["node"])
        starts = np.flatnonzero(np.concatenate([[True], node[1:] != node[:-1]])) if node.size else np.zeros(0, int)
        ends = np.concatenate([starts[1:], [node.size]])
        ids, totals = np.unique(node, return_counts=True)
        data = cls([int(i) for i in ids], duration_s)
        total = dict(zip(ids.tolist(), totals.tolist()))
        keys = ("node", "t_s", "running", "yaw_error_deg", "bias_est_deg_s", "bias_true_deg_s")
        cols = {k: np.asarray(timeseries[k]) for k in keys}
        for a, b in zip(starts, ends):
            data.add({k: v[a:b] for k, v in cols.items()}, total[int(node[a])])
        return data

    def add(self, rows: Mapping[str, np.ndarray], total_rows: int | None = None) -> None:
        """One node's rows (its timeseries columns), all of them, or a piece of its ``total_rows`` (the pieces in
        time order)."""
        node_id = int(np.asarray(rows["node"])[0])
        if node_id in self.shown:
            if node_id not in self._traces:
                self._traces[node_id] = TraceBuilder(node_id, len(rows["t_s"]) if total_rows is None else total_rows)
            self._traces[node_id].add(rows)
        if self.band is None:
            return
        lo, hi = self.band
        band_add(np.ascontiguousarray(rows["t_s"], dtype=float), np.ascontiguousarray(rows["running"], dtype=np.int64),
                 np.ascontiguousarray(rows["yaw_error_deg"], dtype=float), self.duration_s, lo, hi)

    @property
    def traces(self) -> list[NodeTrace]:
        """The drawn nodes' traces (:func:`node_trace` of all the rows each was given), in node order (after the
        last rows)."""
        return [self._traces[i].finish() for i in sorted(self._traces)]

    def band_deg(self) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """(bin centres [s], smallest, largest yaw error [deg]) of the bins any node had a point in, or None."""
        if self.band is None:
            return None
        lo, hi = self.band
        have = np.isfinite(lo)
        centres = (np.arange(BAND_BINS) + 0.5) * self.duration_s / BAND_BINS
        return (centres[have], lo[have], hi[have]) if have.any() else None


def import_matplotlib() -> None:
    """Import what :func:`yaw_figure` and its PNG need (~0.3 s the first time, then a look-up): a streamed run
    (``nodesim run``) calls it on its output thread with each node it keeps, so the import is done beside phase 2
    rather than after the simulation, when no other work is left to overlap it."""
    import matplotlib.backends.backend_agg  # noqa: F401 - savefig's PNG canvas
    import matplotlib.figure  # noqa: F401


def yaw_figure(data: YawPlotData, rotation_end_s: float, title: str):
    """Top: yaw error [deg]; bottom: bias estimate [deg/s] with the true bias dashed, per drawn node (module
    docstring); the end of the last rotation as a dotted line.  Ticks where a node's filter is not running are not
    drawn."""
    import matplotlib
    from matplotlib.figure import Figure

    fig = Figure(figsize=(10, 7))
    axes = fig.subplots(2, 1, sharex=True)
    colors = matplotlib.rcParams["axes.prop_cycle"].by_key()["color"]
    lo, hi = np.inf, -np.inf
    band = data.band_deg()
    if band is not None:
        axes[0].fill_between(band[0], band[1], band[2], color="0.8", lw=0, label=f"all {len(data.node_ids)} nodes")
    shown = data.traces
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
    if shown:
        axes[0].legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=7, borderaxespad=0.0)
    fig.suptitle(title)
    # fixed margins, the legend right of the axes (it hides no data): matplotlib's tight_layout and legend
    # loc="best" each measured ~0.1-0.25 s on the drilling day's figure, which is drawn after the simulation
    fig.subplots_adjust(left=0.08, right=0.86, bottom=0.07, top=0.93, hspace=0.08)
    return fig
