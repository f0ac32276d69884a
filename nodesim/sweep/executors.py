"""Executors behind one seam: a local process pool or Dask distributed.

Both implement ``imap(fn, tasks) -> iterator of RunRecord`` (records in completion order; the campaign store
sorts them), keep a bounded number of runs in flight (2 per worker) and share one retry rule:

- a run that *raises* is retried inside the worker by :func:`nodesim.sweep.tasks.execute`;
- a run whose *worker dies* (killed process: ``BrokenProcessPool``; lost Dask worker: ``KilledWorker`` or
  any error raised by its future) is resubmitted by the driver.  Every such loss costs each affected run one
  attempt (a dying local pool takes down every run in flight on it, so each of those is charged).  After
  ``task.max_attempts`` attempts the run is recorded as failed with the last error and the campaign goes on.

The local pool dies with its driver: :mod:`nodesim.sweep.watchdog` kills its processes and removes its
temporary directory when the driver exits, even by SIGKILL.  The local pool uses the ``forkserver`` start method where available (children forked from a clean server
process that has pre-imported the simulator, so no threads or locks of the driver are inherited) and
``spawn`` elsewhere.  Results do not depend on the executor: every run is seeded by its task alone.
"""

from __future__ import annotations

import logging
import multiprocessing as mp
import os
import uuid
from collections import deque
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from typing import Callable, Iterable, Iterator

from nodesim import threads
from nodesim.errors import NodesimError
from nodesim.sweep.spec import RunTask
from nodesim.sweep.tasks import RunRecord, execute, failed_record

RunFn = Callable[[RunTask], dict]


def _lost(task: RunTask, attempts: int, exc: BaseException, queue: deque) -> RunRecord | None:
    """Charge one attempt for a lost worker; requeue the task or return its failed record."""
    if attempts >= task.max_attempts:
        return failed_record(task, f"worker lost: {type(exc).__name__}: {exc}", attempts)
    queue.appendleft((task, attempts))
    return None


def _immediate(task: RunTask) -> RunRecord | None:
    """Invalid points are recorded without being shipped to a worker."""
    return execute(None, task) if task.invalid is not None else None


def execute_on_one_thread(fn: RunFn, task: RunTask, prior_attempts: int = 0) -> RunRecord:
    """:func:`~nodesim.sweep.tasks.execute` with the run's realizations on one thread (:mod:`nodesim.threads`):
    the workers already use every CPU (local pool, or Dask workers as processes or as threads)."""
    with threads.limited(1):
        return execute(fn, task, prior_attempts)


class LocalExecutor:
    """A process pool on this machine (``--workers N``, default: the number of CPUs)."""

    name = "local"

    def __init__(self, workers: int | None = None):
        if workers is not None and not 1 <= workers <= 4096:
            raise NodesimError(f"--workers must be in [1, 4096] (got {workers})")
        self.workers = workers or os.cpu_count() or 1
        self._pool: ProcessPoolExecutor | None = None

    def _new_pool(self) -> ProcessPoolExecutor:
        # before any pool process exists: the watchdog kills them and removes multiprocessing's temporary
        # directory (the fork server's socket) if this driver dies without shutting the pool down
        from multiprocessing.util import get_temp_dir

        from nodesim.sweep import watchdog

        watchdog.start([get_temp_dir()])
        methods = mp.get_all_start_methods()
        if "forkserver" in methods:
            ctx = mp.get_context("forkserver")
            ctx.set_forkserver_preload(["nodesim.sweep.tasks", "nodesim.api"])
        else:
            ctx = mp.get_context("spawn")
        return ProcessPoolExecutor(max_workers=self.workers, mp_context=ctx)

    def imap(self, fn: RunFn, tasks: Iterable[RunTask]) -> Iterator[RunRecord]:
        queue: deque = deque((t, 0) for t in tasks)
        inflight: dict = {}
        window = 2 * self.workers
        while queue or inflight:
            if self._pool is None:
                self._pool = self._new_pool()
            while queue and len(inflight) < window:
                task, attempts = queue.popleft()
                rec = _immediate(task)
                if rec is not None:
                    yield rec
                    continue
                inflight[self._pool.submit(execute_on_one_thread, fn, task, attempts)] = (task, attempts)
            if not inflight:
                continue
            done, _ = wait(list(inflight), return_when=FIRST_COMPLETED)
            broken = False
            for fut in done:
                task, attempts = inflight.pop(fut)
                try:
                    yield fut.result()
                except BrokenProcessPool as exc:
                    broken = True
                    rec = _lost(task, attempts + 1, exc, queue)
                    if rec is not None:
                        yield rec
            if broken:
                # every other run in flight on the dead pool is lost too
                for fut, (task, attempts) in list(inflight.items()):
                    exc = fut.exception() if fut.done() else BrokenProcessPool("pool restarted")
                    rec = _lost(task, attempts + 1, exc or BrokenProcessPool("pool restarted"), queue)
                    if rec is not None:
                        yield rec
                inflight.clear()
                self._pool.shutdown(wait=False, cancel_futures=True)
                self._pool = None

    def describe(self) -> dict:
        return {"executor": self.name, "workers": self.workers}

    def close(self) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.close()


