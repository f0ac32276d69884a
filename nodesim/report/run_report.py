"""Run report: what a run directory holds, as one HTML page.

Reads only the run-directory contract (``manifest.json``, ``summary.json``, CSV tables, PNG plots), never
the simulation's internals:

- headline metrics from ``summary.json`` (flattened; timing shown apart), and the per-node ones
  (``node<k>_<metric>``) plotted along the chain when the run has more than one node;
- yaw error and bias estimate per node against time, from ``timeseries.parquet`` or ``timeseries.csv`` (a ``node`` column means one
  line per node; without it the run has one node);
- survey stations with their horizontal uncertainty ellipses, from ``ground_survey.csv`` (the
  ``nodesim uncertainty`` CSV form) through :mod:`nodesim.ground` with the tool model ``tool``;
- link margins along the chain, from any CSV with a ``*margin_db`` column (per hop or node);
- every PNG the run wrote itself.
A section whose data the run does not have says so instead of showing an empty plot.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from nodesim.errors import NodesimError
from nodesim.io.rundir import read_parquet
from nodesim.report.html import Page
from nodesim.sweep.spec import select_metrics

MAX_NODES_PLOTTED = 24


def _read_json(path: Path) -> dict:
    try:
        return json.loads(path.read_text())
    except FileNotFoundError:
        return {}
    except (OSError, json.JSONDecodeError) as err:
        raise NodesimError(f"{path}: unreadable ({err})") from None


def _read_csv(path: Path) -> pd.DataFrame | None:
    if not path.exists():
        return None
    try:
        return pd.read_csv(path)
    except (OSError, ValueError) as err:
        raise NodesimError(f"{path}: unreadable CSV ({err})") from None


def _summary_section(page: Page, summary: dict) -> None:
    page.heading("Headline metrics")
    flat = select_metrics({k: v for k, v in summary.items()}, ())
    text = {k: v for k, v in summary.items() if isinstance(v, str)}
    rows = [[k, v] for k, v in flat.items()] + [[k, v] for k, v in text.items()]
    page.table(["metric", "value"], rows)
    timing = summary.get("timing", {})
    if timing:
        page.para("timing: " + ", ".join(f"{k} = {v:.3g} s" for k, v in timing.items() if isinstance(v, (int, float))))


def _chain_section(page: Page, summary: dict) -> None:
    """Per-node headline metrics (summary keys ``node<k>_<metric>``) against the node's place in the chain."""
    per_node: dict[str, dict[int, float]] = {}
    for key, value in summary.items():
        m = re.fullmatch(r"node(\d+)_(.+)", key)
        if m and isinstance(value, (int, float)) and not isinstance(value, bool) and not m.group(2).endswith("_p95"):
            per_node.setdefault(m.group(2), {})[int(m.group(1))] = float(value)
    wanted = [k for k in ("rms_azimuth_error_deg", "rms_yaw_error_deg", "mean_update_age_s") if len(per_node.get(k, {})) > 1]
    if not wanted:
        return
    page.heading("Metrics along the chain")
    fig = Figure(figsize=(8, 2.6 * len(wanted)))
    axes = fig.subplots(len(wanted), 1, sharex=True, squeeze=False)
    for ax, key in zip(axes[:, 0], wanted):
        nodes = sorted(per_node[key])
        ax.plot(nodes, [per_node[key][n] for n in nodes], "o-", ms=4, lw=1.0)
        ax.set_ylabel(key, fontsize=8)
        ax.grid(True, lw=0.3)
    axes[-1, 0].set_xlabel("node (1 = top of the chain)")
    fig.tight_layout()
    page.figure(fig, "per-node headline metrics, mean over realizations (summary.json node<k>_* keys)")


def _yaw_section(page: Page, ts: pd.DataFrame | None) -> None:
    page.heading("Yaw error and bias estimate per node")
    need = {"t_s", "yaw_error_deg", "bias_est_deg_s"}
    if ts is None or not need <= set(ts.columns):
        page.para(f"no time series with {sorted(need)} in this run (timeseries)", note=True)
        return
    groups = list(ts.groupby("node")) if "node" in ts.columns else [(1, ts)]
    fig = Figure(figsize=(10, 6.5))
    axes = fig.subplots(2, 1, sharex=True)
    for node, g in groups[:MAX_NODES_PLOTTED]:
        if "running" in g.columns:
            g = g[g["running"] == 1]
        (line,) = axes[0].plot(g["t_s"], g["yaw_error_deg"], lw=0.7, label=f"node {node}")
        axes[1].plot(g["t_s"], g["bias_est_deg_s"], lw=0.7, color=line.get_color())
        if "bias_true_deg_s" in g.columns:
            axes[1].plot(g["t_s"], g["bias_true_deg_s"], lw=0.7, ls="--", color=line.get_color())
    axes[0].set_ylabel("yaw error [deg]")
    axes[1].set_ylabel("z-gyro bias [deg/s]\n(dashed: true)")
    axes[1].set_xlabel("time [s]")
    # zoom the bias axis past the turn-on transient: 1st-99th percentile of the estimate
    lo, hi = np.nanpercentile(ts["bias_est_deg_s"], [1, 99])
    pad = 0.2 * (hi - lo) + 1e-3
    axes[1].set_ylim(lo - pad, hi + pad)
    for ax in axes:
        ax.grid(True, lw=0.3)
    if len(groups) <= 12:
        axes[0].legend(fontsize=7, ncol=2, loc="best")
    fig.tight_layout()
    shown = min(len(groups), MAX_NODES_PLOTTED)
    page.figure(fig, f"realization 0, {shown} of {len(groups)} node(s)")


