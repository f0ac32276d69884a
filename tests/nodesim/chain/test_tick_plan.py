"""The compiled engine's tick codes (:func:`nodesim.chain.compiled.tick_plan.node_codes`, each window a slice of
the increasing ticks) against the masks of its docstring's rules, on random timelines."""

import numpy as np

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
