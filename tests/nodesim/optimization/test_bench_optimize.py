"""The optimiser-vs-grid benchmark (benchmarks/bench_optimize.py) builds the problems and grids it describes.

Not the benchmark itself (its grids are 2 x 96 simulations): the spaces, the steady rotation covering the
metrics window, the budget, and the figures on a small analytic table; plus the run budget of ``run_search``
(``max_evaluations``) the benchmark gives every sampler.
"""

import importlib.util
from pathlib import Path

import pytest

from nodesim.motion.chain_motion import lab_profile
from nodesim.optimization.outcome import finish
from nodesim.optimization.problem import read_problem
from nodesim.optimization.search import point_key, run_search, synthetic_trial
from nodesim.units import DEG

REPO = Path(__file__).resolve().parents[3]


@pytest.fixture(scope="module")
def bench():
    path = REPO / "benchmarks" / "bench_optimize.py"
    spec = importlib.util.spec_from_file_location("bench_optimize_under_test", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _grid_shape(bench, problem):
    points = bench.grid_points(problem)
    assert problem.variable_keys() == ["schedule.update_s", "schedule.timeout_s"]
    assert len(points) == 96 and len({point_key(p) for p in points}) == 96
    assert sorted({p["schedule.update_s"] for p in points}) == [5.0 * i for i in range(1, 9)]
    assert sorted({p["schedule.timeout_s"] for p in points}) == [5.0 * i for i in range(1, 13)]
    task = problem.task(7, points[7])
    assert task.scenario["schedule"]["update_s"] == points[7]["schedule.update_s"]
    assert task.scenario["schedule"]["timeout_s"] == points[7]["schedule.timeout_s"]
    assert task.seed == problem.seed and task.scenario["simulation"]["realizations"] == 8  # common random numbers
    base = problem.base
    assert base.schedule.mode == "windowed" and base.chain.nodes == 20
    assert base.radio.soil.vwc == 0.275 and base.radio.soil.distance_m == 1.7
    assert [o.key for o in problem.objectives] == ["radio_energy_j"]
    return points


def test_steady_problem_is_the_example_file_on_a_rotation_covering_the_metric_window(bench):
    problem = bench.steady_problem()
    points = _grid_shape(bench, problem)
    assert problem.name == "soil20-steady-rotation" and problem.sampler == "tpe"  # the single-objective default
    assert [(c.key, c.max, c.min) for c in problem.constraints] == [("rms_azimuth_error_deg_p95", 0.3, None)]
    base = problem.base
    fast = lab_profile(base).phases[-1]
    assert fast.name == "fast_rotation" and fast.rate_rad_s == pytest.approx(60.0 * DEG)
    lo, hi = base.metrics.window_start_s, base.metrics.window_end_s
    assert hi == base.simulation.duration_s and fast.start_s <= lo and fast.end_s >= hi - 1e-6  # rotating throughout
    longest = max(p["schedule.update_s"] + p["schedule.timeout_s"] for p in points)
    assert hi - lo >= 10 * longest  # many periods of every schedule


def test_rugged_problem_is_the_lab_profile_space(bench):
    problem = bench.rugged_problem()
    _grid_shape(bench, problem)
    assert {c.key for c in problem.constraints} == {"rms_azimuth_error_deg_p95", "bias_converged_fraction"}
    base = problem.base
    fast = lab_profile(base).phases[-1]
    assert fast.end_s < base.metrics.window_start_s  # the error is measured in the static tail after it


def test_figures_on_an_analytic_table(bench):
    """energy = 10 u / (u + t), error = 0.099 + 0.005 t: feasible t <= 40, the best point u = 5, t = 40."""
    problem = bench.steady_problem()
    table = {}
    for p in bench.grid_points(problem):
        u, t = p["schedule.update_s"], p["schedule.timeout_s"]
        table[point_key(p)] = {"radio_energy_j": 10 * u / (u + t), "rms_azimuth_error_deg_p95": 0.099 + 0.005 * t,
                               "update_fraction": 0.5, "delivery_ratio": 1.0}  # the file's record keys
    samplers = (("tpe_b4", "tpe", 4), ("random_b4", "random", 4))
    out = bench.compare(problem, table, bench.InProcess(), "x", samplers=samplers, seeds=range(2))
    assert out["x_grid_points"] == 96 and out["x_budget"] == 24 and out["x_grid_feasible_points"] == 64
    assert out["x_grid_best_energy_j"] == pytest.approx(10 * 5 / 45)
    assert out["x_max_evaluations"] == 24 and out["x_evaluations_vs_grid"] == 0.25
    for name, _, _ in samplers:
        gaps = [out[f"x_gap_{name}_seed{s}"] for s in range(2)]
        assert all(g >= 0 for g in gaps) and out[f"x_gap_median_{name}"] == pytest.approx(sum(gaps) / 2)
        assert out[f"x_gap_worst_{name}"] == max(gaps)
        assert out[f"x_within_5pct_{name}"] == sum(g <= 0.05 for g in gaps)
        assert all(out[f"x_evaluations_{name}_seed{s}"] == 24 for s in range(2))
    # the same again: deterministic for given sampler seeds
    assert bench.compare(problem, table, bench.InProcess(), "x", samplers=samplers, seeds=range(2)) == out
    by_trials = bench.compare(problem, table, bench.InProcess(), "y", by="trials", per_seed=False,
                              samplers=samplers[:1], seeds=range(1))
    assert by_trials["y_max_evaluations"] <= 24 and "y_gap_tpe_b4_seed0" not in by_trials


def test_max_evaluations_stops_at_a_budget_of_runs(tmp_path, bench):
    """3 points, a budget of 3 runs: a random sampler repeats points, repeats cost no run."""
    data = {"base": str(REPO / "scenarios" / "lab" / "continuous.toml"), "realizations": 2, "batch": 2,
            "sampler": "random", "overrides": {"schedule.mode": "windowed"},
            "variable": [{"key": "schedule.timeout_s", "low": 5.0, "high": 15.0, "step": 5.0}],
            "objective": [{"key": "energy_j"}]}
    problem = read_problem(data)
    manifest = run_search(problem, tmp_path / "s", bench.InProcess(), n_trials=40, max_evaluations=3, quiet=True,
                          run_fn=synthetic_trial)
    study = finish(problem, tmp_path / "s", validate_run=False)
    assert study.summary()["evaluations"] == 3 and 3 <= len(study.trials) < 40
    assert manifest["status"] == "complete" and manifest["evaluations_this_session"] == 3
    assert study.recommended["params"] == {"schedule.timeout_s": 15.0}  # energy falls with the timeout
    assert study.trials["energy_j"].notna().all() and study.trials["reused_from"].notna().sum() == len(study.trials) - 3
