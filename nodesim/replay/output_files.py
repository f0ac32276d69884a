"""Run directory of a replay: the same files as a simulated run, plus the model-versus-MCU comparison.

- ``timeseries.csv``: one row per node and firmware tick: update, yaw estimate and sigma, bias estimate,
  moving-averaged inclination and azimuth, and the yaw error against the log's truth (``true_yaw``) or,
  without it, against the encoder reading at the tick; the log's ``seq`` at the tick when it has one;
- ``comparison.csv`` (logs with firmware outputs): per node, tick and recorded quantity, model - recorded;
- ``summary.json``: headline metrics (RMS/max yaw error, update fraction, repairs, held ticks, per-quantity
  comparison with the first divergence, ``bit_identical``), timing under ``timing``;
- ``manifest.json``: versions, the log's and the configuration's SHA-256, the resolved configuration;
- ``yaw_error.png``: yaw error and bias estimate of every node against time.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from nodesim.replay.compare import QuantityDiff, recorded_at_ticks
from nodesim.replay.reader import NodeLog
from nodesim.replay.replayer import NodeReplay
from nodesim.io.rundir import write_csv, write_png
from nodesim.units import rad_to_deg, wrap_pi

if TYPE_CHECKING:
    from matplotlib.figure import Figure


def yaw_reference(node: NodeLog, rep: NodeReplay) -> tuple[np.ndarray, str | None]:
    """What the yaw error is measured against: the truth at the ticks if logged, else the encoder."""
    if node.has("true_yaw"):
        return recorded_at_ticks(node, rep.t_s, "true_yaw")[0], "truth"
    if np.isfinite(rep.encoder_rad).any():
        return rep.encoder_rad, "encoder"
    return np.full(rep.t_s.size, np.nan), None


def node_metrics(node: NodeLog, rep: NodeReplay) -> dict:
    ref, kind = yaw_reference(node, rep)
    err = rad_to_deg(wrap_pi(rep.yaw_rad - ref))
    use = rep.running & np.isfinite(err)
    return {
        "node": rep.node_id,
        "ticks": int(rep.t_s.size),
        "running_ticks": int(rep.running.sum()),
        "update_fraction": float(rep.update[rep.running].mean()) if rep.running.any() else 0.0,
        "yaw_error_reference": kind,
        "rms_yaw_error_deg": float(np.sqrt(np.mean(err[use] ** 2))) if use.any() else None,
        "max_abs_yaw_error_deg": float(np.abs(err[use]).max()) if use.any() else None,
        "final_bias_est_deg_s": float(rad_to_deg(rep.bias_rad_s[-1])) if np.isfinite(rep.bias_rad_s[-1]) else None,
        "held_ticks": rep.held_ticks,
        "firmware_overflows": dict(rep.overflows),
    }


def timeseries_columns(logs: tuple[NodeLog, ...], reps: tuple[NodeReplay, ...]) -> dict[str, np.ndarray]:
    parts: dict[str, list] = {}
    for node, rep in zip(logs, reps):
        ref, _ = yaw_reference(node, rep)
        cols = {
            "node": np.full(rep.t_s.size, rep.node_id),
            "t_s": rep.t_s,
            "running": rep.running.astype(int),
            "update": rep.update.astype(int),
            "yaw_est_deg": rad_to_deg(rep.yaw_rad),
            "yaw_sigma_deg": rad_to_deg(np.sqrt(rep.yaw_var_rad2)),
            "yaw_error_deg": rad_to_deg(wrap_pi(rep.yaw_rad - ref)),
            "bias_est_deg_s": rad_to_deg(rep.bias_rad_s),
            "inclination_deg": rad_to_deg(rep.inclination_rad),
            "azimuth_deg": rad_to_deg(rep.azimuth_rad),
        }
        if any(n.has("seq") for n in logs):
            cols["seq"] = recorded_at_ticks(node, rep.t_s, "seq")[0] if node.has("seq") else np.full(rep.t_s.size, np.nan)
        for k, v in cols.items():
            parts.setdefault(k, []).append(np.asarray(v))
    return {k: np.concatenate(v) for k, v in parts.items()}


def comparison_columns(diffs: dict[int, dict[str, QuantityDiff]], reps: tuple[NodeReplay, ...]) -> dict[str, np.ndarray]:
    by_id = {r.node_id: r for r in reps}
    rows: dict[str, list] = {"node": [], "quantity": [], "unit": [], "tick": [], "t_s": [], "diff": []}
    for nid, per in diffs.items():
        for name, d in per.items():
            rows["node"].append(np.full(d.tick.size, nid))
            rows["quantity"].append(np.full(d.tick.size, name))
            rows["unit"].append(np.full(d.tick.size, d.unit))
            rows["tick"].append(d.tick)
            rows["t_s"].append(by_id[nid].t_s[d.tick])
            rows["diff"].append(d.diff)
    return {k: np.concatenate(v) if v else np.zeros(0) for k, v in rows.items()}


def replay_figure(logs: tuple[NodeLog, ...], reps: tuple[NodeReplay, ...], title: str) -> Figure:
    """Yaw error (or, without a reference, the yaw estimate) and bias estimate of every node against time."""
    from matplotlib.figure import Figure  # lazy: replays without plots do not load matplotlib

    fig = Figure(figsize=(9, 6))
    axes = fig.subplots(2, 1, sharex=True)
    for node, rep in zip(logs, reps):
        ref, kind = yaw_reference(node, rep)
        if kind is None:  # nothing to measure against: show the free-running yaw itself
            axes[0].plot(rep.t_s, rad_to_deg(rep.yaw_rad), lw=0.8, label=f"node {rep.node_id}: yaw estimate (no reference)")
        else:
            axes[0].plot(rep.t_s, rad_to_deg(wrap_pi(rep.yaw_rad - ref)), lw=0.8, label=f"node {rep.node_id}: error vs {kind}")
        axes[1].plot(rep.t_s, rad_to_deg(rep.bias_rad_s), lw=0.8, label=f"node {rep.node_id}")
    axes[0].set_ylabel("yaw error or estimate [deg]")
    axes[1].set_ylabel("z-gyro bias estimate [deg/s]")
    axes[1].set_xlabel("log time [s]")
    for ax in axes:
        ax.grid(True, lw=0.3)
        ax.legend(loc="best", fontsize=8)
    fig.suptitle(title)
    fig.tight_layout()
    return fig


def plot_replay(logs: tuple[NodeLog, ...], reps: tuple[NodeReplay, ...], path: Path, title: str) -> None:
    """Write :func:`replay_figure` to ``path`` as PNG, atomically."""
    fig = replay_figure(logs, reps, title)
    write_png(path, fig)


def write_tables(out: Path, logs, reps, diffs, plots: bool, title: str) -> None:
    write_csv(out / "timeseries.csv", timeseries_columns(logs, reps))
    if any(diffs.values()):
        write_csv(out / "comparison.csv", comparison_columns(diffs, reps))
    if plots:
        plot_replay(logs, reps, out / "yaw_error.png", title)


__all__ = ["node_metrics", "timeseries_columns", "comparison_columns", "plot_replay", "replay_figure", "write_tables",
           "yaw_reference"]
