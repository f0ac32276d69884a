"""The Optuna study of an optimisation: batches of trials on the sweep executors, stored in a journal.

Loop (ask-and-tell): ask ``batch`` trials from the sampler, suggest each one's decision values
(:meth:`Problem.suggest`), run the batch as one-run tasks on the executor (:mod:`nodesim.sweep.executors`, local
pool or Dask), then tell every result in trial-number order.  The batch size is fixed by the optimisation file,
not by the number of workers, and every trial is seeded by the common root seed alone, so for a given sampler
seed and trial count the study is the same on any executor and any number of workers.

Samplers: NSGA-II (multi-objective; population = ``batch``), TPE (single objective) or random; constraints go
to the sampler as violations v_i = max(value - max, min - value) (feasible when every v_i <= 0;
``Trial.set_constraint``, read by NSGA-II's constrained domination and TPE's feasibility weighting).

Storage: Optuna's journal file ``DIR/study.journal``, appended as each trial is asked and told.  ``--resume``
reopens it: finished trials (complete or failed) are kept, trials that were asked but not told (a SIGINT or a
kill mid-batch) are run again with their stored decision values, then the study continues to the trial budget.
The resumed sampler is seeded with ``sampler_seed + trials already in the study``, so a resumed study is
deterministic for a given interruption point.
"""

from __future__ import annotations

import hashlib
import math
import time
from datetime import datetime, timezone
from pathlib import Path
from typing import Callable

from nodesim.errors import NodesimError
from nodesim.io.rundir import dumps_json, git_commit, host_info, package_version, write_json
from nodesim.optimization.problem import Problem
from nodesim.sweep.campaign import read_manifest
from nodesim.sweep.progress import Progress
from nodesim.sweep.spec import RunTask, select_metrics

STUDY_NAME = "nodesim-optimize"
JOURNAL = "study.journal"
MANIFEST = "optimization.json"
MISSING = "produced by no run"
BIG_VIOLATION = 1e12  # stands for an undefined (NaN) constraint value in the sampler (Optuna needs finite numbers)


def _requested(numeric: dict, task: RunTask) -> dict:
    missing = [k for k in task.metrics if k not in numeric]
    if missing:
        import difflib

        close = sorted({c for k in missing for c in difflib.get_close_matches(k, numeric, n=4, cutoff=0.5)})
        hint = " (a *_p95 key needs realizations > 1)" if any(k.endswith("_p95") for k in missing) else ""
        raise NodesimError(f"objective/constraint/record key(s) {missing} {MISSING}{hint}; closest keys a run "
                           f"produces: {close or sorted(numeric)[:12]}")
    return {k: numeric[k] for k in task.metrics}


def run_trial(task: RunTask) -> dict:
    """Worker side: the trial's batched Monte Carlo run (:func:`nodesim.api.simulate_scenario`), its kept keys."""
    from nodesim.api import simulate_scenario
    from nodesim.scenario.schema import parse_scenario

    scenario = parse_scenario(task.scenario, source=task.run_id)
    run = simulate_scenario(scenario, hashlib.sha256(dumps_json(task.scenario)).hexdigest())
    return _requested(select_metrics(run.summary, ()), task)


def synthetic_trial(task: RunTask) -> dict:
    """A cheap analytic stand-in for a run (tests, benchmarks of the search itself; no simulation).

    With u = schedule.update_s, t = schedule.timeout_s, r = mac.max_retries (base values when not varied)
    and the task's seed s: ``energy_j = 10 u / (u + t) + 0.2 r`` (10 for continuous mode) and
    ``error_deg_p95 = 0.1 + 0.004 t (1 + 0.1 sin s) + 0.05 / (1 + r)``.  ``payload['log']`` appends the run id
    to a file (evaluation counts); ``payload['sleep_s']`` waits that long first.
    """
    sc = task.scenario
    if task.payload.get("sleep_s"):
        time.sleep(float(task.payload["sleep_s"]))
    if task.payload.get("log"):
        with open(task.payload["log"], "a") as f:
            f.write(task.run_id + "\n")
    u, t = sc["schedule"]["update_s"], sc["schedule"]["timeout_s"]
    r = sc["mac"]["max_retries"]
    energy = 10.0 if sc["schedule"]["mode"] == "continuous" else 10.0 * u / (u + t) + 0.2 * r
    if sc["schedule"]["mode"] == "continuous":
        t = 0.0
    error = 0.1 + 0.004 * t * (1.0 + 0.1 * math.sin(task.seed)) + 0.05 / (1.0 + r)
    return _requested({"energy_j": energy, "error_deg_p95": error, "realizations": float(sc["simulation"]["realizations"])}, task)


