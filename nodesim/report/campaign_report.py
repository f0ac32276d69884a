"""Campaign report: every metric against every swept axis with percentile bands, and the best points.

Reads ``campaign.json`` and the campaign table (``results.parquet`` plus any part files not yet
consolidated, through :class:`nodesim.sweep.store.CampaignStore`).  Only ``ok`` runs enter the plots.

- *Metric vs axis*: at each value of the axis, the median over every run with that value (all seeds; with
  two axes, one line per value of the other axis when it has at most ``MAX_LINES`` values, otherwise pooled),
  a 25-75 % band and a 5-95 % band.  Categorical axes (strings) are placed at equal spacing.
- *Best points*: runs are averaged per point (mean over the seeds that finished); ``where`` filters those
  points with a pandas query on the per-point means (dotted keys may be written bare, e.g.
  ``schedule.timeout_s <= 30 and rms_azimuth_error_deg < 0.25``); ``minimize`` / ``maximize`` orders them;
  the ``top`` best are shown.
"""

from __future__ import annotations

import re

import matplotlib
import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from nodesim.errors import NodesimError
from nodesim.report.html import Page
from nodesim.sweep.campaign import read_manifest
from nodesim.sweep.spec import RESERVED_COLUMNS
from nodesim.sweep.store import CampaignStore

MAX_LINES = 6
BANDS = ((5, 95, 0.15), (25, 75, 0.3))


def per_point(ok: pd.DataFrame, axes: list[str], metrics: list[str]) -> pd.DataFrame:
    """Mean of every metric over the seeds of each point, with the number of seeds that finished."""
    agg = ok.groupby("point", sort=True).agg({**{a: "first" for a in axes}, **{m: "mean" for m in metrics}, "seed": "count"})
    return agg.rename(columns={"seed": "seeds_ok"}).reset_index()


def _backtick(expr: str, columns: list[str]) -> str:
    """Let users write dotted column names bare: wrap them in backticks for pandas.query."""
    for col in sorted((c for c in columns if not c.isidentifier()), key=len, reverse=True):
        expr = re.sub(rf"(?<![\w.`]){re.escape(col)}(?![\w.`])", f"`{col}`", expr)
    return expr


def best_points(table: pd.DataFrame, axes: list[str], metrics: list[str], where: str | None, minimize: str | None,
                maximize: str | None, top: int) -> pd.DataFrame:
    """The ``top`` points (per-point means) satisfying ``where``, ordered by ``minimize`` or ``maximize``."""
    if minimize and maximize:
        raise NodesimError("give --minimize or --maximize, not both")
    key = minimize or maximize
    if key is not None and key not in metrics:
        raise NodesimError(f"--{'minimize' if minimize else 'maximize'} {key!r}: not a metric of this campaign; metrics: {metrics}")
    points = per_point(table[table["status"] == "ok"], axes, metrics)
    if where:
        try:
            points = points.query(_backtick(where, list(points.columns)))
        except Exception as err:  # noqa: BLE001 - pandas raises many types for a bad expression
            raise NodesimError(f"--where {where!r}: {type(err).__name__}: {err}; columns: {list(points.columns)}") from None
    if key is not None:
        points = points.sort_values(key, ascending=bool(minimize), kind="stable")
    return points.head(top)


def _numeric(values: pd.Series) -> bool:
    return pd.api.types.is_numeric_dtype(values) and not pd.api.types.is_bool_dtype(values)


def _band_plot(ax, ok: pd.DataFrame, axis: str, metric: str, positions: dict, label: str | None, color) -> None:
    grouped = ok.groupby(axis, sort=True)[metric]
    xs = np.array([positions[v] for v in grouped.groups])
    q = {p: grouped.quantile(p / 100.0).to_numpy() for p in (5, 25, 50, 75, 95)}
    for lo, hi, alpha in BANDS:
        ax.fill_between(xs, q[lo], q[hi], alpha=alpha, color=color, lw=0)
    ax.plot(xs, q[50], "o-", ms=3, lw=1.0, color=color, label=label)


