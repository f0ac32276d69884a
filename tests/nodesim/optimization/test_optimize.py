"""nodesim optimize: file validation, the search (determinism, executors, resume after SIGINT), the tables.

Most tests use :func:`nodesim.optimization.search.synthetic_trial` (an analytic stand-in for a run) so they
exercise the search, the store and the executors in seconds; one test runs the CLI on a shortened lab string.
"""

import json
import os
import signal
import subprocess
import sys
import time
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd
import pandas.testing as pdt
import pytest

import nodesim
from nodesim.cli.main import main
from nodesim.errors import NodesimError
from nodesim.optimization.outcome import TRIALS, finish, pareto_frame, schedule_toml, sensitivity
from nodesim.optimization.problem import Constraint, read_problem
from nodesim.optimization.search import run_search, synthetic_trial
from nodesim.sweep.executors import DaskExecutor, LocalExecutor

REPO = Path(__file__).resolve().parents[3]
LAB = str(REPO / "scenarios" / "lab" / "continuous.toml")
TIMING = ["wall_s", "worker"]


def synthetic(**changes) -> dict:
    """A 2-variable windowed problem on the analytic stand-in: least energy_j with error_deg_p95 <= 0.2."""
    data = {
        "base": LAB, "realizations": 2, "trials": 12, "batch": 4, "sampler": "tpe",
        "overrides": {"schedule.mode": "windowed"}, "baseline": {"schedule.mode": "continuous"},
        "variable": [{"key": "schedule.update_s", "low": 5.0, "high": 30.0, "step": 5.0},
                     {"key": "schedule.timeout_s", "low": 5.0, "high": 60.0, "step": 5.0}],
        "objective": [{"key": "energy_j"}],
        "constraint": [{"key": "error_deg_p95", "max": 0.2}],
    }
    data.update(changes)
    return data


def _study(data, out, executor, **kw):
    problem = read_problem(data)
    run_search(problem, out, executor, run_fn=synthetic_trial, quiet=True, **kw)
    return finish(problem, out, executor, synthetic_trial)


@pytest.mark.parametrize("change, words", [
    ({"colour": 1}, ["unknown key", "colour"]),
    ({"variable": [{"key": "schedule.timeoutt_s", "low": 1.0, "high": 2.0}]}, ["schedule.timeoutt_s", "not a scenario key"]),
    ({"variable": [{"key": "schedule.timeout_s", "low": 9.0, "high": 9.0}]}, ["empty range", "schedule.timeout_s"]),
    ({"variable": [{"key": "schedule.timeout_s", "low": 9.0, "high": 3.0}]}, ["empty range"]),
    ({"variable": [{"key": "schedule.mode", "choices": []}]}, ["non-empty"]),
    ({"variable": [{"key": "schedule.timeout_s", "low": -5.0, "high": 3.0}]}, ["schedule.timeout_s", "rejects -5.0"]),
    ({"variable": [{"key": "schedule.timeout_s", "low": 1.0, "high": 3.0, "when": {"schedule.mode": "windowed"}}]},
     ["when", "not an earlier variable"]),
    ({"variable": []}, ["at least one [[variable]]"]),
    ({"objective": []}, ["at least one [[objective]]"]),
    ({"constraint": [{"key": "error_deg_p95"}]}, ["give max and/or min"]),
    ({"constraint": [{"key": "error_deg_p95", "min": 2.0, "max": 1.0}]}, ["empty range"]),
    ({"recommend": "airtime"}, ["recommend", "not an objective"]),
    ({"seed": 5, "validation_seed": 5}, ["validation_seed", "must differ"]),
    ({"overrides": {"schedule.timeout_s": 1.0}, "variable": [{"key": "schedule.timeout_s", "low": 1.0, "high": 2.0}]},
     ["given twice"]),
])
def test_bad_optimisation_files_name_the_key(change, words):
    with pytest.raises(NodesimError) as err:
        read_problem(synthetic(**change))
    for w in words:
        assert w in str(err.value)


