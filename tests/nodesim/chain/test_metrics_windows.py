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


def test_trailing_averages_in_pieces_are_the_moving_average_at_once():
    """firmware_model.survey_resolution.TrailingAverage: a series given in pieces (of one sample, shorter and longer
    than the average) gives the N-point trailing average's definition (prefix sums by numpy's cumsum, their
    differences, divided by min(k + 1, N)) of the whole series, bit for bit; CircularAverage in pieces gives
    circular_moving_average at once."""
    from firmware_model.survey_resolution import CircularAverage, TrailingAverage, circular_moving_average

    x = np.random.default_rng(4).normal(size=(3, 500)) * 1e3
    edges = [0, 1, 2, 5, 60, 61, 300, 500]
    for points in (1, 2, 7, 100):
        csum = np.cumsum(x, axis=1)
        want = csum.copy()
        want[:, points:] = csum[:, points:] - csum[:, :-points]
        want = want / np.minimum(np.arange(1, 501), points)
        average, circular = TrailingAverage(points), CircularAverage(points)
        got = np.concatenate([average.add(x[:, a:b]) for a, b in zip(edges[:-1], edges[1:])], axis=1)
        assert np.array_equal(got, want), points
        got = np.concatenate([circular.add(x[:, a:b]) for a, b in zip(edges[:-1], edges[1:])], axis=1)
        assert np.array_equal(got, circular_moving_average(x, points)), points


@pytest.mark.parametrize("over", [
    {"motion.kind": "drilling", "chain.nodes": 4, "simulation.duration_s": 520.0, "simulation.realizations": 3,
     "metrics.window_start_s": 0.0, "metrics.window_end_s": 520.0, "motion.rate_of_penetration_m_s": 2.0 / 60.0,
     "motion.survey_stop_s": 30.0, "motion.survey_settle_s": 15.0, "motion.insertion_s": 30.0,
     "faults.node_failure": [{"node": 3, "at_s": 400.0}], "radio.model": "channel", "radio.shadowing_sigma_db": 0.0,
     "radio.soil.distance_m": 2.0, "radio.soil.vwc": 0.275, "mac.enabled": True},
    {"chain.nodes": 2, "simulation.duration_s": 300.0, "simulation.realizations": 2, "metrics.window_start_s": 120.0,
     "metrics.window_end_s": 300.0, "metrics.output_moving_average_points": 25, "metrics.bias_hold_s": 5.0,
     "schedule.mode": "windowed", "schedule.update_s": 20.0, "schedule.timeout_s": 60.0}])
def test_node_metrics_from_windows_of_ticks_are_those_at_once(over):
    """NodeMetricSums fed a node's records window by window (NodeRun.ticks, windows of 1 to 7 ticks) gives
    node_metrics' values: bit for bit, except the RMS errors and the mean age, whose window sums are added
    (equal to 1e-13 relative); drilling (survey stops as metric windows, a dead node) and lab motion with the
    output moving average and timeouts."""
    from nodesim.chain.metrics import NodeMetricSums, bias_hold_ticks, node_metrics
    from nodesim.chain.network import simulate_chain
    from nodesim.scenario.schema import Scenario

    scenario = Scenario().with_overrides(**over)
    run = simulate_chain(scenario)
    rng = np.random.default_rng(1)
    for node in run.nodes:
        want = node_metrics(run.motion, node, scenario.metrics)
        K = node.t_s.size
        cuts = np.unique(np.concatenate([[0, 1, 2, K], rng.integers(0, K, size=12), np.arange(0, K, 7)]))
        sums = NodeMetricSums(run.motion, scenario.metrics, node.yaw_est_rad.shape[0],
                              bias_hold_ticks(node.t_s, scenario.metrics.bias_hold_s))
        for a, b in zip(cuts[:-1], cuts[1:]):
            sums.add(node.ticks(int(a), int(b)))
        got = sums.metrics()
        assert set(got) == set(want)
        for key in want:
            if key.startswith("rms_") or key == "mean_update_age_s":
                assert np.allclose(got[key], want[key], rtol=1e-13, atol=0, equal_nan=True), (node.node_id, key)
            else:
                assert np.array_equal(got[key], want[key], equal_nan=True), (node.node_id, key)
        assert np.isfinite(want["rms_azimuth_error_deg"]).all()


@pytest.mark.parametrize("seed, hold", [(1, 1), (2, 7), (3, 40), (4, 4000)])
def test_the_bias_band_s_runs_carried_over_windows_find_the_same_first_run(seed, hold):
    """metrics._hold_runs given a band test window by window (the run carried over each cut) finds the first run of
    ``hold`` ticks that bias_convergence_time_s's definition finds at once."""
    from nodesim.chain.metrics import _hold_runs

    rng = np.random.default_rng(seed)
    inside = rng.random((5, 3000)) > 0.08  # runs of ~12 ticks on average, some much longer
    t = np.cumsum(rng.choice([0.25, 0.5], size=3000))
    want = (np.zeros(5, np.int64), np.full(5, np.nan), np.full(5, np.nan))
    _hold_runs(inside, t, hold, *want)
    got = (np.zeros(5, np.int64), np.full(5, np.nan), np.full(5, np.nan))
    for a in range(0, 3000, 5):
        _hold_runs(inside[:, a:a + 5], t[a:a + 5], hold, *got)
    for r in range(5):
        first = next((i for i in range(3000 - hold + 1) if inside[r, i:i + hold].all()), None)
        assert (np.isnan(want[2][r]) if first is None else want[2][r] == t[first]), r
    assert np.array_equal(got[2], want[2], equal_nan=True) and np.isfinite(want[2]).sum() >= 5 * (hold < 100)
