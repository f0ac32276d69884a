"""The chain network: feed-forward propagation, timeouts, losses, stale packets, delay compensation,
clocks, determinism and the shared event skeleton (thesis 3.4-3.5, digest 2.6-2.7)."""

import math

import numpy as np
import pytest

from nodesim.chain.network import simulate_chain
from nodesim.chain.metrics import per_realization_metrics, summarize
from nodesim.chain.network import Network, tick_span, tick_times
from nodesim.scenario.schema import Scenario
from nodesim.units import DEG, wrap_pi

SHORT = {"simulation.duration_s": 450.0, "metrics.window_start_s": 370.0, "metrics.window_end_s": 450.0}
QUIET = {  # noise-free sensors and a fine encoder: errors left are the chain's own
    "sensor.gyro_arw_deg_per_sqrt_s": 0.0,
    "sensor.gyro_turn_on_bias_deg_s": 0.0,
    "sensor.gyro_residual_bias_deg_s": 0.0,
    "sensor.gyro_scale_factor_error": 0.0,
    "sensor.gyro_bias_instability_deg_s": 0.0,
    "sensor.accel_noise_ug_per_sqrt_hz": 0.0,
    "sensor.encoder_counts_per_rev": 1 << 24,
}


def chain(**over):
    return simulate_chain(Scenario().with_overrides(**{**SHORT, **over}))


def test_one_reference_wave_per_update_runs_down_the_chain_and_timeouts_coast():
    run = chain(**{"chain.nodes": 4, "simulation.realizations": 2, "schedule.mode": "windowed",
                   "schedule.update_s": 20.0, "schedule.timeout_s": 30.0})
    top = run.nodes[0]
    assert top.update_mask.any() and not top.update_mask.all()
    for node in run.nodes[1:]:
        k = min(top.t_s.size, node.t_s.size)  # tick k of every node lies in the same cycle (stagger < dt)
        both = top.running[:k] & node.running[:k]
        # each node applies an update exactly in the ticks where the node above did
        assert (node.update_mask[:, :k][:, both] == top.update_mask[:, :k][:, both]).all()
        ages = node.update_age_s[node.update_mask]
        assert np.allclose(ages, 0.06)  # t_use - t_read = the clock stagger
    assert np.allclose(top.update_age_s[top.update_mask], 0.015)  # encoder read one link delay before use


def test_losses_stop_the_wave_below_the_lost_hop():
    run = chain(**{"chain.nodes": 3, "simulation.realizations": 4, "chain.link_loss_probability": 0.3})
    k = min(n.t_s.size for n in run.nodes)
    a, b, c = (n.update_mask[:, :k] for n in run.nodes)
    both = run.nodes[0].running[:k] & run.nodes[1].running[:k] & run.nodes[2].running[:k]
    assert (b[:, both] <= a[:, both]).all()
    assert (c[:, both] <= b[:, both]).all()
    fa, fb = a[:, both].mean(), b[:, both].mean()
    assert abs(fa - 0.7**2) < 0.03  # request and reply legs
    assert abs(fb / fa - 0.7) < 0.04
    assert run.lost_packets.sum() > 0


def test_stale_packets_are_ignored_and_counted():
    run = chain(**{"chain.nodes": 2, "simulation.realizations": 2, "chain.max_update_age_s": 0.01})
    top, low = run.nodes
    assert top.update_mask.any()
    assert not low.update_mask.any()  # every forwarded estimate is 0.06 s old at use
    sent = top.update_mask.sum(axis=1)
    # every packet is stale, except the last one when the run ends before node 2's next tick
    assert ((low.stale_packets == sent) | (low.stale_packets == sent - 1)).all()


