"""Phase 1's event order (:func:`nodesim.chain.compiled.events.next_events`: a ring plus a heap) is SimPy's: one
priority queue of (time, creation counter), each node's next tick scheduled at now + (T - now) when it finishes
the last.  The reference here is that queue written with :mod:`heapq`."""

import heapq

import numpy as np
import pytest

from nodesim.chain.compiled import events as ev


def _simpy_order(T, K, dead_at):
    queue, eid = [], 0
    for n in range(T.shape[0]):
        if K[n] > 0 and T[n, 0] < dead_at[n]:
            heapq.heappush(queue, (0.0 + (T[n, 0] - 0.0), eid, n, 0))
            eid += 1
    order = []
    while queue:
        now, _, n, k = heapq.heappop(queue)
        order.append((n, k))
        if k + 1 < K[n] and T[n, k + 1] < dead_at[n]:
            heapq.heappush(queue, (now + (T[n, k + 1] - now), eid, n, k + 1))
            eid += 1
    return order


def _compiled_order(T, K, dead_at, chunk, clock=None, times_of=None):
    """The compiled order, each event's time checked against ``times_of`` (T where None)."""
    clock = ev.table_clock(T.shape[0]) if clock is None else clock
    times_of = T if times_of is None else times_of
    queue, counters, next_k = ev.first_events(T, K, dead_at, clock)
    nodes, ticks = np.empty(chunk, np.int32), np.empty(chunk, np.int32)
    times, codes = np.empty(chunk), np.empty(chunk, np.int8)
    plan = np.zeros(T.shape, np.int8)
    order = []
    while count := ev.next_events(T, K, dead_at, plan, queue, counters, next_k, nodes, ticks, times, codes, clock):
        order += list(zip(nodes[:count].tolist(), ticks[:count].tolist()))
        assert times[:count].tolist() == [times_of[n, k] for n, k in order[-count:]]
    return order


def _random_clocks(rng):
    """Tick tables with what reorders nodes: offsets, drifts, clock steps, deaths, nodes that start late."""
    N, K_max = int(rng.integers(1, 25)), int(rng.integers(1, 50))
    T, K = np.full((N, K_max), np.nan), rng.integers(0, K_max + 1, N)
    for n in range(N):
        offset = rng.choice([0.0, rng.uniform(0, 3), rng.uniform(0, 30), float(rng.integers(0, 3))])
        t = offset + np.arange(K[n]) * rng.choice([1.0, rng.uniform(0.9, 1.1)])
        if K[n] > 3 and rng.random() < 0.2:
            j = int(rng.integers(1, K[n]))
            t[j:] += rng.uniform(-3, 3)
            t = np.unique(t)
            K[n] = t.size
        T[n, :K[n]] = t
    dead_at = np.where(rng.random(N) < 0.2, rng.uniform(0, 40, N), np.inf)
    return T, K, dead_at


@pytest.mark.parametrize("seed", range(60))
def test_the_event_order_is_simpys(seed):
    rng = np.random.default_rng(seed)
    T, K, dead_at = _random_clocks(rng)
    assert _compiled_order(T, K, dead_at, int(rng.choice([1, 4, 1000]))) == _simpy_order(T, K, dead_at)



def test_the_event_order_is_simpys_with_more_nodes_than_the_prefetch_looks_ahead():
    """A ring longer than :data:`~nodesim.chain.compiled.prefetch.AHEAD` (its prefetches run): the same order."""
    from nodesim.chain.compiled.prefetch import AHEAD

    rng = np.random.default_rng(7)
    N, K_max = 4 * AHEAD, 40
    T = np.arange(K_max)[None, :] * rng.uniform(0.99, 1.01, (N, 1)) + rng.uniform(0, 1, (N, 1))
    K, dead_at = rng.integers(1, K_max + 1, N), np.where(rng.random(N) < 0.1, rng.uniform(0, 40, N), np.inf)
    assert _compiled_order(T, K, dead_at, 1000) == _simpy_order(T, K, dead_at)


@pytest.mark.parametrize("seed", range(20))
def test_an_affine_clock_gives_the_tables_ticks_and_order_without_reading_it(seed):
    """Clocks of :func:`nodesim.chain.network.tick_times` (offset + k period, drifting, from a first tick on): the
    event order and every tick time computed from (first, period, offset) are the table's; the table given here is
    NaN, so nothing is read from it."""
    from nodesim.chain.network import tick_period_s, tick_times

    rng = np.random.default_rng(100 + seed)
    N, K_max = int(rng.integers(1, 30)), int(rng.integers(1, 60))
    T, K = np.full((N, K_max), np.nan), rng.integers(1, K_max + 1, N)
    first, period, offset = np.zeros(N, np.int64), np.zeros(N), np.zeros(N)
    for n in range(N):
        offset[n], drift = rng.uniform(0, 3), rng.choice([0.0, rng.uniform(-200, 200)])
        period[n] = tick_period_s(drift, 1 / 1.9)
        first[n] = rng.integers(0, 5000)
        full = tick_times(offset[n], drift, 1 / 1.9, (first[n] + K[n] + 0.5) * period[n] + offset[n])
        T[n, :K[n]] = full[first[n]:first[n] + K[n]]
    dead_at = np.where(rng.random(N) < 0.2, rng.uniform(0, 3000, N), np.inf)
    order = _compiled_order(T, K, dead_at, 7)
    assert _compiled_order(np.full_like(T, np.nan), K, dead_at, 7, (True, first, period, offset), T) == order


def test_the_networks_clock_is_affine_unless_a_clock_steps():
    """:meth:`Network.tick_clock` reproduces every node's tick times (drilling: nodes that tick from their insertion;
    per-node clock offsets and drifts), and is not affine with a clock step."""
    from pathlib import Path

    from nodesim.chain.network import Network
    from nodesim.scenario.schema import load_scenario

    base = load_scenario(Path(__file__).parents[3] / "scenarios" / "field" / "drilling_10_tubes.toml")[0]
    clocks = base.with_overrides(**{"chain.node": [{"id": 3, "clock_offset_s": 0.123, "clock_drift_ppm": 80.0},
                                                   {"id": 7, "clock_drift_ppm": -40.0}]})
    net = Network(clocks, attach_signals=False)
    affine, first, period, offset = net.tick_clock()
    assert affine
    for n, node in enumerate(net.nodes):
        k = np.arange(node.t_s.size)
        assert ((k + first[n]).astype(float) * period[n] + offset[n]).tobytes() == node.t_s.tobytes()
    stepped = base.with_overrides(**{"faults.clock_step": [{"node": 2, "at_s": 100.0, "step_s": 0.3}]})
    assert not Network(stepped, attach_signals=False).tick_clock()[0]
