"""Faults in the chain (issue 7): a dead middle node with and without a reachable next-but-one node, a 60 s
outage, a burst-loss link and a clock step each complete and move the metrics the expected way."""

import numpy as np
import pytest

from nodesim.chain import faults
from nodesim.chain.network import simulate_chain
from nodesim.chain.metrics import per_realization_metrics
from nodesim.errors import NodesimError, ScenarioError
from nodesim.scenario.schema import Scenario

BASE = {  # 4 nodes, soil hops with the ARQ MAC, lab rotation from 50 s; metrics over 60..220 s
    "chain.nodes": 4, "simulation.duration_s": 220.0, "simulation.realizations": 2,
    "metrics.window_start_s": 60.0, "metrics.window_end_s": 220.0,
    "radio.model": "channel", "radio.shadowing_sigma_db": 0.0, "radio.soil.distance_m": 0.5, "mac.enabled": True,
}


def run(**over):
    s = Scenario().with_overrides(**{**BASE, **over})
    r = simulate_chain(s)
    return r, per_realization_metrics(r, s.metrics)


@pytest.fixture(scope="module")
def healthy():
    return run()


def test_healthy_channel_chain_delivers_everything(healthy):
    r, m = healthy
    assert np.all(m["delivery_ratio"] == 1.0)
    assert np.all(m["retransmissions"] == 0)
    for n in (1, 2, 3, 4):
        assert np.all(m[f"node{n}_max_time_since_update_s"] < 1.1)  # an update every tick or two
    assert np.all(m["radio_energy_j"] > 0)


def test_dead_middle_node_without_reachable_next_but_one_starves_the_nodes_below(healthy):
    # 1.5 m soil hops at vwc 0.2: 24 dB margin each, the 3 m skip hop -23 dB: no fallback
    _, ok = run(**{"radio.soil.distance_m": 1.5})
    r, m = run(**{"radio.soil.distance_m": 1.5, "faults.node_failure": [{"node": 2, "at_s": 100.0}]})
    assert not r.nodes[1].running[r.nodes[1].t_s >= 100.0].any()  # node 2 is dead from 100 s on
    assert np.all(m["fallback_frames"] == 0)
    for n in (3, 4):  # no reference from 100 s to the end: 120 s without an update
        assert np.all(m[f"node{n}_max_time_since_update_s"] > 115.0)
        assert np.all(m[f"node{n}_update_fraction"] < ok[f"node{n}_update_fraction"] - 0.5)
    assert np.all(m["hop2_delivery_ratio"] < 0.5)  # hop 2 feeds node 2: its frames are not acknowledged
    assert np.all(m["hop2_retransmissions"] > 100)


def test_dead_middle_node_with_reachable_next_but_one_falls_back(healthy):
    _, ok = healthy
    r, m = run(**{"faults.node_failure": [{"node": 2, "at_s": 100.0}]})
    assert np.all(m["fallback_frames"] > 100)
    # node 3 gets node 1's estimates over the 1 m skip hop after two unanswered frames
    assert np.all(m["node3_max_time_since_update_s"] < 3.0)
    assert np.all(m["node4_max_time_since_update_s"] < 3.0)
    assert np.all(m["node3_update_fraction"] > ok["node3_update_fraction"] - 0.05)
    assert np.all(m["node4_rms_azimuth_error_deg"] < 2 * ok["node4_rms_azimuth_error_deg"] + 0.05)


def test_a_60_s_outage_stales_the_nodes_below_for_60_s(healthy):
    _, ok = healthy
    outage = [{"hop": 2, "start_s": 100.0, "end_s": 160.0}]
    r, m = run(**{"faults.link_outage": outage, "faults.fallback": False})
    for n in (2, 3, 4):
        assert np.all(np.abs(m[f"node{n}_max_time_since_update_s"] - 60.0) < 1.2)
    assert np.all(ok["node2_max_time_since_update_s"] < 1.1)
    assert np.all(m["node1_max_time_since_update_s"] < 1.1)  # the hop above is untouched
    assert np.all(m["hop2_delivery_ratio"] < 0.75)
    assert np.all(m["node4_rms_yaw_error_deg"] > ok["node4_rms_yaw_error_deg"])
    # with the fallback node 1 reaches node 3 over the skip hop; node 2 answers again after the outage
    r, m = run(**{"faults.link_outage": outage})
    assert np.all(np.abs(m["node2_max_time_since_update_s"] - 60.0) < 1.2)
    assert np.all(m["node3_max_time_since_update_s"] < 3.0)
    assert np.all(m["fallback_frames"] > 100)