def metric_vs_axis_figure(ok: pd.DataFrame, axis: str, metric: str, other: str | None) -> Figure:
    fig = Figure(figsize=(7.5, 4.2))
    ax = fig.subplots()
    values = sorted(ok[axis].unique(), key=lambda v: (isinstance(v, str), v))
    numeric = _numeric(ok[axis])
    positions = {v: (float(v) if numeric else i) for i, v in enumerate(values)}
    colors = matplotlib.rcParams["axes.prop_cycle"].by_key()["color"]
    if other is not None and ok[other].nunique() <= MAX_LINES:
        for i, (ov, g) in enumerate(ok.groupby(other, sort=True)):
            _band_plot(ax, g.dropna(subset=[metric]), axis, metric, positions, f"{other} = {ov}", colors[i % len(colors)])
        ax.legend(fontsize=7, loc="best")
    else:
        _band_plot(ax, ok.dropna(subset=[metric]), axis, metric, positions, None, colors[0])
    if numeric:
        span = [float(v) for v in values if float(v) > 0]
        if len(span) == len(values) and len(span) > 2 and max(span) / min(span) > 50:
            ax.set_xscale("log")
    else:
        ax.set_xticks(list(positions.values()), [str(v) for v in values])
    ax.set_xlabel(axis)
    ax.set_ylabel(metric)
    ax.grid(True, lw=0.3)
    ax.set_title(f"{metric} vs {axis}: median, 25-75 % and 5-95 % bands", fontsize=9)
    fig.tight_layout()
    return fig


def campaign_page(directory, where: str | None = None, minimize: str | None = None, maximize: str | None = None,
                  top: int = 10, **_ignored) -> tuple[Page, dict]:
    """The report page of one campaign directory."""
    manifest = read_manifest(directory) or {}
    axes = list(manifest.get("param_keys", []))
    table = CampaignStore(directory, axes).load()
    if not len(table):
        raise NodesimError(f"{directory}: the campaign has no finished runs yet")
    metrics = [c for c in table.columns if c not in RESERVED_COLUMNS and c not in axes]
    sweep = manifest.get("sweep", {})
    page = Page(f"nodesim campaign report: {sweep.get('name', directory.name)}")
    ok = table[table["status"] == "ok"]
    n_failed = int((table["status"] == "failed").sum())
    page.table(["campaign", "value"], [
        ["directory", str(directory)], ["description", sweep.get("description", "")],
        ["status", manifest.get("status")], ["planned runs", manifest.get("planned_runs")],
        ["runs ok", len(ok)], ["runs failed", n_failed], ["seeds per point", len(sweep.get("seeds", []))],
        ["combine", sweep.get("combine")], ["executor", str(manifest.get("executor"))],
        ["git commit", manifest.get("git_commit")],
    ])
    page.table(["axis", "values"], [[a["key"], ", ".join(map(str, a["values"]))] for a in sweep.get("axes", [])])
    page.heading("Metrics against each swept axis")
    if not axes:
        page.para("no swept axis: the campaign repeats one point over seeds", note=True)
    if ok.empty:
        page.para("no run finished ok: nothing to plot", note=True)
    else:
        for metric in metrics:
            if ok[metric].notna().sum() == 0:
                page.para(f"{metric}: no finite value in any ok run", note=True)
                continue
            for axis in axes:
                others = [a for a in axes if a != axis]
                page.figure(metric_vs_axis_figure(ok, axis, metric, others[0] if len(others) == 1 else None),
                            f"{metric} vs {axis} ({ok[metric].notna().sum()} runs)")
    best = best_points(table, axes, metrics, where, minimize, maximize, top)
    page.heading("Best points")
    rule = " and ".join(filter(None, [f"where {where}" if where else "", f"minimizing {minimize}" if minimize else "",
                                      f"maximizing {maximize}" if maximize else ""])) or "all points, in point order"
    page.para(f"per-point means over the seeds that finished; {rule}; top {top}")
    if best.empty:
        page.para("no point satisfies the constraint", note=True)
    else:
        page.table(list(best.columns), best.astype(object).where(best.notna(), None).values.tolist())
    failed = table[table["status"] == "failed"]
    page.heading("Failed runs")
    if failed.empty:
        page.para("none", note=True)
    else:
        page.table(["run_id"] + axes + ["attempts", "error"],
                   failed[["run_id"] + axes + ["attempts", "error"]].head(50).astype(object).values.tolist())
    return page, {"best_points": best.to_dict(orient="records"), "runs_ok": len(ok), "runs_failed": n_failed}
