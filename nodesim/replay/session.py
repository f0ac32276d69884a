"""One replay: log + firmware configuration + schedule -> firmware outputs, comparison, run directory."""

from __future__ import annotations

import hashlib
import time
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path

from nodesim.replay.compare import QUANTITIES, compare_node
from nodesim.replay.output_files import node_metrics, write_tables
from nodesim.replay.reader import DEFAULT_MAX_GAP_S, ReplayLog, read_log
from nodesim.replay.replayer import FirmwareSetup, NodeReplay, allan_noise_of, parse_schedule, replay_log
from nodesim.io.rundir import default_run_dir, git_commit, host_info, package_version, write_json
from nodesim.scenario.schema import load_scenario
from nodesim.units import rad_to_deg


@dataclass(frozen=True)
class ReplayOutcome:
    log: ReplayLog
    setup: FirmwareSetup
    replays: tuple[NodeReplay, ...]
    summary: dict
    out_dir: Path | None


def replay(
    log_path,
    config_path,
    schedule: str | None = None,
    out_dir=None,
    repair: bool = False,
    max_gap_s: float = DEFAULT_MAX_GAP_S,
    noise: str = "config",
    allan_slope_tolerance: float = 0.05,
    tolerances: dict[str, float] | None = None,
    plots: bool = True,
    write: bool = True,
) -> ReplayOutcome:
    """Read, replay and compare; write the run directory when ``write`` (nothing is written on an error).

    ``schedule``: None = ``recorded`` when the log records its updates, else ``config``.
    ``noise``: ``config`` (the configuration's gyro noise) or ``allan`` (Allan deviation of the top node's
    z-gyro samples inside the static bias window, or of all its samples when that window holds < 100;
    ``allan_slope_tolerance`` widens the slope band of the ARW line for short or disturbed records).
    ``tolerances``: per recorded quantity (``fw_yaw`` ...), in the comparison's report units; default 0.
    """
    started = datetime.now(timezone.utc)
    t0 = time.perf_counter()
    scenario, config_hash = load_scenario(config_path)
    log = read_log(log_path, repair=repair, max_gap_s=max_gap_s)
    noise_params = None
    if noise == "allan":
        top = log.nodes[0]
        in_window = int((top.t_s < top.t_s[0] + scenario.motion.stationary_s).sum())
        noise_params = allan_noise_of(top, scenario.motion.stationary_s if in_window >= 100 else None,
                                      allan_slope_tolerance)
    elif noise != "config":
        from nodesim.errors import NodesimError

        raise NodesimError(f"--noise {noise!r}: allowed 'config' or 'allan'")
    setup = FirmwareSetup.from_scenario(scenario, noise_params)
    if schedule is None:
        schedule = "recorded" if all(n.has("ref_update") for n in log.nodes) else "config"
    imposed = parse_schedule(schedule, setup)
    reps = replay_log(log, setup, imposed)
    t_replay = time.perf_counter() - t0
    diffs = {n.node_id: compare_node(n, r, tolerances or {}, log.row_kind) for n, r in zip(log.nodes, reps)}
    summary = {
        "log": str(log.path),
        "nodes": len(reps),
        "schedule": schedule if imposed is None else imposed.describe(),
        "implementation": setup.implementation,
        "noise_source": setup.noise_source,
        "arw_deg_per_sqrt_s": rad_to_deg(setup.filter_config.arw_rad_per_sqrt_s),
        "bias_instability_deg_s": rad_to_deg(setup.filter_config.bias_instability_rad_s),
        "repairs": dict(log.repairs),
        "per_node": [node_metrics(n, r) for n, r in zip(log.nodes, reps)],
    }
    top = summary["per_node"][0]
    for key in ("rms_yaw_error_deg", "max_abs_yaw_error_deg", "update_fraction", "yaw_error_reference"):
        summary[key] = top[key]
    compared = {nid: {q: d.summary() for q, d in per.items()} for nid, per in diffs.items()}
    if any(compared.values()):
        summary["comparison"] = {str(nid): per for nid, per in compared.items()}
        firsts = [(d["first_divergence"]["t_s"], nid, q, d["first_divergence"]) for nid, per in compared.items()
                  for q, d in per.items() if d["first_divergence"] is not None]
        summary["bit_identical"] = not firsts and all(
            d["identical_ticks"] == d["compared_ticks"] for per in compared.values() for d in per.values())
        summary["first_divergence"] = ({"node": min(firsts)[1], "quantity": min(firsts)[2], **min(firsts)[3]}
                                       if firsts else None)
    out = None
    if write:
        out = Path(out_dir) if out_dir is not None else default_run_dir(f"replay-{log.path.stem}", started)
        write_tables(out, log.nodes, reps, diffs, plots, f"replay of {log.path.name}")
        summary["timing"] = {"replay_s": t_replay, "wall_s": time.perf_counter() - t0}
        write_json(out / "summary.json", summary)
        write_json(out / "manifest.json", {
            "nodesim_version": package_version(),
            "git_commit": git_commit(),
            "log": str(log.path),
            "log_sha256": hashlib.sha256(log.path.read_bytes()).hexdigest(),
            "log_header": log.meta.to_dict(),
            "firmware_config": str(config_path),
            "firmware_config_sha256": config_hash,
            "scenario": scenario.model_dump(),
            "schedule": summary["schedule"],
            "started_utc": started.isoformat(),
            "host": host_info(),
        })
    else:
        summary["timing"] = {"replay_s": t_replay, "wall_s": time.perf_counter() - t0}
    return ReplayOutcome(log, setup, reps, summary, out)


TOLERANCE_KEYS = tuple(QUANTITIES)

__all__ = ["ReplayOutcome", "replay", "TOLERANCE_KEYS"]
