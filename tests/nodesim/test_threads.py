"""Realizations on worker threads (nodesim.threads): same numbers as one thread, clear errors, fork-safe."""

import multiprocessing as mp
import threading

import numpy as np
import pytest

from nodesim import threads
from nodesim.chain.network import simulate_chain
from nodesim.errors import NodesimError
from nodesim.scenario.schema import Scenario
from tests.nodesim.chain.test_compiled import CASES, FIXED, assert_identical


def test_chunks_cover_the_realizations_once_and_evenly():
    for R, n in [(1000, 2), (1001, 3), (64, 4), (33, 2)]:
        ranges = threads.chunks(R, n)
        assert ranges[0][0] == 0 and ranges[-1][1] == R
        assert all(a[1] == b[0] for a, b in zip(ranges, ranges[1:]))
        sizes = [b - a for a, b in ranges]
        assert len(ranges) == min(n, R // threads.MIN_REALIZATIONS_PER_THREAD) and max(sizes) - min(sizes) <= 1


def test_small_batches_stay_on_one_thread():
    assert threads.chunks(1, 8) == [(0, 1)]
    assert threads.chunks(2 * threads.MIN_REALIZATIONS_PER_THREAD - 1, 8) == [(0, 31)]


@pytest.mark.parametrize("text", ["0", "-2", "two", "1.5", "5000"])
def test_a_bad_thread_count_is_a_clear_error(monkeypatch, text):
    monkeypatch.setenv(threads.ENV, text)
    with pytest.raises(NodesimError, match="NODESIM_THREADS must be an integer in \\[1, 1024\\]"):
        threads.thread_count()


def test_map_chunks_runs_the_ranges_on_worker_threads_in_order(monkeypatch):
    monkeypatch.setenv(threads.ENV, "3")
    seen = []
    out = threads.map_chunks(lambda a, b: (seen.append(threading.current_thread().name), (a, b))[1], 96)
    assert out == [(0, 32), (32, 64), (64, 96)]
    assert all(name.startswith("nodesim") for name in seen)


def _child(queue):
    queue.put(threads.map_chunks(lambda a, b: b - a, 64))


def test_a_forked_child_gets_its_own_threads(monkeypatch):
    monkeypatch.setenv(threads.ENV, "2")
    threads.map_chunks(lambda a, b: None, 64)  # the parent's pool exists
    ctx = mp.get_context("fork")
    queue = ctx.Queue()
    child = ctx.Process(target=_child, args=(queue,))
    child.start()
    child.join(60)
    assert child.exitcode == 0 and queue.get(timeout=5) == [32, 32]


@pytest.mark.parametrize("name", ["lossy, shadowing, 5 nodes", "fixed, dead node and fallback"])
def test_a_batch_on_threads_equals_the_batch_on_one_thread(monkeypatch, name):
    """R = 64 on 2 threads (two ranges of 32) and on 1: every record, link statistic and overflow count
    equal.  The dead-node case restarts phase 1 for more draws (both ranges ask) and sums fixed-point
    overflow counts over the ranges."""
    over = {**CASES, **FIXED}[name] | {"simulation.realizations": 64, "simulation.engine": "compiled"}
    scenario = Scenario().with_overrides(**over)
    monkeypatch.setenv(threads.ENV, "1")
    one = simulate_chain(scenario)
    monkeypatch.setenv(threads.ENV, "2")
    assert len(threads.chunks(64)) == 2
    two = simulate_chain(scenario)
    assert_identical(one, two)
    assert not np.array_equal(two.nodes[-1].yaw_est_rad[0], two.nodes[-1].yaw_est_rad[40])


@pytest.mark.parametrize("name", ["lossy, shadowing, 5 nodes", "fixed, drilling, lossy hops"])
def test_a_single_realization_on_node_threads_equals_one_thread(monkeypatch, name):
    """R = 1: the nodes' sensor signals and surveys on worker threads (threads.map_nodes), same bits as one
    thread, on both engines."""
    for engine in ("compiled", "event"):
        over = {**CASES, **FIXED}[name] | {"simulation.realizations": 1, "simulation.engine": engine}
        scenario = Scenario().with_overrides(**over)
        monkeypatch.setenv(threads.ENV, "1")
        one = simulate_chain(scenario)
        monkeypatch.setenv(threads.ENV, "2")
        used = []
        original = threads._executor
        monkeypatch.setattr(threads, "_executor", lambda n: (used.append(n), original(n))[1])
        two = simulate_chain(scenario)
        monkeypatch.setattr(threads, "_executor", original)
        assert used  # the nodes did go to the pool
        assert_identical(one, two)


def test_map_nodes_keeps_node_order_and_stays_inline_for_big_batches(monkeypatch):
    monkeypatch.setenv(threads.ENV, "2")
    assert threads.map_nodes(lambda i: i * i, 5, 1) == [0, 1, 4, 9, 16]
    names = threads.map_nodes(lambda i: threading.current_thread().name, 2, 64)
    assert names == [threading.current_thread().name] * 2  # 64 realizations split by map_chunks instead


def test_limited_caps_the_calling_thread_only(monkeypatch):
    monkeypatch.setenv(threads.ENV, "4")
    seen = []
    with threads.limited(1):
        assert threads.thread_count() == 1 and threads.chunks(1000) == [(0, 1000)]
        other = threading.Thread(target=lambda: seen.append(threads.thread_count()))
        other.start()
        other.join()
    assert seen == [4] and threads.thread_count() == 4


def test_a_sweep_point_runs_its_realizations_on_one_thread(monkeypatch):
    """Both executors submit execute_on_one_thread: a point's batched run keeps to one thread in its worker
    (local pool processes, or Dask workers that may be threads of the driver), and the driver's setting stays."""
    from nodesim.sweep.executors import execute_on_one_thread
    from nodesim.sweep.spec import RunTask

    monkeypatch.setenv(threads.ENV, "2")
    task = RunTask(run_id="r0", point=0, seed_index=0, seed=1, params=(), scenario={}, max_attempts=1)
    record = execute_on_one_thread(lambda t: {"threads": threads.thread_count()}, task)
    assert record.status == "ok" and record.metrics == {"threads": 1}
    assert threads.thread_count() == 2
