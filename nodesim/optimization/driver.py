"""``nodesim.optimize``: the whole optimisation (search, tables, validation, report) in one call.

The library seam of ``nodesim optimize``; kept out of :mod:`nodesim.api` because trial runs import the API
(:func:`nodesim.optimization.search.run_trial`), and the API must not import them back.
"""

from __future__ import annotations

from pathlib import Path
from typing import Callable

from nodesim.errors import NodesimError


def optimize(
    opt: "str | Path | dict",
    *,
    out: str | Path | None = None,
    trials: int | None = None,
    executor: str = "local",
    scheduler: str | None = None,
    workers: int | None = None,
    resume: bool = False,
    validate: bool = True,
    report: bool = True,
    quiet: bool = True,
    run_fn: Callable | None = None,
    payload: dict | None = None,
):
    """Search the schedule of an optimisation file (``nodesim optimize``) and return its ``Study``.

    ``opt`` is a path or a parsed dict (:mod:`nodesim.optimization.problem`).  The study is stored in ``out``
    (default ``runs/<name>-<UTC timestamp>``; ``resume=True`` continues one); ``trials`` overrides the file's
    budget.  The returned :class:`nodesim.optimization.outcome.Study` holds ``trials``, ``pareto`` and
    ``sensitivity`` DataFrames, ``recommended`` (trial, decision values, TOML; None when no trial is feasible),
    ``validation`` (the fresh-seed re-run and the baseline) and ``closest`` (closest trials when infeasible).
    ``run_fn``/``payload``: the worker function and its free data (default: the simulator; tests and
    benchmarks pass :func:`nodesim.optimization.search.synthetic_trial`).
    """
    from nodesim.io.rundir import default_run_dir
    from nodesim.optimization.outcome import finish
    from nodesim.optimization.problem import read_problem
    from nodesim.optimization.search import run_search, run_trial
    from nodesim.sweep.executors import make_executor

    problem = read_problem(opt)
    if resume and out is None:
        raise NodesimError("resume needs out (the study directory to continue)")
    directory = Path(out) if out is not None else default_run_dir(problem.name)
    fn = run_fn or run_trial
    with make_executor(executor, workers, scheduler) as ex:
        run_search(problem, directory, ex, trials, resume=resume, quiet=quiet, run_fn=fn, payload=payload)
        study = finish(problem, directory, ex, fn, validate_run=validate, payload=payload)
    if report:
        from nodesim.report import write_report

        write_report(directory)
    return study