def test_burst_loss_link_costs_retransmissions_and_some_frames():
    burst = [{"hop": 2, "p_good_to_bad": 0.1, "p_bad_to_good": 0.3}]  # P(bad) = 0.25, bursts of ~3.3 attempts
    r, m = run(**{"faults.burst": burst, "simulation.realizations": 4})
    assert np.all(m["hop2_retransmissions"] > 50)
    assert np.all(m["hop1_retransmissions"] == 0)
    # ARQ saves most frames: a frame is lost only when 4 attempts in a row fall in the bad state
    assert np.all((m["hop2_delivery_ratio"] < 0.99) & (m["hop2_delivery_ratio"] > 0.8))
    r0, m0 = run(**{"faults.burst": burst, "simulation.realizations": 4, "mac.enabled": False})
    # without ARQ: 1 - P(bad); ~320 frames with state correlation 1 - p - r = 0.6 (variance x4): sigma of the
    # 4-realization mean ~0.024
    assert abs(m0["hop2_delivery_ratio"].mean() - 0.75) < 0.07
    assert np.all(m0["node2_update_fraction"] < m["node2_update_fraction"])


def test_clock_step_moves_the_ticks_and_the_update_age(healthy):
    _, ok = healthy
    # node 3 steps back by 58 ms: its ticks come 2 ms after node 2's, before node 2's estimate arrives
    # (5 ms processing + 4.2 ms airtime), so it uses each estimate one tick later
    r, m = run(**{"faults.clock_step": [{"node": 3, "at_s": 100.0, "step_s": -0.058}]})
    t = r.nodes[2].t_s
    assert np.all(np.diff(t) > 0)
    assert np.all(m["node3_mean_update_age_s"] > ok["node3_mean_update_age_s"] + 0.2)
    assert np.all(m["node2_mean_update_age_s"] == ok["node2_mean_update_age_s"])


def test_a_step_back_by_whole_ticks_repeats_no_tick():
    # a step of exactly -2 ticks lands the stepped ticks on earlier ones: each time is kept once, in order
    t = faults.stepped_ticks(Scenario().with_overrides(**{**BASE, "faults.clock_step": [
        {"node": 2, "at_s": 2.0, "step_s": -1.0}]}), 2, np.arange(10) * 0.5, 10.0)
    assert t.tolist() == [0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5]


def test_a_step_back_of_19_ticks_completes_with_finite_estimates():
    # 10 s = 19 ticks at 1.9 Hz: before the fix the repeated tick times gave a zero-length gyro average (NaN)
    r, m = run(**{"faults.clock_step": [{"node": 2, "at_s": 100.0, "step_s": -10.0}]})
    assert np.all(np.diff(r.nodes[1].t_s) > 0)
    for node in r.nodes:
        assert np.isfinite(node.yaw_est_rad).all()
    assert np.isfinite(m["node4_rms_yaw_error_deg"]).all()


def test_a_node_without_a_tick_in_the_run_is_a_clear_error():
    with pytest.raises(NodesimError, match=r"node 2 has no firmware tick inside the run \[0, 5.0 s\].*\(0.0, 10.0\)"):
        run(**{"simulation.duration_s": 5.0, "metrics.window_start_s": 0.0, "metrics.window_end_s": 5.0,
               "faults.clock_step": [{"node": 2, "at_s": 0.0, "step_s": 10.0}]})


def test_fault_keys_are_checked_against_the_chain():
    with pytest.raises(ScenarioError, match=r"faults.node_failure\[0\].node = 9: allowed 1..4"):
        Scenario().with_overrides(**{**BASE, "faults.node_failure": [{"node": 9, "at_s": 1.0}]})
    with pytest.raises(ScenarioError, match="end_s"):
        Scenario().with_overrides(**{**BASE, "faults.link_outage": [{"hop": 1, "start_s": 5.0, "end_s": 5.0}]})
    with pytest.raises(ScenarioError, match=r"radio.hop\[0\].hop = 5"):
        Scenario().with_overrides(**{**BASE, "radio.hop": [{"hop": 5, "kind": "pipe"}]})
