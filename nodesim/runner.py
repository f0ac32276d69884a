"""One simulation run: scenario -> simulation -> metrics -> run directory."""

from __future__ import annotations

import time
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

import nodesim
from nodesim.metrics import per_realization_metrics, summarize
from nodesim.plots import plot_lab_run
from nodesim.results import default_run_dir, git_commit, host_info, write_csv, write_json
from nodesim.scenario import Scenario
from nodesim.simulation import simulate_lab
from nodesim.units import rad_to_deg, wrap_pi


@dataclass(frozen=True)
class RunOutcome:
    out_dir: Path
    summary: dict


def run_scenario(
    scenario: Scenario, scenario_hash: str | None, out_dir: Path | None = None, plots: bool = True
) -> RunOutcome:
    """Simulate ``scenario`` and write its run directory.  Nothing is written if the simulation fails."""
    started = datetime.now(timezone.utc)
    t0 = time.perf_counter()
    run = simulate_lab(scenario)
    t_sim = time.perf_counter() - t0
    per_real = per_realization_metrics(run, scenario.metrics)
    summary = summarize(per_real)
    summary["scenario"] = scenario.name
    summary["seed"] = scenario.seed
    summary["simpy_events"] = run.simpy_events

    out = Path(out_dir) if out_dir is not None else default_run_dir(scenario.name, started)
    write_csv(out / "realizations.csv", {"realization": np.arange(len(per_real["rms_azimuth_error_deg"])), **per_real})
    write_csv(
        out / "timeseries.csv",
        {
            "t_s": run.t_s,
            "update": run.update_mask[0].astype(int),
            "true_yaw_deg": rad_to_deg(run.true_yaw_rad),
            "yaw_est_deg": rad_to_deg(run.yaw_est_rad[0]),
            "yaw_error_deg": rad_to_deg(wrap_pi(run.yaw_est_rad[0] - run.true_yaw_rad)),
            "yaw_sigma_deg": rad_to_deg(np.sqrt(run.yaw_var_rad2[0])),
            "bias_true_deg_s": rad_to_deg(run.true_bias_rad_s[0]),
            "bias_est_deg_s": rad_to_deg(run.bias_est_rad_s[0]),
            "inclination_deg": rad_to_deg(run.inclination_rad[0]),
            "azimuth_deg": rad_to_deg(run.azimuth_rad[0]),
        },
    )
    if plots:
        plot_lab_run(run, out / "yaw_error.png", f"{scenario.name}: realization 0")
    wall = time.perf_counter() - t0
    summary["timing"] = {"simulation_s": t_sim, "wall_s": wall}
    write_json(out / "summary.json", summary)
    write_json(
        out / "manifest.json",
        {
            "nodesim_version": nodesim.__version__,
            "git_commit": git_commit(),
            "scenario_sha256": scenario_hash,
            "scenario": scenario.model_dump(),
            "root_seed": scenario.seed,
            "started_utc": started.isoformat(),
            "wall_time_s": wall,
            "host": host_info(),
        },
    )
    return RunOutcome(out_dir=out, summary=summary)
