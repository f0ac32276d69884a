"""One simulation run: scenario -> chain simulation -> metrics -> run directory."""

from __future__ import annotations

import time
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path
from typing import Callable

import nodesim
from nodesim.chain.network import simulate_chain
from nodesim.chain.metrics import per_realization_metrics, summarize
from nodesim.chain.run_tables import write_outputs
from nodesim.io.rundir import default_run_dir, git_commit, host_info, write_json
from nodesim.scenario.schema import Scenario


@dataclass(frozen=True)
class RunOutcome:
    out_dir: Path
    summary: dict
    run: object = None  # the ChainRun (nodesim run --record writes it as a replay log)


def run_scenario(
    scenario: Scenario,
    scenario_hash: str | None,
    out_dir: Path | None = None,
    plots: bool = True,
    progress: Callable[[float], None] | None = None,
) -> RunOutcome:
    """Simulate ``scenario`` and write its run directory.  Nothing is written if the simulation fails.
    ``progress(fraction)`` is called as simulated time advances (a progress bar for long runs)."""
    started = datetime.now(timezone.utc)
    t0 = time.perf_counter()
    run = simulate_chain(scenario, progress)
    t_sim = time.perf_counter() - t0
    per_real = per_realization_metrics(run, scenario.metrics)
    summary = summarize(per_real)
    summary["scenario"] = scenario.name
    summary["seed"] = scenario.seed
    summary["simpy_events"] = run.simpy_events
    summary["engine"] = run.engine
    summary["nodes"] = len(run.nodes)
    summary["firmware_saturations"] = sum(sum(n.firmware_overflows.values()) for n in run.nodes)

    out = Path(out_dir) if out_dir is not None else default_run_dir(scenario.name, started)
    write_outputs(run, out, f"{scenario.name}: realization 0", per_real, plots)
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
    return RunOutcome(out_dir=out, summary=summary, run=run)
