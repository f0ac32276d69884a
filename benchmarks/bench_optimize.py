"""Schedule optimiser against an exhaustive grid on a small 2-variable space (issue 23 must-show).

Space: the 20-node soil chain of ``scenarios/optimize/soil20_vwc0p275.toml`` (vwc 0.275, 1.7 m hops, ARQ with
3 retries) in windowed mode, ``schedule.update_s`` in 5..40 s and ``schedule.timeout_s`` in 5..60 s, both in
5 s steps (8 x 12 = 96 points), 8 realizations per run, the same root seed everywhere (common random numbers).
Problem: minimise ``radio_energy_j`` subject to ``rms_azimuth_error_deg_p95 <= 0.3`` and
``bias_converged_fraction >= 0.95``.

The grid evaluates every point (the exhaustive reference: its best feasible energy E_grid).  The optimiser gets
a quarter of the grid's evaluations as its trial budget; repeated decision values reuse the earlier run, so its
evaluations are at most that budget.  Figures:

- ``optimize_evaluations_vs_grid``: optimiser evaluations / grid evaluations (goal <= 0.25), the largest over
  the TPE sampler seeds;
- ``optimize_front_gap_vs_grid``: (E_opt - E_grid) / E_grid, E_opt the optimiser's best feasible energy (the
  single-objective front), the worst over the TPE sampler seeds 0, 1, 2 (goal <= 0.05);
- ``optimize_gap_<sampler>_seed<k>``: the same gap for NSGA-II (population 8) and random search at the same
  budget and seeds (TPE and random in batches of 4).
"""

from __future__ import annotations

import math
import tempfile
from importlib import resources
from pathlib import Path

from nodesim.optimization.outcome import finish
from nodesim.optimization.problem import parse_problem
from nodesim.optimization.search import run_search, run_trial
from nodesim.sweep.executors import LocalExecutor

GRID_SHARE = 4  # the optimiser's budget: grid points / GRID_SHARE


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


def _grid_best(problem, executor) -> tuple[float, int, int]:
    points = [{"schedule.update_s": u, "schedule.timeout_s": t}
              for u in problem.variables[0].grid() for t in problem.variables[1].grid()]
    tasks = [problem.task(i, p) for i, p in enumerate(points)]
    best, feasible = math.inf, 0
    for rec in executor.imap(run_trial, tasks):
        if rec.status != "ok":
            raise RuntimeError(f"grid run failed: {rec.error}")
        if all(c.violation(rec.metrics[c.key]) <= 0 for c in problem.constraints):
            feasible += 1
            best = min(best, rec.metrics["radio_energy_j"])
    return best, len(points), feasible


def _optimiser_best(problem, executor) -> tuple[float, int]:
    with tempfile.TemporaryDirectory() as tmp:
        run_search(problem, Path(tmp) / "study", executor, quiet=True)
        study = finish(problem, Path(tmp) / "study", validate_run=False)
        energy = study.recommended["objectives"]["radio_energy_j"] if study.recommended else math.inf
        return energy, study.summary()["evaluations"]


def optimize_vs_grid() -> dict:
    with LocalExecutor() as ex:
        grid_best, n_grid, n_feasible = _grid_best(_problem(), ex)
        budget = n_grid // GRID_SHARE
        gaps, evals = [], []
        for seed in (0, 1, 2):
            e, n = _optimiser_best(_problem("tpe", seed, budget), ex)
            gaps.append((e - grid_best) / grid_best)
            evals.append(n)
        others = {}
        for sampler in ("nsga2", "random"):
            for seed in (0, 1, 2):
                e, _ = _optimiser_best(_problem(sampler, seed, budget, batch=8 if sampler == "nsga2" else 4), ex)
                others[f"optimize_gap_{sampler}_seed{seed}"] = (e - grid_best) / grid_best
    return {
        "optimize_evaluations_vs_grid": max(evals) / n_grid,
        "optimize_front_gap_vs_grid": max(gaps),
        "optimize_front_gap_vs_grid_mean": sum(gaps) / len(gaps),
        **{f"optimize_gap_tpe_seed{i}": g for i, g in enumerate(gaps)},
        "optimize_grid_points": n_grid,
        "optimize_grid_feasible_points": n_feasible,
        "optimize_grid_best_energy_j": grid_best,
        "optimize_trial_budget": budget,
        **others,
    }


BENCHMARKS = [optimize_vs_grid]
