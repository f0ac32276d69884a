"""Schedule optimiser against an exhaustive grid on a small 2-variable space (issue 23 must-show).

Space: the 20-node soil chain of ``scenarios/optimize/soil20_vwc0p275.toml`` (vwc 0.275, 1.7 m hops, ARQ with
3 retries) in windowed mode, ``schedule.update_s`` in 5..40 s and ``schedule.timeout_s`` in 5..60 s, both in
5 s steps (8 x 12 = 96 points), 8 realizations per run, the same root seed everywhere (common random numbers).
Problem: minimise ``radio_energy_j`` subject to ``rms_azimuth_error_deg_p95 <= 0.3`` and
``bias_converged_fraction >= 0.95``.

The grid runs every point (the exhaustive reference: its best feasible energy E_grid).  Each optimiser study
then gets a quarter of the grid's evaluations as its trial budget; its trials read the grid's stored results
(:func:`nodesim.optimization.search.table_trial`: with common random numbers a point's run is a function of
its decision values, so this equals running it, and each study costs no simulation).  Figures:

- ``optimize_evaluations_vs_grid``: optimiser evaluations (distinct points run) / grid evaluations, the
  largest over the studies (goal <= 0.25);
- ``optimize_front_gap_vs_grid``: (E_opt - E_grid) / E_grid, E_opt the study's best feasible energy (the
  single-objective front), median over the TPE sampler seeds 0..4 (goal <= 0.05);
  ``optimize_front_gap_vs_grid_worst`` the largest; ``optimize_within_5pct_<sampler>``: how many of the 5 seeds
  came within 5 %;
- ``optimize_gap_median_<sampler>`` for NSGA-II (population 8) and random search at the same budget and seeds.
"""

from __future__ import annotations

import itertools
import math
import statistics
import tempfile
from importlib import resources
from pathlib import Path

from nodesim.optimization.outcome import finish
from nodesim.optimization.problem import parse_problem
from nodesim.optimization.search import point_key, run_search, run_trial, table_trial
from nodesim.sweep.executors import LocalExecutor

GRID_SHARE = 4  # the optimiser's budget: grid points / GRID_SHARE
SEEDS = range(5)


def _problem(sampler: str = "tpe", sampler_seed: int = 0, trials: int = 24, batch: int = 4):
    with resources.as_file(resources.files("scenarios") / "whatif" / "soil_vwc_0p28.toml") as base:
        data = {
            "name": "bench-optimize", "base": base.name, "realizations": 8, "trials": trials, "batch": batch,
            "sampler": sampler, "sampler_seed": sampler_seed,
            "overrides": {"chain.nodes": 20, "radio.soil.vwc": 0.275, "radio.soil.distance_m": 1.7,
                          "schedule.mode": "windowed"},
            "variable": [{"key": "schedule.update_s", "low": 5.0, "high": 40.0, "step": 5.0},
                         {"key": "schedule.timeout_s", "low": 5.0, "high": 60.0, "step": 5.0}],
            "objective": [{"key": "radio_energy_j"}],
            "constraint": [{"key": "rms_azimuth_error_deg_p95", "max": 0.3},
                           {"key": "bias_converged_fraction", "min": 0.95}],
        }
        return parse_problem(data, "bench_optimize", base.parent)


def _grid(problem, executor) -> dict:
    """Run every grid point; returns {point_key: metrics}."""
    points = [dict(zip([v.key for v in problem.variables], combo))
              for combo in itertools.product(*(v.grid() for v in problem.variables))]
    table = {}
    for rec in executor.imap(run_trial, [problem.task(i, p) for i, p in enumerate(points)]):
        if rec.status != "ok":
            raise RuntimeError(f"grid run failed: {rec.error}")
        table[point_key(dict(rec.params))] = rec.metrics
    return table


def _study_best(problem, executor, table: dict) -> tuple[float, int]:
    with tempfile.TemporaryDirectory() as tmp:
        run_search(problem, Path(tmp) / "study", executor, quiet=True, run_fn=table_trial, payload={"table": table})
        study = finish(problem, Path(tmp) / "study", validate_run=False)
        energy = study.recommended["objectives"]["radio_energy_j"] if study.recommended else math.inf
        return energy, study.summary()["evaluations"]


def optimize_vs_grid() -> dict:
    reference = _problem()
    with LocalExecutor() as ex:
        table = _grid(reference, ex)
    feasible = [m["radio_energy_j"] for m in table.values()
                if all(c.violation(m[c.key]) <= 0 for c in reference.constraints)]
    grid_best, n_grid = min(feasible), len(table)
    budget = n_grid // GRID_SHARE
    out: dict = {}
    evals = []
    with LocalExecutor(1) as ex:
        for sampler, batch in (("tpe", 4), ("nsga2", 8), ("random", 4)):
            gaps = []
            for seed in SEEDS:
                e, n = _study_best(_problem(sampler, seed, budget, batch), ex, table)
                gaps.append((e - grid_best) / grid_best)
                evals.append(n)
            out[f"optimize_gap_median_{sampler}"] = statistics.median(gaps)
            out[f"optimize_within_5pct_{sampler}"] = sum(g <= 0.05 for g in gaps)
            if sampler == "tpe":
                out["optimize_front_gap_vs_grid"] = statistics.median(gaps)
                out["optimize_front_gap_vs_grid_worst"] = max(gaps)
    return {
        "optimize_evaluations_vs_grid": max(evals) / n_grid,
        **out,
        "optimize_grid_points": n_grid,
        "optimize_grid_feasible_points": len(feasible),
        "optimize_grid_best_energy_j": grid_best,
        "optimize_trial_budget": budget,
    }


BENCHMARKS = [optimize_vs_grid]