class DaskExecutor:
    """Dask distributed: an existing cluster (``--scheduler ADDRESS``) or a LocalCluster started here.

    ``processes=False`` runs the LocalCluster's workers as threads of this process (used by the tests);
    the default uses one single-threaded worker process per CPU, like the local executor.
    """

    name = "dask"

    def __init__(self, scheduler: str | None = None, workers: int | None = None, processes: bool = True):
        try:
            from distributed import Client, LocalCluster
        except ImportError as err:  # dask is the optional [dask] extra
            raise NodesimError(f"--executor dask needs dask[distributed]: pip install 'nodesim[dask]' ({err})") from None
        if workers is not None and not 1 <= workers <= 4096:
            raise NodesimError(f"--workers must be in [1, 4096] (got {workers})")
        self.scheduler = scheduler
        self.cluster = None
        if scheduler:
            try:
                self.client = Client(scheduler, timeout="15s")
            except (OSError, TimeoutError) as err:
                raise NodesimError(f"--scheduler {scheduler}: cannot reach the Dask scheduler ({err})") from None
        else:
            import tempfile

            from nodesim.sweep import watchdog

            # the workers' scratch space in a directory of our own, removed on close (and by the watchdog
            # if this driver dies), instead of a dask-scratch-space left in the temp directory
            self._scratch = tempfile.mkdtemp(prefix="nodesim-dask-")
            watchdog.start([self._scratch])
            import dask

            with dask.config.set({"temporary-directory": self._scratch}):  # dask's own dask-scratch-space too
                self.cluster = LocalCluster(
                    n_workers=workers or os.cpu_count() or 1,
                    threads_per_worker=1,
                    processes=processes,
                    dashboard_address=None,
                    silence_logs=logging.ERROR,
                    local_directory=self._scratch,
                )
            self.client = Client(self.cluster)

    @property
    def workers(self) -> int:
        info = self.client.scheduler_info()
        return max(1, sum(w.get("nthreads", 1) for w in info.get("workers", {}).values()))

    def imap(self, fn: RunFn, tasks: Iterable[RunTask]) -> Iterator[RunRecord]:
        from distributed import as_completed

        queue: deque = deque((t, 0) for t in tasks)
        meta: dict = {}
        window = 2 * self.workers
        pending = as_completed()
        tag = uuid.uuid4().hex[:8]
        while queue or meta:
            while queue and len(meta) < window:
                task, attempts = queue.popleft()
                rec = _immediate(task)
                if rec is not None:
                    yield rec
                    continue
                fut = self.client.submit(execute_on_one_thread, fn, task, attempts, pure=False, key=f"nodesim-{task.run_id}-{attempts}-{tag}")
                meta[fut.key] = (task, attempts)
                pending.add(fut)
            if not meta:
                continue
            fut = next(pending)
            task, attempts = meta.pop(fut.key)
            try:
                yield fut.result()
            except Exception as exc:  # noqa: BLE001 - KilledWorker, CommClosedError, ...: the worker was lost
                rec = _lost(task, attempts + 1, exc, queue)
                if rec is not None:
                    yield rec
            finally:
                fut.release()

    def describe(self) -> dict:
        return {"executor": self.name, "workers": self.workers, "scheduler": self.scheduler or "LocalCluster"}

    def close(self) -> None:
        self.client.close()
        if self.cluster is not None:
            self.cluster.close()
            import shutil

            shutil.rmtree(self._scratch, ignore_errors=True)

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def make_executor(kind: str, workers: int | None = None, scheduler: str | None = None, processes: bool = True):
    """The executor for ``--executor kind``; ``--scheduler`` only makes sense with dask."""
    if kind == "local":
        if scheduler:
            raise NodesimError("--scheduler needs --executor dask")
        return LocalExecutor(workers)
    if kind == "dask":
        return DaskExecutor(scheduler, workers, processes)
    raise NodesimError(f"--executor must be 'local' or 'dask' (got {kind!r})")