@pytest.mark.parametrize("stagger", [0.06, 0.4])
def test_forwarded_estimate_is_advanced_by_the_receivers_rate(stagger):
    """Thesis eq 3.29: psi_ref = psi_hat_(n-1)(t_read) + omega_hat_n (t_use - t_read).  With perfect sensors
    node 2 tracks the string through the 71 deg/s rotation although the estimate is `stagger` s old
    (uncompensated that would be an error of 71 x stagger = 4.3 or 28 deg).  What remains is the one-off
    error of the rate step at the start of the rotation (the rate changed between t_read and t_use),
    which the filter absorbs over tens of seconds."""
    run = chain(**{**QUIET, "chain.nodes": 2, "chain.clock_stagger_s": stagger, "chain.link_delay_s": 0.1})
    low = run.nodes[1]
    rotating = (low.t_s > 262.0) & (low.t_s < 340.0)
    err = np.abs(wrap_pi(low.yaw_est_rad[0, rotating] - low.true_yaw_rad[rotating])) / DEG
    assert err.max() < 0.1
    assert err[-10:].max() < 0.5 * err[:10].max()  # the step error decays
    assert low.update_mask[0, rotating].all()


def test_hop_count_grows_the_yaw_error():
    run = chain(**{"chain.nodes": 3, "simulation.realizations": 8, "schedule.mode": "single",
                   "schedule.single_rate_hz": 0.8})
    m = summarize(per_realization_metrics(run, Scenario().with_overrides(**SHORT).metrics))
    assert m["node1_rms_yaw_error_deg"] < m["node2_rms_yaw_error_deg"] < m["node3_rms_yaw_error_deg"]


def test_clock_offset_and_drift():
    t = tick_times(0.25, 100.0, 1 / 1.9, 100.0)
    assert t[0] == 0.25
    assert math.isclose(t[1] - t[0], (1 / 1.9) / (1 + 1e-4))
    assert t[-1] <= 100.0 < t[-1] + (1 / 1.9)
    run = chain(**{"chain.nodes": 2, "chain.node": [{"id": 2, "clock_offset_s": 0.3, "clock_drift_ppm": 50.0}]})
    assert run.nodes[0].t_s[0] == 0.0 and run.nodes[1].t_s[0] == 0.3
    assert math.isclose(np.diff(run.nodes[1].t_s).mean(), (1 / 1.9) / (1 + 50e-6))
    assert run.nodes[1].update_mask.any()


def _ticks_from_the_array(offset, drift, dt, duration, present):
    """Network._tick_times' ticks of a clock without steps, from the whole array (faults.stepped_ticks' slice)."""
    t = tick_times(offset, drift, dt, duration)
    t = t[np.searchsorted(t, 0.0, side="left"):np.searchsorted(t, duration, side="right")]
    return t[np.searchsorted(t, present, side="left"):]


def test_tick_span_gives_the_array_s_ticks_without_the_array():
    rng = np.random.default_rng(7)
    dt = 1 / 1.9
    cases = [(0.0, 0.0, 86400.0, 0.0), (0.0, 0.0, 86400.0, 60.0), (0.0, 0.0, 100.0, 200.0), (150.0, 0.0, 100.0, 0.0),
             (0.25, 100.0, 100.0, -5.0), (0.0, 0.0, 10 * dt, 10 * dt), (0.0, -30.0, 500.0, 3 * dt / (1 - 30e-6)),
             (0.0, 0.0, 100.0, math.inf), (0.0, 0.0, 100.0, -math.inf)]
    for _ in range(300):
        present = rng.choice([rng.uniform(-10, 5000), float(rng.integers(0, 9000)) * dt])  # on a tick, or between
        cases.append((float(rng.choice([0.0, rng.uniform(0, 2)])), float(rng.uniform(-200, 200)), rng.uniform(1, 5000),
                      float(present)))
    for offset, drift, duration, present in cases:
        expected = _ticks_from_the_array(offset, drift, dt, duration, present)
        j0, j1, period = tick_span(offset, drift, dt, duration, present)
        made = np.arange(j1, dtype=float)[j0:j1] * period + offset
        assert j1 - j0 == expected.size and np.array_equal(made, expected), (offset, drift, duration, present)