def _survey_section(page: Page, run_dir: Path, tool: str) -> None:
    page.heading("Survey stations and uncertainty ellipses")
    path = run_dir / "ground_survey.csv"
    df = _read_csv(path)
    if df is None or len(df) < 2:
        page.para("no survey stations in this run (ground_survey.csv absent or under 2 stations)", note=True)
        return
    from nodesim.ground import load_tool, propagate, read_survey_csv
    from nodesim.ground.ellipsoid import confidence_scale, horizontal_ellipse
    from nodesim.ground.wellpath_plot import uncertainty_figure

    survey = read_survey_csv(path)
    u = propagate(survey, load_tool(tool))
    scale = confidence_scale("2", dof=1)
    fig = uncertainty_figure(u, scale, f"{len(survey)} stations received, tool {tool}, 2 sigma")
    # dpi 110: the same image as `nodesim uncertainty --plot` writes
    page.figure(fig, "plan view with horizontal 2-sigma ellipses; TVD band against MD", dpi=110)
    major, minor, _ = horizontal_ellipse(u.cov_nev_m2)
    rows = [
        [float(survey.md_m[k]), float(np.degrees(survey.inc_rad[k])), float(np.degrees(survey.azi_rad[k])),
         float(scale * major[k]), float(scale * minor[k])]
        for k in range(len(survey))
    ]
    page.table(["md_m", "inc_deg", "azi_deg", "semi_major_2sigma_m", "semi_minor_2sigma_m"], rows[-10:])


def _link_section(page: Page, run_dir: Path) -> None:
    page.heading("Link margins along the chain")
    for csv in sorted(run_dir.glob("*.csv")):
        df = _read_csv(csv)
        cols = [c for c in df.columns if c.endswith("margin_db")] if df is not None else []
        # simple links (fixed delay and loss) have no link budget: their margin is written as inf
        cols = [c for c in cols if np.isfinite(pd.to_numeric(df[c], errors="coerce")).any()]
        if not cols:
            continue
        where = next((c for c in ("hop", "link", "node", "md_m") if c in df.columns), None)
        x = df[where] if where else np.arange(len(df))
        fig = Figure(figsize=(9, 4))
        ax = fig.subplots()
        for c in cols:
            ax.plot(x, df[c], "o-", ms=3, lw=0.8, label=c)
        ax.axhline(0.0, color="tab:red", lw=0.8, ls="--")
        ax.set_xlabel(where or "row")
        ax.set_ylabel("margin [dB]")
        ax.grid(True, lw=0.3)
        ax.legend(fontsize=8)
        page.figure(fig, f"from {csv.name}")
        return
    page.para("no link data in this run (no CSV with a finite *margin_db column: simple links have no link budget)",
              note=True)


def run_page(run_dir: Path, tool: str = "mpu6500", **_ignored) -> tuple[Page, dict]:
    """The report page of one run directory."""
    manifest = _read_json(run_dir / "manifest.json")
    summary = _read_json(run_dir / "summary.json")
    name = summary.get("scenario") or manifest.get("scenario", {}).get("name") or run_dir.name
    page = Page(f"nodesim run report: {name}")
    ident = [[k, manifest.get(k)] for k in ("nodesim_version", "git_commit", "root_seed", "started_utc", "scenario_sha256")]
    page.table(["run", "value"], [["directory", str(run_dir)]] + ident)
    _summary_section(page, summary)
    _chain_section(page, summary)
    parquet = run_dir / "timeseries.parquet"
    _yaw_section(page, read_parquet(parquet) if parquet.exists() else _read_csv(run_dir / "timeseries.csv"))
    _survey_section(page, run_dir, tool)
    _link_section(page, run_dir)
    pngs = sorted(run_dir.glob("*.png"))
    page.heading("Plots written by the run")
    if not pngs:
        page.para("the run wrote no PNG plots", note=True)
    for png in pngs:
        data = png.read_bytes()
        if data:
            page.image(data, png.name)
    return page, {"run_pngs": len(pngs)}