def table_trial(task: RunTask) -> dict:
    """The stored result of an already-run point: ``payload['table']`` maps :func:`point_key` of the decision
    values to the run's metrics.  With common random numbers a run is a function of its decision values, so
    this equals re-running the point (benchmarks comparing samplers on one exhaustive grid)."""
    key = point_key(dict(task.params))
    if key not in task.payload["table"]:
        raise NodesimError(f"point {key} is not in the stored table")
    return _requested(task.payload["table"][key], task)


def _sampler(problem: Problem, offset: int):
    import optuna

    seed = problem.sampler_seed + offset
    if problem.sampler == "nsga2":
        if problem.batch < 2:
            raise NodesimError(f"{problem.source}: sampler 'nsga2' needs batch >= 2 (its population size)")
        return optuna.samplers.NSGAIISampler(population_size=problem.batch, seed=seed)
    if problem.sampler == "tpe":
        # multivariate: the joint density of the variables (update window and timeout act together on energy
        # and error); constant liar (Optuna's default) spreads the trials of one batch
        return optuna.samplers.TPESampler(seed=seed, n_startup_trials=max(problem.batch, 8), multivariate=True)
    return optuna.samplers.RandomSampler(seed=seed)


def open_study(problem: Problem, directory: Path, offset: int = 0, create: bool = True):
    """The study in ``directory/study.journal`` (created when ``create``), with a sampler seeded at ``offset``."""
    import optuna
    from optuna.storages import JournalStorage
    from optuna.storages.journal import JournalFileBackend

    optuna.logging.set_verbosity(optuna.logging.WARNING)
    path = Path(directory) / JOURNAL
    if not create and not path.exists():
        raise NodesimError(f"{directory}: no study journal ({JOURNAL}) to read")
    storage = JournalStorage(JournalFileBackend(str(path)))
    return optuna.create_study(
        storage=storage, study_name=STUDY_NAME, sampler=_sampler(problem, offset), load_if_exists=True,
        directions=[o.direction for o in problem.objectives],
    )


def point_key(params: dict) -> str:
    """Canonical text of a point's decision values (sorted keys, JSON)."""
    return dumps_json(sorted(params.items())).decode()


def _record_of(frozen):
    """A RunRecord rebuilt from a told trial's stored attributes (reuse of its result on resume)."""
    from nodesim.sweep.tasks import RunRecord

    run = frozen.user_attrs["run"]
    metrics = {k: (math.nan if v is None else v) for k, v in frozen.user_attrs["metrics"].items()}
    return RunRecord(f"t{frozen.number:05d}", frozen.number, 0, 0, tuple(frozen.params.items()), run["status"], metrics,
                     run["error"], run["attempts"], run["wall_s"], run["worker"])


def _tell(study, problem: Problem, number: int, trial_id: int, rec, reused: bool = False) -> None:
    from optuna.trial import Trial, TrialState

    metrics = {k: (None if v != v else float(v)) for k, v in rec.metrics.items()}
    violations = [c.violation(rec.metrics.get(c.key, math.nan)) for c in problem.constraints]
    trial = Trial(study, trial_id)
    trial.set_user_attr("metrics", metrics)
    if reused:  # same decision values as an earlier trial: its run's result, not a new evaluation
        trial.set_user_attr("reused_from", rec.point)
    trial.set_user_attr("violations", [None if math.isinf(v) else v for v in violations])
    for c, v in zip(problem.constraints, violations):  # what the samplers read (Optuna >= 5 trial constraints)
        trial.set_constraint(c.key, min(v, BIG_VIOLATION))
    trial.set_user_attr("run", {"status": rec.status, "error": rec.error, "wall_s": rec.wall_s, "worker": rec.worker,
                                "attempts": rec.attempts})
    values = [rec.metrics.get(o.key, math.nan) for o in problem.objectives]
    if rec.status == "ok" and all(math.isfinite(v) for v in values):
        study.tell(number, values)
    else:
        study.tell(number, state=TrialState.FAIL)


def _check_keys(study) -> None:
    """Stop when every trial so far failed because an objective/constraint key is not produced by a run."""
    from optuna.trial import TrialState

    done = [t for t in study.get_trials(deepcopy=False) if t.state in (TrialState.COMPLETE, TrialState.FAIL)]
    errors = [(t.user_attrs.get("run") or {}).get("error") or "" for t in done]
    if done and all(MISSING in e for e in errors):
        raise NodesimError(errors[0].replace("NodesimError: ", ""))


def _manifest(problem: Problem, out: Path, executor, old: dict | None, n_trials: int) -> dict:
    return {
        "kind": "optimization",
        "nodesim_version": package_version(),
        "git_commit": git_commit(),
        "optimize": problem.describe(),
        "base_scenario": problem.base.model_dump(),
        "trial_budget": n_trials,
        "executor": executor.describe(),
        "host": host_info(),
        "started_utc": (old or {}).get("started_utc", datetime.now(timezone.utc).isoformat()),
        "status": "running",
        "study": str(out / JOURNAL),
    }


