"""Sweep executors: parallel speed-up of a 64-run sweep and the per-run overhead of the executor.

``sweep_speedup_2_workers``: wall time of a 64-run campaign (the thesis lab scenario, 4 realizations per
run, seeds 0..31 x 2 tuning points, campaign store included) on 1 local worker divided by the same campaign
on 2 local workers, best of 2 interleaved repetitions.  Goal >= 1.7; the pool start-up is inside both times.  On a 2-core machine shared with
other jobs the figure drops with the load, so ``sweep_cpu_count`` and ``sweep_load_avg_1min`` are reported
next to it, and ``sweep_run_slowdown_2_workers``: the median wall time of one run inside a worker with 2
workers over that with 1 (1.0 when the workers do not compete for the cores).

``executor_overhead_fraction`` (local pool, 1 worker) and ``dask_executor_overhead_fraction`` (Dask
LocalCluster, 1 single-threaded worker process): per-run wall time of a campaign of ``N_OVERHEAD`` synthetic
2 s runs (``nodesim.sweep.tasks.busy_run``: keeps one core busy for 2 s, no simulation) minus the 2 s run
timed by a direct call, divided by that direct time.  Goal < 0.05.  This is the steady-state per-run cost
(task shipping, result return, the campaign store's write per run): the one-time start-up of the pool or
cluster is measured apart by a 1-run warm-up campaign (``executor_local_startup_s``,
``executor_dask_startup_s``).
"""

from __future__ import annotations

import dataclasses
import os
import tempfile
import time
from importlib import resources
from pathlib import Path

from nodesim.bench import best_time_s
from nodesim.sweep.campaign import run_campaign
from nodesim.sweep.executors import DaskExecutor, LocalExecutor
from nodesim.sweep.spec import parse_sweep
from nodesim.sweep.tasks import busy_run

N_RUNS = 64
N_OVERHEAD = 3
REPEAT = 2
RUN_S = 2.0


def _spec(seeds: int, axis_values: list):
    with resources.as_file(resources.files("scenarios") / "lab" / "continuous.toml") as lab:
        data = {
            "base": lab.name,
            "seeds": seeds,
            "metrics": ["rms_azimuth_error_deg"],
            "overrides": {"simulation.realizations": 4},
            "axis": [{"key": "filter.tuning_b", "values": axis_values}],
        }
        return parse_sweep(data, "bench_sweep", lab.parent)


def _campaign_s(spec, make_executor, tasks=None, run_fn=None, medians: list | None = None) -> float:
    """Wall time of one whole campaign, executor start-up included (median run wall time -> ``medians``)."""

    def once():
        with make_executor() as executor, tempfile.TemporaryDirectory() as tmp:
            kwargs = {"run_fn": run_fn} if run_fn else {}
            res = run_campaign(spec, Path(tmp) / "c", executor, quiet=True, tasks=tasks, **kwargs)
            if res.failed:
                raise RuntimeError(f"benchmark campaign had failed runs: {res.table['error'].dropna().tolist()[:3]}")
            if medians is not None:
                medians.append(float(res.table["wall_s"].median()))

    return best_time_s(once, repeat=1)


def sweep_speedup() -> dict:
    spec = _spec(N_RUNS // 2, [1.0, 5.0])
    times = {1: float("inf"), 2: float("inf")}
    medians: dict = {1: [], 2: []}
    for _ in range(REPEAT):  # interleaved, best of REPEAT: the machine is shared, load comes and goes
        for workers in (1, 2):
            t = _campaign_s(spec, lambda: LocalExecutor(workers=workers), medians=medians[workers])
            times[workers] = min(times[workers], t)
    return {
        "sweep_speedup_2_workers": times[1] / times[2],
        "sweep_64_runs_1_worker_s": times[1],
        "sweep_64_runs_2_workers_s": times[2],
        # > 1 when the two workers slow each other down (other jobs on the cores, memory bandwidth)
        "sweep_run_slowdown_2_workers": min(medians[2]) / min(medians[1]),
        "sweep_cpu_count": os.cpu_count(),
        "sweep_load_avg_1min": os.getloadavg()[0],
    }


def _warm_then_timed(spec, make_executor, tasks) -> tuple[float, float]:
    """(start-up s, timed s): creating the executor plus a 1-run warm-up campaign, then the timed campaign."""
    warm = [dataclasses.replace(tasks[0], payload={"busy_s": 0.0})]
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        with make_executor() as executor:
            run_campaign(spec, Path(tmp) / "w", executor, quiet=True, tasks=warm, run_fn=busy_run)
            startup = time.perf_counter() - t0
            timed = best_time_s(lambda: run_campaign(spec, Path(tmp) / "c", executor, quiet=True, tasks=tasks, run_fn=busy_run), repeat=1)
    return startup, timed


def executor_overhead() -> dict:
    spec = _spec(N_OVERHEAD, [5.0])
    tasks = [dataclasses.replace(t, payload={"busy_s": RUN_S}) for t in spec.plan()]
    direct = best_time_s(lambda: busy_run(tasks[0]), repeat=1)
    local_start, local = _warm_then_timed(spec, lambda: LocalExecutor(workers=1), tasks)
    dask_start, dask = _warm_then_timed(spec, lambda: DaskExecutor(workers=1, processes=True), tasks)
    return {
        "executor_overhead_fraction": (local / N_OVERHEAD - direct) / direct,
        "dask_executor_overhead_fraction": (dask / N_OVERHEAD - direct) / direct,
        "executor_direct_2s_run_s": direct,
        "executor_local_3_runs_s": local,
        "executor_dask_3_runs_s": dask,
        "executor_local_startup_s": local_start,
        "executor_dask_startup_s": dask_start,
    }


BENCHMARKS = [sweep_speedup, executor_overhead]
