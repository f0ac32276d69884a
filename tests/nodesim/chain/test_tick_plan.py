"""The compiled engine's tick codes (:func:`nodesim.chain.compiled.tick_plan.node_codes`, each window a slice of
the increasing ticks) against the masks of its docstring's rules, on random timelines; which of them are running
ticks, and a window's tick times from the clock (:mod:`nodesim.chain.compiled.events`)."""

import numpy as np

from nodesim.chain.compiled import events as ev
from nodesim.chain.compiled import tick_plan as tp


def test_node_codes_take_each_window_as_a_slice():
    """:func:`tick_plan.node_codes` (windows by searchsorted) against the masks of its docstring's rules."""
    class Timeline:
        pass

    rng = np.random.default_rng(3)
    for _ in range(300):
        t = np.unique(rng.uniform(0, 100, rng.integers(0, 40)))
        tl = Timeline()
        tl.present_from_s, tl.top_until_s, tl.filter_start_s = rng.uniform(-10, 110, 3)
        tl.holds = [tuple(sorted(rng.uniform(-10, 110, 2))) for _ in range(rng.integers(0, 4))]
        scheduled, dead_at = rng.random(t.size) < 0.5, rng.choice([np.inf, rng.uniform(-10, 110)])
        want = np.full(t.size, tp.RUN, np.int8)
        top = (t >= tl.present_from_s) & (t < tl.top_until_s)
        want[top] = np.where(scheduled[top], tp.ASK, tp.TOP)
        for a, b in tl.holds:
            want[(t >= a) & (t < b)] = tp.HOLD
        want[t < tl.filter_start_s] = tp.STATIC
        if (t >= tl.filter_start_s).any():
            want[np.flatnonzero(t >= tl.filter_start_s)[0]] = tp.START
        want[(t >= dead_at) | (t < tl.present_from_s)] = tp.ABSENT
        assert np.array_equal(tp.node_codes(t, tl, scheduled, dead_at), want)


def test_running_ticks_are_the_running_codes_before_the_death():
    """:func:`events.running_ticks` (one compiled pass) against numpy's ``isin(codes, RUNNING) & (t < dead_at)``,
    every code, times with NaNs, deaths at +inf, inside and before the ticks."""
    rng = np.random.default_rng(5)
    for _ in range(200):
        K = int(rng.integers(0, 50))
        codes = rng.integers(tp.ABSENT, tp.RUN + 1, K).astype(np.int8)
        t = np.where(rng.random(K) < 0.1, np.nan, np.sort(rng.uniform(0, 100, K)))
        dead_at = rng.choice([np.inf, rng.uniform(-10, 110)])
        got = ev.running_ticks(codes, t, dead_at)
        assert got.dtype == np.bool_
        assert np.array_equal(got, np.isin(codes, tp.RUNNING) & (t < dead_at))
    assert set(tp.RUNNING) == {tp.ASK, tp.TOP, tp.RUN}  # the codes events._running tests


def test_a_windows_tick_times_are_the_tables_row():
    """:func:`events.tick_times`: the table's values where the clock is not affine, else the clock's formula
    float(k + first) * period + offset (the table's doubles, :meth:`nodesim.chain.network.Network.tick_clock`)."""
    rng = np.random.default_rng(8)
    N, K = 3, 40
    first, period, offset = rng.integers(0, 9, N), rng.uniform(0.5, 0.6, N), rng.uniform(-1, 1, N)
    T = (np.arange(K)[None, :] + first[:, None]).astype(float) * period[:, None] + offset[:, None]
    for affine in (True, False):
        table = T if affine else T + rng.normal(0, 1e-3, T.shape)  # not the formula: read from the table
        for n, k0, k1 in ((0, 0, K), (1, 7, 19), (2, 39, 40), (2, 5, 5)):
            got = ev.tick_times(table, (affine, first, period, offset), n, k0, k1)
            assert np.array_equal(got, table[n, k0:k1])
