"""What a worker runs: one (point, seed) through :func:`nodesim.api.simulate_scenario`, wrapped with bounded retries.

Run functions take a :class:`RunTask` and return a dict of metrics.  They live at module level so both
executors can ship them to workers by reference (process pools and Dask pickle functions by name).

:func:`execute` is the worker-side wrapper: it retries a run that raises (up to ``task.max_attempts``; a user error such as an unsupported
setting is deterministic and is not retried) and
then returns a failed :class:`RunRecord` carrying the last error; it never raises for a run's own failure,
so one bad point never stops a campaign.  A *worker* that dies (killed process, lost Dask worker) is handled
on the driver side by the executors (:mod:`nodesim.sweep.executors`).

``busy_run`` is a synthetic run function (no simulation) used by the benchmarks and tests: it keeps one
core busy for ``payload['busy_s']`` seconds and can fail or kill its worker on request.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import socket
import time
import traceback
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from nodesim.errors import USER_ERRORS
from nodesim.sweep.spec import RunTask, select_metrics


@dataclass(frozen=True)
class RunRecord:
    """The outcome of one run: the row the campaign store writes."""

    run_id: str
    point: int
    seed_index: int
    seed: int
    params: tuple
    status: str  # "ok" | "failed"
    metrics: dict
    error: str | None
    attempts: int
    wall_s: float
    worker: str


def run_point(task: RunTask) -> dict:
    """Run the task's scenario (:func:`nodesim.api.simulate_scenario`) and keep the requested metrics.

    The run directory (with its plot) is written only when the sweep keeps runs (``task.keep_dir``): a
    campaign keeps its table, not thousands of run directories.
    """
    from nodesim.api import simulate_scenario
    from nodesim.io.rundir import dumps_json
    from nodesim.scenario.schema import parse_scenario

    scenario = parse_scenario(task.scenario, source=task.run_id)
    digest = hashlib.sha256(dumps_json(task.scenario)).hexdigest()
    run = simulate_scenario(scenario, digest)
    if task.keep_dir is not None:
        # the directory is this task's own: an earlier attempt (a retry, a resumed campaign) is replaced
        shutil.rmtree(task.keep_dir, ignore_errors=True)
        run.save(Path(task.keep_dir))
    return select_metrics(run.summary, task.metrics)


def busy_run(task: RunTask) -> dict:
    """Synthetic run: spin one core for ``payload['busy_s']`` s; ``fail`` raises, ``crash_marker`` kills the worker once.

    ``crash_marker``: a file path; if it does not exist yet the function creates it and ends its process with
    ``os._exit(1)`` (a dying worker), so the retried attempt succeeds.
    """
    marker = task.payload.get("crash_marker")
    if marker and not os.path.exists(marker):
        Path(marker).write_text(task.run_id)
        os._exit(1)
    if task.payload.get("fail"):
        raise RuntimeError(f"synthetic failure of {task.run_id}")
    end = time.perf_counter() + float(task.payload.get("busy_s", 0.0))
    x = 0
    while time.perf_counter() < end:
        x += 1
    return {"value": float(task.seed) + float(task.point), "spins": float(x > 0)}


def failed_record(task: RunTask, error: str, attempts: int, wall_s: float = 0.0) -> RunRecord:
    return RunRecord(task.run_id, task.point, task.seed_index, task.seed, task.params, "failed", {}, error, attempts, wall_s, "")


def execute(fn: Callable[[RunTask], dict], task: RunTask, prior_attempts: int = 0) -> RunRecord:
    """Run ``fn(task)`` with bounded retries; return an ok or failed record (never raises for the run's error)."""
    t0 = time.perf_counter()
    if task.invalid is not None:
        return failed_record(task, f"invalid point: {task.invalid}", 0)
    worker = f"{socket.gethostname()}:{os.getpid()}"
    attempts = prior_attempts
    error = "no attempt left"
    while attempts < task.max_attempts:
        attempts += 1
        try:
            metrics = fn(task)
        except USER_ERRORS as exc:  # deterministic (bad value, unsupported setting): retrying cannot help
            return failed_record(task, f"{type(exc).__name__}: {exc}", attempts, time.perf_counter() - t0)
        except Exception as exc:  # noqa: BLE001 - a run's own failure is data, recorded with its message
            error = f"{type(exc).__name__}: {exc}"
            last = traceback.extract_tb(exc.__traceback__)[-1:] if exc.__traceback__ else []
            if last:
                error += f" (at {Path(last[0].filename).name}:{last[0].lineno})"
            continue
        return RunRecord(
            task.run_id, task.point, task.seed_index, task.seed, task.params, "ok", metrics, None, attempts,
            time.perf_counter() - t0, worker,
        )
    return failed_record(task, error, attempts, time.perf_counter() - t0)
