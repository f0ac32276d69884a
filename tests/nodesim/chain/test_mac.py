"""MAC (stop-and-wait ARQ, airtime, half duplex, duty cycle, queue, energy), hop channels from the channel
models, and batched Monte Carlo: R realizations in one run equal the same realizations run one at a time."""

import math

import numpy as np
import pytest

from nodesim.chain.network import simulate_chain
from nodesim.chain.links import LossDraws
from nodesim.chain.mac import Link, RadioState, radio_energy_j
from nodesim.chain.metrics import per_realization_metrics
from nodesim.chain.radio import hop_channels, simple_channel
from nodesim.rng.streams import RunStreams
from nodesim.scenario.schema import Scenario


def _link(p_loss: float, R: int, **mac) -> tuple[Link, Scenario]:
    s = Scenario().with_overrides(**{"chain.link_loss_probability": p_loss, "mac.enabled": True,
                                     **{f"mac.{k}": v for k, v in mac.items()}})
    streams = RunStreams(seed=5, n_nodes=1)
    return Link(simple_channel(s, "h", R), LossDraws([streams.link(r, 0) for r in range(R)]), s.mac), s


def test_arq_delivers_unless_every_attempt_fails_and_counts_attempts():
    R, p = 4000, 0.5
    link, s = _link(p, R, max_retries=3)
    tr = link.transfer(0.0, np.ones(R, dtype=bool), RadioState(R, 4), RadioState(R, 4))
    assert abs(tr.delivered.mean() - (1 - p**4)) < 0.015  # 1 - p^(retries + 1); sigma ~0.004
    # attempts: geometric, truncated at 4: E = sum_{k<4} p^k
    assert abs(link.stats.attempts.mean() - sum(p**k for k in range(4))) < 0.05
    # a frame acknowledged at attempt k arrived at start + (k-1) (T + timeout) + T
    T, to = s.chain.link_delay_s, s.mac.ack_timeout_s
    k = np.round((tr.arrival_s[tr.delivered] - T) / (T + to))
    assert np.allclose(tr.arrival_s[tr.delivered], k * (T + to) + T)


def test_half_duplex_receiver_busy_loses_the_frame_and_duty_cycle_spaces_frames():
    R = 3
    link, s = _link(0.0, R, max_retries=0)
    rx = RadioState(R, 4)
    rx.busy_start[:] = [0.0, 0.0, 5.0]
    rx.busy_end[:] = [1.0, 1.0, 6.0]
    tr = link.transfer(0.5, np.ones(R, dtype=bool), RadioState(R, 4), rx)
    assert tr.delivered.tolist() == [False, False, True]
    link, s = _link(0.0, 1, duty_cycle=0.01, queue_length=2)
    tx = RadioState(1, 2)
    ends = [link.transfer(0.0, np.ones(1, dtype=bool), tx, None) for _ in range(3)]
    T = s.chain.link_delay_s
    # the second frame waits for the 1 % duty-cycle off time T / 0.01 of the first; the third finds the queue full
    assert math.isclose(ends[1].arrival_s[0] - ends[0].arrival_s[0], T / 0.01)
    assert not ends[2].delivered[0] and link.stats.dropped[0] == 1


def test_radio_energy_is_supply_times_currents_times_airtime():
    R = 1
    link, s = _link(0.0, R, max_retries=0)
    tx, rx = RadioState(R, 4), RadioState(R, 4)
    link.transfer(0.0, np.ones(R, dtype=bool), tx, rx)
    m, T = s.mac, s.chain.link_delay_s
    assert math.isclose(radio_energy_j(tx, m)[0], m.supply_v * (m.tx_current_a * T + m.rx_current_a * (
        m.turnaround_s + T)))
    assert math.isclose(radio_energy_j(rx, m)[0], m.supply_v * (m.tx_current_a * T + m.rx_current_a * T))


def test_hop_channels_follow_the_channel_models():
    s = Scenario().with_overrides(**{"chain.nodes": 3, "radio.model": "channel", "radio.shadowing_sigma_db": 0.0,
                                     "radio.soil.distance_m": 2.0, "radio.hop": [{"hop": 3, "kind": "pipe"}]})
    hops, skips = hop_channels(s, RunStreams(0, 3), 1)
    assert [h.kind for h in hops] == ["cable", "soil", "pipe"]
    assert hops[0].mean_path_loss_db == 20.0
    # soil at 2 m, vwc 0.2: 104.1 dB (as `nodesim link soil --distance 2`), margin 2 + 110 - 104.1
    assert abs(hops[1].mean_path_loss_db - 104.1) < 0.1 and abs(hops[1].mean_margin_db - 7.9) < 0.1
    assert hops[2].mean_path_loss_db < 1.0  # 3 m of air-filled pipe at 5 GHz
    assert skips[1] is not None  # node 1 -> node 3 over soil + pipe: the summed losses
    assert math.isclose(skips[1].mean_path_loss_db, hops[1].mean_path_loss_db + hops[2].mean_path_loss_db)
    # the estimate frame (27 bytes, firmware_model.frames) + the CC1101 preamble, sync word and length byte (56 bits)
    assert math.isclose(hops[1].airtime_s, (56 + 8 * 27) / 38400)
    short = s.with_overrides(**{"mac.preamble_bits": 0})
    h0, _ = hop_channels(short, RunStreams(0, 3), 1)
    assert math.isclose(h0[1].airtime_s, 8 * 27 / 38400)
    assert (h0[1].per_data_table < hops[1].per_data_table).all()  # fewer bits on air, fewer errors