@pytest.mark.parametrize("spill", [False, True])
def test_the_tick_table_holds_each_node_s_ticks(spill, monkeypatch):
    """Node clocks with offsets and drift, a clock step, a string partly in the hole: each row of the tick table
    (written from tick_span, or from the array where the clock steps; to the file when it spills) is the node's
    ticks."""
    from nodesim.chain import scratch

    monkeypatch.setattr(scratch, "SPILL_MIN_BYTES", 0)
    scenario = Scenario().with_overrides(**{
        "motion.kind": "drilling", "chain.nodes": 5, "motion.initial_tubes": 3, "simulation.duration_s": 1500.0,
        "metrics.window_start_s": 0.0, "metrics.window_end_s": 1500.0,
        "chain.node": [{"id": 2, "clock_offset_s": 0.3, "clock_drift_ppm": 50.0},
                       {"id": 4, "clock_offset_s": 0.1, "clock_drift_ppm": -80.0}],
        "faults.clock_step": [{"node": 3, "at_s": 100.0, "step_s": 0.2}]})
    net = Network(scenario, attach_signals=False, spill=spill)
    assert (net.scratch is not None) == spill and net.tick_clock()[0] is False  # the step: not affine
    assert [net._tick_span(i) is None for i in range(5)] == [False, False, True, False, False]
    for i, node in enumerate(net.nodes):
        assert np.array_equal(node.t_s, net._tick_times(i))
    assert net.nodes[0].t_s[0] > net.nodes[1].t_s[0] > 60.0  # the new tubes (at the top) tick from their insertion


def test_realizations_share_the_event_skeleton_and_own_their_draws():
    over = {"chain.nodes": 3, "chain.link_loss_probability": 0.2}
    one = chain(**over, **{"simulation.realizations": 1})
    three = chain(**over, **{"simulation.realizations": 3})
    again = chain(**over, **{"simulation.realizations": 3})
    assert one.simpy_events == three.simpy_events
    for a, b, c in zip(one.nodes, three.nodes, again.nodes):
        assert np.array_equal(a.yaw_est_rad[0], b.yaw_est_rad[0], equal_nan=True)
        assert np.array_equal(a.update_mask[0], b.update_mask[0])
        assert np.array_equal(b.yaw_est_rad, c.yaw_est_rad, equal_nan=True)
    assert not np.array_equal(three.nodes[2].update_mask[0], three.nodes[2].update_mask[1])


def test_fixed_point_firmware_runs_the_chain_and_tracks_the_float_filter():
    """Every node can run the bit-exact fixed-point filter (firmware issue); on a 3-node chain it stays
    within the digest 2.7 acceptance (0.01 deg RMS) of the float filter and does not saturate."""
    over = {"chain.nodes": 3, "simulation.realizations": 2}
    flt = chain(**over)
    fix = chain(**over, **{"filter.implementation": "fixed"})
    for a, b in zip(flt.nodes, fix.nodes):
        sel = a.running
        rms = np.sqrt(np.mean(wrap_pi(a.yaw_est_rad[:, sel] - b.yaw_est_rad[:, sel]) ** 2)) / DEG
        assert 0.0 < rms < 0.01
        assert sum(b.firmware_overflows.values()) == 0 and a.firmware_overflows == {}


def test_forward_every_tick_keeps_lower_nodes_updated_through_timeouts():
    """chain.forward = "every_tick": a node forwards its post-time-update estimate when it had no reference,
    so the node below is updated every tick while the top node coasts in the timeouts."""
    over = {"chain.nodes": 2, "simulation.realizations": 2, "schedule.mode": "windowed", "schedule.update_s": 20.0,
            "schedule.timeout_s": 30.0}
    default = chain(**over)
    every = chain(**over, **{"chain.forward": "every_tick"})
    top, low = every.nodes
    k = min(top.t_s.size, low.t_s.size)
    both = top.running[:k] & low.running[:k]
    assert not top.update_mask[:, :k][:, both].all()
    assert low.update_mask[:, :k][:, both].all()
    assert default.nodes[1].update_mask[:, both].mean() < 0.5
    # the coasting estimate carries the top node's growing variance, so node 2's R grows with it
    assert np.array_equal(default.nodes[0].yaw_est_rad, top.yaw_est_rad, equal_nan=True)