def test_cli_user_errors_exit_2(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text(f'base = "{LAB}"\n[[variable]]\nkey = "schedule.timeout_s"\nlow = 30.0\nhigh = 10.0\n'
                   '[[objective]]\nkey = "radio_energy_j"\n')
    assert main(["optimize", str(bad), "--out", str(tmp_path / "o")]) == 2
    assert "empty range" in capsys.readouterr().err
    assert main(["optimize", str(bad), "--resume"]) == 2


def test_an_objective_no_run_produces_stops_the_study_naming_it(tmp_path):
    data = synthetic(objective=[{"key": "energy_jj"}])
    with LocalExecutor(1) as ex, pytest.raises(NodesimError) as err:
        run_search(read_problem(data), tmp_path / "s", ex, run_fn=synthetic_trial, quiet=True)
    assert "energy_jj" in str(err.value) and "produced by no run" in str(err.value) and "energy_j'" in str(err.value)


def test_same_seed_and_trials_give_the_same_study_on_1_or_2_workers(tmp_path):
    with LocalExecutor(1) as ex:
        a = _study(synthetic(), tmp_path / "a", ex)
    with LocalExecutor(2) as ex:
        b = _study(synthetic(), tmp_path / "b", ex)
    assert len(a.trials) == 12 and (a.trials["state"] == "COMPLETE").all()
    pdt.assert_frame_equal(a.trials.drop(columns=TIMING), b.trials.drop(columns=TIMING))
    assert a.recommended == b.recommended
    # a different sampler seed explores differently (the equality above is not vacuous)
    with LocalExecutor(2) as ex:
        c = _study(synthetic(sampler_seed=99), tmp_path / "c", ex)
    assert not a.trials[["schedule.update_s", "schedule.timeout_s"]].equals(c.trials[["schedule.update_s", "schedule.timeout_s"]])


def test_local_pool_and_dask_give_the_same_trials(tmp_path):
    data = synthetic(sampler="nsga2", batch=4, trials=12, objective=[{"key": "energy_j"}, {"key": "error_deg_p95"}])
    with LocalExecutor(2) as ex:
        local = _study(data, tmp_path / "local", ex)
    with DaskExecutor(workers=2, processes=False) as ex:
        dask = _study(data, tmp_path / "dask", ex)
    pdt.assert_frame_equal(local.trials.drop(columns=TIMING), dask.trials.drop(columns=TIMING))
    pdt.assert_frame_equal(local.pareto.drop(columns=TIMING), dask.pareto.drop(columns=TIMING))
    assert json.loads((tmp_path / "dask" / "optimization.json").read_text())["executor"]["executor"] == "dask"


DRIVER = """
import sys
import nodesim
from nodesim.optimization.search import synthetic_trial
if __name__ == "__main__":
    data = {data!r}
    nodesim.optimize(data, out=sys.argv[1], workers=1, run_fn=synthetic_trial, validate=False, report=False,
                     payload={{"sleep_s": 0.15, "log": sys.argv[2]}})
"""


def test_resume_after_sigint_continues_without_repeating_finished_trials(tmp_path):
    data = synthetic(trials=16, batch=4, sampler="random")
    out, log = tmp_path / "study", tmp_path / "evaluations.log"
    script = tmp_path / "driver.py"
    script.write_text(DRIVER.format(data=data))
    proc = subprocess.Popen([sys.executable, str(script), str(out), str(log)], cwd=REPO)
    deadline = time.time() + 60
    while time.time() < deadline and (not log.exists() or len(log.read_text().split()) < 6):
        time.sleep(0.05)
    proc.send_signal(signal.SIGINT)
    assert proc.wait(timeout=60) != 0
    problem = read_problem(data)
    from nodesim.optimization.search import open_study
    from nodesim.optimization.outcome import trials_frame

    before = trials_frame(open_study(problem, out, create=False), problem)
    finished_before = set(before.loc[before["state"].isin(["COMPLETE", "FAIL"]), "trial"])
    assert 4 <= len(finished_before) < 16
    assert json.loads((out / "optimization.json").read_text())["status"] == "interrupted"
    study = nodesim.optimize(data, out=out, resume=True, workers=1, run_fn=synthetic_trial, validate=False,
                             report=False, payload={"sleep_s": 0.0, "log": str(log)})
    assert len(study.trials) == 16 and (study.trials["state"] == "COMPLETE").all()
    runs = pd.Series(log.read_text().split()).value_counts()
    for number in finished_before:  # each finished trial was evaluated once, in the first session only
        assert runs.get(f"t{number:05d}", 0) == 1
    pdt.assert_frame_equal(study.trials[study.trials["trial"].isin(finished_before)].drop(columns=TIMING).reset_index(drop=True),
                           before[before["trial"].isin(finished_before)].drop(columns=TIMING).reset_index(drop=True))
    # a resumed study refuses a changed file
    with pytest.raises(NodesimError, match="different optimisation file"):
        nodesim.optimize(synthetic(trials=16, batch=4, sampler="tpe"), out=out, resume=True, workers=1,
                         run_fn=synthetic_trial, validate=False, report=False)


def test_infeasible_everywhere_says_so_and_lists_the_closest_trials(tmp_path):
    with LocalExecutor(1) as ex:
        s = _study(synthetic(constraint=[{"key": "error_deg_p95", "max": 0.01}], trials=8), tmp_path / "s", ex)
    assert not s.feasible and s.recommended is None and s.schedule_toml() is None
    assert len(s.closest) == 5 and s.closest["total_violation"].is_monotonic_increasing
    assert s.summary()["closest_infeasible"][0]["trial"] == int(s.closest.iloc[0]["trial"])
    assert len(s.pareto) == 0
    from nodesim.report import write_report

    info = write_report(tmp_path / "s")
    page = Path(info["report"]).read_text()
    assert info["kind"] == "optimization" and "no trial meets every constraint" in page and "<td class=\"text\">spearman_rho</td>" in page


def test_pareto_front_constraint_violation_and_sensitivity_on_known_data():
    problem = read_problem(synthetic(objective=[{"key": "energy_j"}, {"key": "error_deg_p95", "direction": "minimize"}]))
    t = pd.DataFrame({
        "trial": [0, 1, 2, 3, 4], "state": ["COMPLETE"] * 5,
        "schedule.update_s": [5.0, 10.0, 15.0, 20.0, 25.0], "schedule.timeout_s": [5.0, 5.0, 5.0, 5.0, 5.0],
        "energy_j": [1.0, 2.0, 2.0, 3.0, 0.5], "error_deg_p95": [0.15, 0.1, 0.12, 0.05, 0.3],
        "feasible": [True, True, True, True, False], "reused_from": pd.array([None] * 5, dtype="Int64"),
    })
    front = pareto_frame(t, problem)
    assert list(front["trial"]) == [0, 1, 3]  # 2 is dominated by 1, 4 is infeasible
    t.loc[3, "reused_from"] = 1  # a repeated point (reused run) appears once on the front
    assert list(pareto_frame(t, problem)["trial"]) == [0, 1]
    c = Constraint("x", max=0.3, min=0.1)
    assert c.violation(0.35) == pytest.approx(0.05) and c.violation(0.2) == pytest.approx(-0.1)
    assert c.violation(0.0) == pytest.approx(0.1) and c.violation(float("nan")) == float("inf")
    sens = sensitivity(t, problem).set_index(["metric", "variable"])
    assert sens.loc[("error_deg_p95", "schedule.update_s"), "value"] == pytest.approx(0.1)  # spearman of the data
    assert np.isnan(sens.loc[("energy_j", "schedule.timeout_s"), "value"])  # constant variable: undefined


def test_recommended_toml_parses_and_applies_to_the_scenario():
    problem = read_problem(synthetic(variable=[
        {"key": "schedule.mode", "choices": ["windowed", "single"]},
        {"key": "schedule.timeout_s", "low": 5.0, "high": 60.0, "when": {"schedule.mode": "windowed"}},
        {"key": "mac.max_retries", "low": 0, "high": 6}], overrides={}))
    text = schedule_toml(problem, {"schedule.mode": "windowed", "schedule.timeout_s": 12.5, "mac.max_retries": 2})
    parsed = tomllib.loads(text)
    assert parsed == {"schedule": {"mode": "windowed", "update_s": 20.0, "timeout_s": 12.5}, "mac": {"max_retries": 2}}


def test_cli_on_a_short_lab_string_writes_the_tables_report_and_schedule(tmp_path, capsys):
    opt = tmp_path / "opt.toml"
    opt.write_text(f'''base = "{LAB}"
realizations = 2
trials = 4
batch = 2
sampler = "random"
[overrides]
"simulation.duration_s" = 120.0
"motion.fast_turns" = 2.0
"metrics.window_start_s" = 80.0
"metrics.window_end_s" = 120.0
"schedule.mode" = "windowed"
[baseline]
"schedule.mode" = "continuous"
[[variable]]
key = "schedule.timeout_s"
low = 5.0
high = 40.0
step = 5.0
[[objective]]
key = "radio_energy_j"
[[constraint]]
key = "rms_azimuth_error_deg_p95"
max = 5.0
''')
    rc = main(["optimize", str(opt), "--out", str(tmp_path / "o"), "--workers", "1", "--quiet"])
    out = capsys.readouterr().out
    assert rc == 0, out
    assert "[schedule]" in out and 'mode = "windowed"' in out and "validation (fresh seed" in out
    trials = pd.read_parquet(tmp_path / "o" / TRIALS)
    assert len(trials) == 4 and trials["radio_energy_j"].notna().all()
    assert (tmp_path / "o" / "report.html").read_text().count("<img") >= 2
    rec = json.loads((tmp_path / "o" / "recommendation.json").read_text())
    assert rec["validation"]["seed"] != 20260101 and rec["validation"]["recommended"]["feasible"] in (True, False)


@pytest.mark.parametrize("path", sorted((REPO / "scenarios" / "optimize").glob("*.toml")), ids=lambda p: p.name)
def test_example_optimisation_files_load(path):
    from nodesim.optimization.problem import load_problem

    problem = load_problem(path)
    assert problem.constraints and problem.objectives and problem.validation_seed != problem.seed
    assert problem.realizations > 1  # their *_p95 keys need more than one realization