def test_frame_bits_is_gone_with_a_message_naming_preamble_bits():
    from nodesim.errors import ScenarioError

    with pytest.raises(ScenarioError, match=r"mac.frame_bits is gone.*27 bytes.*preamble_bits"):
        Scenario().with_overrides(**{"mac.frame_bits": 160})
    assert Scenario().mac.data_frame_bits == 56 + 8 * 27


def test_soil_water_raises_per_and_shadowing_spreads_margins():
    wet = Scenario().with_overrides(**{"chain.nodes": 2, "radio.model": "channel", "radio.soil.distance_m": 2.0,
                                       "radio.soil.vwc_profile": [[0.0, 0.1], [600.0, 0.4]]})
    hops, _ = hop_channels(wet, RunStreams(0, 2), 50)
    per = hops[1].per_data_table  # (time steps, realizations)
    assert np.all(np.diff(per.mean(axis=1)) >= 0) and per[0].mean() < 0.01 and per[-1].mean() > 0.95
    assert 2.0 < hops[1].margin_db[0].std() < 6.0  # 4 dB log-normal shadowing over 50 realizations


BATCH = {
    "chain.nodes": 3, "simulation.duration_s": 120.0, "metrics.window_start_s": 60.0,
    "metrics.window_end_s": 120.0, "radio.model": "channel", "radio.soil.distance_m": 2.0, "mac.enabled": True,
    "faults.burst": [{"hop": 3, "p_good_to_bad": 0.2, "p_bad_to_good": 0.3}], "seed": 77,
}


def test_batched_realizations_equal_the_same_realizations_run_one_at_a_time():
    """Realization r of a run = SeedSequence(seed) child first_realization + r: R = 3 in one batched run gives,
    per realization, bit for bit what first_realization = r, R = 1 gives."""
    batched_s = Scenario().with_overrides(**{**BATCH, "simulation.realizations": 3})
    batched = simulate_chain(batched_s)
    mb = per_realization_metrics(batched, batched_s.metrics)
    assert batched.lost_packets.sum() > 0 and not np.array_equal(batched.nodes[2].update_mask[0],
                                                                batched.nodes[2].update_mask[1])
    for r in range(3):
        s = Scenario().with_overrides(**{**BATCH, "simulation.realizations": 1, "simulation.first_realization": r})
        one = simulate_chain(s)
        assert one.simpy_events == batched.simpy_events
        for a, b in zip(one.nodes, batched.nodes):
            assert np.array_equal(a.yaw_est_rad[0], b.yaw_est_rad[r], equal_nan=True)
            assert np.array_equal(a.update_mask[0], b.update_mask[r])
        m1 = per_realization_metrics(one, s.metrics)
        for key, v in m1.items():  # the states are bit-exact; numpy's SIMD loops over (1, K) and (3, K) arrays
            # may round the survey resolution (arctan2, moving averages) differently in the last ulp
            assert np.allclose(v[0], mb[key][r], rtol=1e-12, atol=0.0, equal_nan=True), key


def test_seed_mapping_rejects_bad_first_realization():
    from nodesim.errors import ScenarioError

    with pytest.raises(ScenarioError, match="first_realization"):
        Scenario().with_overrides(**{"simulation.first_realization": -1})


def test_radio_and_mac_keys_are_validated_with_their_path():
    from nodesim.errors import ScenarioError

    for key, value, where in (("radio.soil.vwc", 1.5, "radio.soil.vwc"), ("mac.duty_cycle", 0.0, "mac.duty_cycle"),
                              ("radio.kind", "air", "radio.kind"), ("mac.drop_policy", "random", "mac.drop_policy")):
        with pytest.raises(ScenarioError, match=where):
            Scenario().with_overrides(**{key: value})
    with pytest.raises(ScenarioError, match="vwc_profile"):
        Scenario().with_overrides(**{"radio.soil.vwc_profile": [[10.0, 0.2], [5.0, 0.3]]})


def test_perf_scenario_is_the_benchmark_chain():
    from importlib import resources

    from nodesim.scenario.schema import load_scenario

    with resources.as_file(resources.files("scenarios") / "perf" / "chain100_1h.toml") as p:
        s, _ = load_scenario(p)
    assert (s.chain.nodes, s.simulation.duration_s, s.filter.implementation) == (100, 3600.0, "fixed")
    assert s.radio.model == "channel" and s.radio.kind == "soil" and s.mac.enabled
    hops, _ = hop_channels(s, RunStreams(s.seed, s.chain.nodes), 1)
    assert 0.05 < hops[1].per_data_table[0, 0] < 0.3  # lossy soil hops


def test_the_link_what_if_default_frame_is_the_chain_data_frame():
    from nodesim.chain.link_whatif import DATA_FRAME_BITS
    from nodesim.scenario.radio_sections import MacSection

    assert DATA_FRAME_BITS == MacSection().data_frame_bits