def run_search(problem: Problem, out_dir: Path, executor, n_trials: int | None = None, resume: bool = False,
               quiet: bool = False, run_fn: Callable[[RunTask], dict] = run_trial, payload: dict | None = None,
               stream=None, max_evaluations: int | None = None) -> dict:
    """Run (or resume) the study of ``problem`` in ``out_dir`` until it holds ``n_trials`` finished trials.

    ``max_evaluations``: also stop once the study holds that many runs (finished trials that were not a repeat
    of an earlier point; a batch is shortened so as not to pass it), ``n_trials`` then capping the trials
    (benchmarks giving a sampler a budget of runs).
    Returns the manifest (also written to ``DIR/optimization.json``); the tables are built by
    :func:`nodesim.optimization.outcome.finish`.
    """
    from optuna.trial import TrialState

    out = Path(out_dir)
    n_trials = problem.trials if n_trials is None else n_trials
    if not 1 <= n_trials <= 100_000:
        raise NodesimError(f"--trials must be in [1, 100000] (got {n_trials})")
    old = read_manifest_file(out)
    if old is not None and not resume:
        raise NodesimError(f"{out}: already holds a study; pass --resume to continue it, or choose another --out")
    if resume and old is None:
        raise NodesimError(f"{out}: no study to resume ({MANIFEST} missing)")
    if old is not None and old.get("optimize", {}).get("spec_sha256") != problem.spec_hash:
        raise NodesimError(f"{out}: was started from a different optimisation file or base scenario; --resume needs "
                           "the same one, or choose another --out")
    out.mkdir(parents=True, exist_ok=True)
    manifest = _manifest(problem, out, executor, old, n_trials)
    write_json(out / MANIFEST, manifest)
    existing = open_study(problem, out).get_trials(deepcopy=False)
    study = open_study(problem, out, offset=len(existing))
    finished = sum(t.state in (TrialState.COMPLETE, TrialState.FAIL) for t in existing)
    pending = [t for t in existing if t.state == TrialState.RUNNING]
    cache = {}  # decision values -> the record of the finished run that evaluated them
    for t in existing:
        run = t.user_attrs.get("run") or {}
        if t.state == TrialState.COMPLETE and run.get("status") == "ok" and "reused_from" not in t.user_attrs:
            cache[point_key(dict(t.params))] = _record_of(t)
    evaluations = 0
    runs = sum(t.state in (TrialState.COMPLETE, TrialState.FAIL) and "reused_from" not in t.user_attrs
               for t in existing)
    run_cap = math.inf if max_evaluations is None else max_evaluations
    progress = Progress(max(n_trials, finished), already_done=finished, quiet=quiet, stream=stream)
    t0 = time.perf_counter()
    try:
        while (finished < n_trials and runs < run_cap) or pending:
            if pending:  # asked before an interruption, never told: run them again with their stored values
                batch = [(t.number, t._trial_id, {v.key: t.params[v.key] for v in problem.variables if v.key in t.params})
                         for t in pending]
                pending = []
            else:
                asked = [study.ask() for _ in range(int(min(problem.batch, n_trials - finished, run_cap - runs)))]
                batch = [(t.number, t._trial_id, problem.suggest(t)) for t in asked]
            # common random numbers make a run a function of its decision values: a repeated point is not re-run
            first: dict = {}
            for number, _, params in batch:
                first.setdefault(point_key(params), number)
            tasks = [problem.task(number, params, payload=payload) for number, _, params in batch
                     if first[point_key(params)] == number and point_key(params) not in cache]
            records = {}
            for rec in executor.imap(run_fn, tasks):
                records[rec.point] = rec
                progress.update(rec.status == "ok")
            for number, trial_id, params in batch:
                key = point_key(params)
                if key not in cache and records.get(number) is not None and records[number].status == "ok":
                    cache[key] = records[number]
                rec = records.get(number) or cache.get(key) or records[first[key]]
                _tell(study, problem, number, trial_id, rec, reused=rec.point != number)
            evaluations += len(tasks)
            runs += len(tasks)
            finished += len(batch)
            _check_keys(study)
    finally:
        progress.close()
        trials = study.get_trials(deepcopy=False)
        done = sum(t.state in (TrialState.COMPLETE, TrialState.FAIL) for t in trials)
        manifest.update(status="complete" if done >= n_trials or runs >= run_cap else "interrupted",
                        finished_trials=done, evaluations_this_session=evaluations,
                        finished_utc=datetime.now(timezone.utc).isoformat(), session_wall_s=time.perf_counter() - t0)
        write_json(out / MANIFEST, manifest)
    return manifest


def read_manifest_file(directory: Path) -> dict | None:
    """``DIR/optimization.json`` or None (the sweep's reader, pointed at this file name)."""
    return read_manifest(directory, MANIFEST)
