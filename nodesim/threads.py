"""Realizations (or, in a run of a few realizations, independent nodes) on worker threads: a compiled kernel run
over disjoint ranges of realizations at once.

Realizations share no state (every random draw, filter state, radio and packet is per realization), so a
compiled kernel (numba, ``nogil=True``) run over realizations [0, r1) in one thread and [r1, R) in another
writes disjoint rows and gives the same numbers, bit for bit, as one thread over all of them: only the wall
time changes.  A run with fewer than ``2 x MIN_REALIZATIONS_PER_THREAD`` realizations stays on the calling
thread.

``NODESIM_THREADS`` sets how many threads (default: the CPUs this process may use); :func:`limited` caps it for
the runs a thread starts inside a block (``nodesim sweep`` runs each point with 1: its workers already use
every CPU).
"""

from __future__ import annotations

import os
import threading
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from typing import Callable, Iterator, TypeVar

from nodesim.errors import NodesimError

MIN_REALIZATIONS_PER_THREAD = 16  # below this a thread costs more than it saves
ENV = "NODESIM_THREADS"

T = TypeVar("T")
_pool: ThreadPoolExecutor | None = None
_pool_size = 0
_pool_lock = threading.Lock()


_local = threading.local()  # .limit: the cap of :func:`limited` in this thread


def thread_count() -> int:
    """Threads a batched run may use: ``NODESIM_THREADS`` or the CPUs this process may run on, capped by an
    enclosing :func:`limited` of the calling thread."""
    text = os.environ.get(ENV, "").strip()
    if not text:
        n = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    else:
        try:
            n = int(text)
        except ValueError:
            n = 0
        if not 1 <= n <= 1024:
            raise NodesimError(f"{ENV} must be an integer in [1, 1024] (got {text!r})")
    limit = getattr(_local, "limit", None)
    return n if limit is None else min(n, limit)


@contextmanager
def limited(threads: int) -> Iterator[None]:
    """At most ``threads`` threads for the batched runs the calling thread starts inside the block."""
    before = getattr(_local, "limit", None)
    _local.limit = threads
    try:
        yield
    finally:
        _local.limit = before


def chunks(realizations: int, threads: int | None = None) -> list[tuple[int, int]]:
    """Contiguous realization ranges [r0, r1), one per thread, as even as they divide."""
    threads = thread_count() if threads is None else threads
    n = max(1, min(threads, realizations // MIN_REALIZATIONS_PER_THREAD))
    bounds = [realizations * i // n for i in range(n + 1)]
    return list(zip(bounds[:-1], bounds[1:]))


def _executor(workers: int) -> ThreadPoolExecutor:
    """The shared pool, grown to ``workers`` threads when a run asks for more (a replaced pool is not shut
    down: a run on another thread may still submit to it; its threads end once it is unreferenced)."""
    global _pool, _pool_size
    with _pool_lock:
        if _pool is None or _pool_size < workers:
            _pool, _pool_size = ThreadPoolExecutor(max_workers=workers, thread_name_prefix="nodesim"), workers
        return _pool


def _forget_pool_after_fork() -> None:  # a forked child has none of the parent's threads (nor a held lock)
    global _pool, _pool_size, _pool_lock
    _pool, _pool_size, _pool_lock = None, 0, threading.Lock()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_forget_pool_after_fork)


def map_nodes(work: Callable[[int], T], nodes: int, realizations: int) -> list[T]:
    """``work(i)`` for i = 0 .. nodes - 1, the results in node order: on worker threads, one task per node, when
    the realizations are too few for :func:`map_chunks` to split (a single-realization run), else in this thread
    (each node's work then splits its realizations).  Nodes must be independent (their own draws and records):
    the results are the same bits either way."""
    return map_nodes_later(work, nodes, realizations)()


def map_nodes_later(work: Callable[[int], T], nodes: int, realizations: int) -> Callable[[], list[T]]:
    """:func:`map_nodes` started now, its results when the returned function is called: the worker threads start
    on the nodes at once (this thread goes on meanwhile); where :func:`map_nodes` would work in this thread, the
    work is done at that call."""
    workers = thread_count()
    if workers == 1 or nodes < 2 or len(chunks(realizations, workers)) > 1:
        return lambda: [work(i) for i in range(nodes)]
    futures = [_executor(workers).submit(work, i) for i in range(nodes)]
    return lambda: [f.result() for f in futures]


def map_chunks(kernel: Callable[[int, int], T], realizations: int) -> list[T]:
    """``kernel(r0, r1)`` for every range of :func:`chunks`, on worker threads when there are several; the
    results in range order.  ``kernel`` must release the GIL (numba ``nogil=True``) to run in parallel."""
    ranges = chunks(realizations)
    if len(ranges) == 1:
        return [kernel(*ranges[0])]
    futures = [_executor(len(ranges)).submit(kernel, r0, r1) for r0, r1 in ranges]
    return [f.result() for f in futures]
