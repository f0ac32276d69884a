"""The metric ticks and the bias convergence time (nodesim.chain.metrics) against their definitions, on ticks that
fall on the windows' edges: a window [a, b] holds the running ticks with a <= t <= b; convergence is the first
running tick after the end of the rotations from which |b_hat - b| <= tol holds for ceil(hold / dt) ticks."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from nodesim.chain.metrics import bias_convergence_time_s, metric_ticks


def _node(seed: int, K: int = 4000, R: int = 3):
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.choice([0.25, 0.5, 0.75], size=K))
    return SimpleNamespace(t_s=t, running=rng.random(K) > 0.1,
                           bias_est_rad_s=rng.normal(scale=1e-3, size=(R, K)), true_bias_rad_s=np.zeros((R, K)))


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_the_metric_ticks_are_the_running_ticks_inside_any_window(seed):
    node = _node(seed)
    rng = np.random.default_rng(seed + 10)
    edges = rng.choice(node.t_s, size=40)  # windows that start and end on ticks, some overlapping, one reversed
    windows = [(float(min(a, b)), float(max(a, b))) for a, b in edges.reshape(-1, 2)] + [(50.0, 20.0), (-5.0, 3.1)]
    want = np.zeros(node.t_s.size, bool)
    for a, b in windows:
        want |= (node.t_s >= a) & (node.t_s <= b)
    assert np.array_equal(metric_ticks(node, windows), want & node.running)
    assert not metric_ticks(node, ()).any()


@pytest.mark.parametrize("seed, hold_s", [(1, 10.0), (2, 0.0), (3, 3.0), (4, 1e6)])
def test_the_bias_converges_at_the_first_run_of_hold_ticks_inside_the_band(seed, hold_s):
    node = _node(seed)
    tol, after = 1.2e-3, float(node.t_s[100])
    got = bias_convergence_time_s(node, after, tol, hold_s)
    idx = np.flatnonzero((node.t_s >= after) & node.running)
    h = max(int(math.ceil(hold_s / (node.t_s[1] - node.t_s[0]))), 1)
    for r in range(got.size):
        ok = np.abs(node.bias_est_rad_s[r, idx] - node.true_bias_rad_s[r, idx]) <= tol
        first = next((i for i in range(ok.size - h + 1) if ok[i:i + h].all()), None)
        assert (np.isnan(got[r]) if first is None else got[r] == node.t_s[idx[first]] - after), (r, first, got[r])


@pytest.mark.parametrize("seed, start_tick, keep_before_start", [(1, 100, False), (2, 100, True), (3, 0, True),
                                                                 (4, 3990, False)])
def test_the_longest_time_since_an_update_is_numpys_max_over_the_metric_ticks(seed, start_tick, keep_before_start):
    """Against the (R, K) definition: since = t - max(last update, start), NaN before the start, max over sel
    (numpy's max: NaN as soon as one selected tick is before the start)."""
    from nodesim.chain.metrics import max_time_since_update_s

    node = _node(seed)
    rng = np.random.default_rng(seed + 20)
    node.update_mask = rng.random(node.bias_est_rad_s.shape) > 0.97
    node.filter_start_s = float(node.t_s[start_tick])
    sel = rng.random(node.t_s.size) > 0.5
    sel[-1] = True
    if not keep_before_start:
        sel[:start_tick] = False
    t = node.t_s
    last = np.maximum.accumulate(np.where(node.update_mask, t[None, :], -np.inf), axis=1)
    since = np.where(t[None, :] >= node.filter_start_s, t[None, :] - np.maximum(last, node.filter_start_s), np.nan)
    want = since[:, sel].max(axis=1)
    got = max_time_since_update_s(node, sel)
    assert np.array_equal(got, want, equal_nan=True) and np.isnan(got).all() == (keep_before_start and start_tick > 0)
    assert np.isnan(max_time_since_update_s(node, np.zeros(t.size, bool))).all()
