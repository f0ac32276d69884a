"""The compiled chain engine gives the SimPy engine's numbers, bit for bit, feature by feature (issue 7).

Each case runs one scenario on both engines (``simulation.engine = "event"`` and ``"compiled"``) and compares
every per-node record (estimates, variances, biases, references, update masks and ages, surveys resolved from
them, stale/duplicate counts, fixed-point overflow counts), every link's statistics, the radio energy, the lost
packets and the event count.  Several realizations run at once in each case, so lanes that differ (one lost a
frame, the other did not) are covered too."""

import dataclasses
import warnings

import numpy as np
import pytest

from nodesim.chain.network import simulate_chain
from nodesim.chain.compiled import engine
from nodesim.chain.compiled.engine import choose_engine
from nodesim.errors import NodesimError
from nodesim.scenario.schema import Scenario

warnings.filterwarnings("ignore", message="First-class function type feature is experimental")

BASE = {  # 4 soil hops with the ARQ MAC (the fault tests' chain), lab rotation from 50 s
    "chain.nodes": 4, "simulation.duration_s": 160.0, "simulation.realizations": 3,
    "metrics.window_start_s": 60.0, "metrics.window_end_s": 160.0,
    "radio.model": "channel", "radio.shadowing_sigma_db": 0.0, "radio.soil.distance_m": 0.5, "mac.enabled": True,
}
LOSSY = {**BASE, "radio.soil.distance_m": 2.0, "radio.soil.vwc": 0.275}  # PER ~0.12 per frame: retries, losses

CASES = {
    "healthy soil hops": BASE,
    "lossy hops with ARQ": LOSSY,
    "lossy, shadowing, 5 nodes": {**LOSSY, "chain.nodes": 5, "radio.shadowing_sigma_db": 4.0},
    "dead node, fallback": {**BASE, "faults.node_failure": [{"node": 2, "at_s": 100.0}]},
    "dead node, no reachable skip": {**BASE, "radio.soil.distance_m": 1.5,
                                     "faults.node_failure": [{"node": 2, "at_s": 100.0}]},
    "60 s outage": {**BASE, "faults.link_outage": [{"hop": 2, "start_s": 70.0, "end_s": 130.0}]},
    "burst loss": {**BASE, "faults.burst": [{"hop": 3, "p_good_to_bad": 0.1, "p_bad_to_good": 0.3}]},
    "burst loss, no MAC": {**BASE, "mac.enabled": False, "faults.burst": [{"hop": 3}]},
    "clock step": {**BASE, "faults.clock_step": [{"node": 3, "at_s": 100.0, "step_s": -0.058}]},
    "simple links with loss": {"chain.nodes": 3, "simulation.duration_s": 160.0, "simulation.realizations": 3,
                               "metrics.window_start_s": 60.0, "metrics.window_end_s": 160.0,
                               "chain.link_loss_probability": 0.3},
    "every tick, extrapolated rate": {**LOSSY, "chain.forward": "every_tick", "chain.rate_compensation": "extrapolated"},
    "windowed schedule, short max age": {**LOSSY, "schedule.mode": "windowed", "schedule.update_s": 20.0,
                                         "schedule.timeout_s": 10.0, "chain.max_update_age_s": 0.3},
    "single updates": {**BASE, "schedule.mode": "single", "schedule.single_rate_hz": 0.2},
    "equal clocks (tied event times)": {**LOSSY, "chain.clock_stagger_s": 0.0},
    "drifting clocks": {**LOSSY, "chain.clock_drift_ppm": 300.0, "chain.clock_stagger_s": 0.31},
    "duty cycle and a one-frame queue": {**LOSSY, "mac.duty_cycle": 0.01, "mac.queue_length": 1},
    "rising soil water": {**LOSSY, "radio.soil.vwc_profile": [[0.0, 0.2], [160.0, 0.34]],
                          "radio.profile_step_s": 5.0},
    # the sender's queue drops frames while it falls back (a dropped frame neither counts nor goes over the skip
    # hop; both engines once sent it there with a NaN ready time)
    "outage, long ACK timeout, fallback": {**BASE, "mac.ack_timeout_s": 1.0,
                                           "faults.link_outage": [{"hop": 3, "start_s": 70.0, "end_s": 130.0}]},
    "dead node, one-frame queue, fallback": {**BASE, "mac.ack_timeout_s": 0.2, "mac.queue_length": 1,
                                             "faults.node_failure": [{"node": 3, "at_s": 100.0}]},
    "dead node, duty cycle, fallback": {**BASE, "mac.duty_cycle": 0.01, "mac.queue_length": 2,
                                        "faults.node_failure": [{"node": 3, "at_s": 100.0}]},
    "step back by 19 whole ticks": {**LOSSY, "faults.clock_step": [{"node": 2, "at_s": 100.0, "step_s": -10.0}]},
}

# drilling (tube insertions, holds, the top node changing, survey stops, surveys hop by hop up to the ground
# station): 4 tubes, 60 s per tube drilled, 30 s stops, 30 s insertions (programme 60 + 4 x 90 + 3 x 30 = 510 s)
DRILL = {"motion.kind": "drilling", "chain.nodes": 4, "simulation.duration_s": 520.0, "simulation.realizations": 3,
         "metrics.window_start_s": 0.0, "metrics.window_end_s": 520.0, "motion.rate_of_penetration_m_s": 2.0 / 60.0,
         "motion.survey_stop_s": 30.0, "motion.survey_settle_s": 15.0, "motion.insertion_s": 30.0,
         "motion.wellpath": [[0.0, 2.0, 120.0], [10.0, 6.0, 135.0]]}
DRILL_LOSSY = {**DRILL, **{k: v for k, v in LOSSY.items() if k.startswith(("radio.", "mac."))}}
CASES.update({
    "drilling, simple links": DRILL,
    "drilling, lossy hops with ARQ": DRILL_LOSSY,
    "drilling, lossy, every tick, extrapolated": {**DRILL_LOSSY, "chain.forward": "every_tick",
                                                  "chain.rate_compensation": "extrapolated"},
    "drilling, pipe hops": {**DRILL_LOSSY, "radio.kind": "pipe"},
    "drilling, windowed schedule": {**DRILL_LOSSY, "schedule.mode": "windowed", "schedule.update_s": 20.0,
                                    "schedule.timeout_s": 10.0},
    "drilling, no updates": {**DRILL_LOSSY, "schedule.mode": "none"},
    "drilling, dead node on the survey path": {**DRILL, "faults.node_failure": [{"node": 3, "at_s": 400.0}]},
    "drilling, up-hop outage": {**DRILL_LOSSY, "faults.link_outage": [{"hop": 3, "start_s": 200.0, "end_s": 330.0}]},
    "drilling, per-node clocks": {**DRILL_LOSSY, "chain.node": [{"id": 2, "clock_offset_s": 0.3, "clock_drift_ppm": 200.0},
                                                                {"id": 4, "clock_drift_ppm": -150.0}]},
    "drilling, dead node, surveys over the skip hop": {**DRILL, **{k: v for k, v in BASE.items() if k.startswith(
        ("radio.", "mac."))}, "faults.node_failure": [{"node": 3, "at_s": 400.0}]},
    "drilling, every node surveys, 2 tubes in the hole": {**DRILL_LOSSY, "motion.survey_nodes": "all",
                                                          "motion.initial_tubes": 2, "simulation.duration_s": 430.0,
                                                          "metrics.window_end_s": 430.0},
    "pipe hops": {**LOSSY, "radio.kind": "pipe"},
    "no updates": {**BASE, "schedule.mode": "none"},
    "arbitrary schedule": {**LOSSY, "schedule.mode": "arbitrary",
                           "schedule.windows": [[55.0, 90.0, 1.9], [100.0, 140.0, 0.3]]},
    "per-node clocks": {**LOSSY, "chain.node": [{"id": 2, "clock_offset_s": 0.4, "clock_drift_ppm": 250.0},
                                                {"id": 3, "clock_offset_s": 0.0}]},
})


UNDETECTED = {**LOSSY, "filter.implementation": "fixed", "mac.bit_errors": True, "mac.preamble_bits": 0,
              "mac.max_retries": 20, "radio.soil.distance_m": 2.3, "simulation.realizations": 10, "seed": 4}

FIXED = {  # the bit-exact fixed-point filter (its overflow counting is checked lane by lane in test_fixed_kernel.py)
    "fixed, lossy hops": {**LOSSY, "filter.implementation": "fixed"},
    "fixed, dead node and fallback": {**CASES["dead node, fallback"], "filter.implementation": "fixed"},
    "fixed, every tick, extrapolated": {**CASES["every tick, extrapolated rate"], "filter.implementation": "fixed"},
    "fixed, 16-bit word": {**LOSSY, "filter.implementation": "fixed", "filter.fixed_word_bits": 16},
    "fixed, MPU6500 count model": {**LOSSY, "filter.implementation": "fixed", "sensor.model": "mpu6500_counts"},
    # mac.bit_errors: CRC rejections and ARQ retries; then a hop so bad (BER 0.27, no preamble, 21 tries) that the
    # only estimate taken below the top node is a corruption the CRC-16 let through (seed 4: one, on hop 2)
    "fixed, bit errors": {**LOSSY, "filter.implementation": "fixed", "mac.bit_errors": True},
    "fixed, bit errors, dead node and fallback": {**CASES["dead node, fallback"], "filter.implementation": "fixed",
                                                  "mac.bit_errors": True, "radio.soil.distance_m": 1.1,
                                                  "faults.fallback_min_margin_db": -20.0},
    "fixed, bit errors, undetected corruption used": UNDETECTED,
    "fixed, drilling, lossy hops": {**DRILL_LOSSY, "filter.implementation": "fixed"},
    "fixed, drilling, every tick, dead node": {**DRILL_LOSSY, "filter.implementation": "fixed",
                                               "chain.forward": "every_tick",
                                               "faults.node_failure": [{"node": 3, "at_s": 400.0}]},
    "fixed, drilling, arbitrary schedule, per-node clocks": {
        **DRILL_LOSSY, "filter.implementation": "fixed", "schedule.mode": "arbitrary",
        "schedule.windows": [[60.0, 250.0, 1.9], [250.0, 520.0, 0.5]],
        "chain.node": [{"id": 1, "clock_offset_s": 0.2, "clock_drift_ppm": 300.0}]},
}


def _both(over: dict):
    s = Scenario().with_overrides(**over)
    return (simulate_chain(s.with_overrides(**{"simulation.engine": "event"})),
            simulate_chain(s.with_overrides(**{"simulation.engine": "compiled"})))


def _same(a, b, where: str) -> None:
    if isinstance(a, np.ndarray):
        assert a.shape == b.shape and np.array_equal(a, b, equal_nan=a.dtype.kind == "f"), where
    else:
        assert a == b, where


def assert_identical(event, compiled) -> None:
    assert event.simpy_events == compiled.simpy_events
    _same(event.lost_packets, compiled.lost_packets, "lost packets")
    _same(event.radio_energy_j, compiled.radio_energy_j, "radio energy")
    for na, nb in zip(event.nodes, compiled.nodes, strict=True):
        # every record (the SI sensor readings: properties over ``readings``, converted when read)
        names = [f.name for f in dataclasses.fields(na) if f.name != "readings"] + ["gyro_rad_s", "specific_force"]
        for name in names:
            _same(getattr(na, name), getattr(nb, name), f"node {na.node_id} {name}")
    pairs = list(zip(event.down_links + event.up_links, compiled.down_links + compiled.up_links, strict=True))
    assert [x.channel.name for x in event.skip_links] == [x.channel.name for x in compiled.skip_links]
    for la, lb in pairs + list(zip(event.skip_links, compiled.skip_links)):
        for f in ("frames", "delivered", "attempts", "dropped", "latency_sum_s", "crc_rejected", "undetected"):
            _same(getattr(la.stats, f), getattr(lb.stats, f), f"{la.channel.name} {f}")
    assert len(event.surveys) == len(compiled.surveys)
    for i, (ga, gb) in enumerate(zip(event.surveys, compiled.surveys)):
        for f in dataclasses.fields(ga.packet):
            _same(getattr(ga.packet, f.name), getattr(gb.packet, f.name), f"survey {i} {f.name}")
        _same(ga.arrival_s, gb.arrival_s, f"survey {i} arrival")
        assert (ga.frame is None) == (gb.frame is None), f"survey {i} frame"
        if ga.frame is not None:
            _same(ga.frame, gb.frame, f"survey {i} frame")


@pytest.mark.parametrize("name", list(CASES) + list(FIXED))
def test_compiled_engine_matches_the_event_engine(name):
    event, compiled = _both({**CASES, **FIXED}[name])
    assert_identical(event, compiled)
    if "no updates" in name:  # the filters coast: predictions only
        assert all(n.running.any() for n in compiled.nodes) and not any(n.update_mask.any() for n in compiled.nodes)
    else:
        assert any(n.update_mask.any() for n in compiled.nodes)  # the run did something worth comparing


def test_lossy_case_exercises_retries_losses_and_lane_differences():
    _, run = _both(LOSSY)
    link = run.down_links[2]
    assert (link.stats.attempts > link.stats.frames).all() and run.lost_packets.sum() > 0
    assert not np.array_equal(run.nodes[3].update_mask[0], run.nodes[3].update_mask[1])


def test_bit_error_cases_exercise_rejections_and_an_undetected_corruption():
    event, _ = _both(FIXED["fixed, bit errors"])
    assert all(x.stats.crc_rejected.sum() > 20 for x in event.down_links[1:])
    event, _ = _both(FIXED["fixed, bit errors, dead node and fallback"])
    assert sum(x.stats.crc_rejected.sum() for x in event.skip_links) > 0
    event, _ = _both(UNDETECTED)
    assert sum(x.stats.undetected.sum() for x in event.down_links) >= 1
    assert sum(n.update_mask.sum() for n in event.nodes[1:]) >= 1  # and it was used


def test_fallback_and_queue_cases_exercise_their_paths():
    _, run = _both(CASES["dead node, fallback"])
    assert run.skip_links and (run.skip_links[0].stats.frames > 100).all()
    _, run = _both(CASES["duty cycle and a one-frame queue"])
    assert sum(int(x.stats.dropped.sum()) for x in run.down_links) > 0


@pytest.mark.parametrize("name, node", [("outage, long ACK timeout, fallback", 3),
                                        ("dead node, one-frame queue, fallback", 4)])
def test_a_queue_drop_during_fallback_does_not_silence_the_sender(name, node):
    """A frame the sender's queue dropped once went on over the skip hop with a NaN ready time, which made the
    SimPy engine's radio free time NaN: no frame of that node got through again.  Now the node below (the outage
    over) or the one after the dead node (over the skip hop) keeps getting updates to the end."""
    for run in _both(CASES[name]):
        assert sum(int(x.stats.dropped.sum()) for x in run.down_links + run.skip_links) > 0  # the path is exercised
        late = run.nodes[node - 1].update_mask[:, run.nodes[node - 1].t_s > 140.0]
        assert late.sum(axis=1).min() >= 10


@pytest.mark.parametrize("name", ["dead node, fallback", "drilling, lossy hops with ARQ"])
def test_phase_1_in_small_chunks_and_after_a_restart_gives_the_same_run(monkeypatch, name):
    """Phase 1 takes the events in chunks (each run in every realization, the lanes' states kept between them) and
    starts again from scratch when an inbox fills (here: said to have filled once the events were half done):
    neither changes a record."""
    over = {**CASES[name], "simulation.engine": "compiled"}
    whole = simulate_chain(Scenario().with_overrides(**over))
    run_events, calls = engine.ev.run_events, []

    def full_once(T, chunk, e_first, *rest):
        status = run_events(T, chunk, e_first, *rest)
        calls.append(e_first)
        return engine.ev.INBOX_FULL if len(calls) == 40 else status

    monkeypatch.setattr(engine.ev, "CHUNK_EVENTS", 7)  # many chunks, odd sized
    monkeypatch.setattr(engine.ev, "run_events", full_once)
    assert_identical(whole, simulate_chain(Scenario().with_overrides(**over)))
    assert calls.count(0) == 2  # it did start again


def test_drilling_cases_exercise_insertions_holds_and_surveys():
    """The drilling cases do what they are named for: nodes hold, the top node changes, every stop's survey is
    sent, the lossy ones lose some on the way up, and a node dead on the survey path loses what crosses it."""
    _, run = _both(DRILL_LOSSY)
    assert [g.packet.station for g in run.surveys] == [1, 2, 3, 4]
    assert all(g.packet.node_id == 4 for g in run.surveys)
    assert sum(int(x.stats.attempts.sum() - x.stats.frames.sum()) for x in run.up_links) > 0  # retries going up
    assert not all(n.running[n.t_s >= n.present_from_s].all() for n in run.nodes)  # holds
    for node, tl in zip(run.nodes, run.motion.timelines):  # each node was the encoder-aided top node in its time
        assert node.update_mask[:, node.t_s < tl.top_until_s].sum(axis=1).min() > 10
        top = node.running & (node.t_s < tl.top_until_s)  # over hop 1, the lossless cable, whichever node is on top
        assert node.update_mask[:, top].all()
    assert (run.down_links[0].stats.frames > 2 * run.nodes[0].running.sum()).all()
    arrived = np.sum([np.isfinite(g.arrival_s) for g in run.surveys], axis=0)  # every survey's last hop is hop 1
    assert np.array_equal(run.up_links[0].stats.delivered, arrived) and arrived.min() >= 1
    _, run = _both(CASES["drilling, dead node on the survey path"])  # simple links: no fallback
    assert np.isnan(run.surveys[-1].arrival_s).all() and np.isfinite(run.surveys[0].arrival_s).all()


def test_surveys_pass_a_dead_node_over_the_skip_hop():
    """Node 3 dies at 400 s; the bottom node's last survey goes 4 -> (3 silent) -> skip hop -> 2 -> 1 -> ground on
    both engines, where without the fallback it is lost at node 3."""
    over = CASES["drilling, dead node, surveys over the skip hop"]
    for run in _both(over):
        last = run.surveys[-1]
        assert last.packet.t_s > 400.0 and np.isfinite(last.arrival_s).all()
        skip = [x for x in run.skip_links if x.channel.name == "skip4-2"]
        assert skip and (skip[0].stats.delivered >= 1).all()
    run = simulate_chain(Scenario().with_overrides(**{**over, "faults.fallback": False}))
    assert np.isnan(run.surveys[-1].arrival_s).all() and np.isfinite(run.surveys[0].arrival_s).all()


def test_a_node_not_yet_inserted_does_not_tick():
    """Its first tick is the first at or after its insertion (it costs no event before); it has no records there."""
    for run in _both(DRILL):
        for node in run.nodes:
            assert node.t_s[0] >= node.present_from_s and node.t_s[0] - node.present_from_s < 1.0 / 1.9
        assert run.nodes[0].t_s.size < run.nodes[-1].t_s.size / 2


def test_auto_picks_the_compiled_engine_for_lab_and_drilling():
    assert choose_engine(Scenario()) == "compiled"
    drilling = Scenario().with_overrides(**{"motion.kind": "drilling", "chain.nodes": 2})
    assert choose_engine(drilling) == "compiled"
    bits = drilling.with_overrides(**{"radio.model": "channel", "filter.implementation": "fixed", "mac.bit_errors": True})
    assert choose_engine(bits) == "event"
    with pytest.raises(NodesimError, match="simulation.engine = 'compiled'.*bit_errors.*drilling"):
        choose_engine(bits.with_overrides(**{"simulation.engine": "compiled"}))


SIX_STATE = {  # the float 6-state filter (issue 24): lab spin at 2 and 45 deg, drilling with a build section
    "6-state, lossy hops": {**LOSSY, "filter.states": 6},
    "6-state, 45 deg, every tick, extrapolated": {**CASES["every tick, extrapolated rate"], "filter.states": 6,
                                                 "motion.inclination_deg": 45.0},
    "6-state, 89 deg, decouple, euler": {**BASE, "filter.states": 6, "motion.inclination_deg": 89.0,
                                        "filter.singularity": "decouple", "filter.discretisation": "euler"},
    "6-state, dead node, fallback": {**CASES["dead node, fallback"], "filter.states": 6},
    "6-state, drilling, lossy hops": {**DRILL_LOSSY, "filter.states": 6},
    "6-state, drilling, windowed, per-node clocks": {**CASES["drilling, per-node clocks"], "filter.states": 6,
                                                    "schedule.mode": "windowed", "schedule.update_s": 20.0,
                                                    "schedule.timeout_s": 10.0},
}
FIXED6 = {"filter.states": 6, "filter.implementation": "fixed"}
SIX_STATE.update({  # the fixed-point 6-state node firmware (firmware_model.six_state_firmware)
    "fixed 6-state, 2 deg, lossy hops": {**LOSSY, **FIXED6},
    "fixed 6-state, 45 deg, every tick, extrapolated": {**CASES["every tick, extrapolated rate"], **FIXED6,
                                                        "motion.inclination_deg": 45.0},
    "fixed 6-state, dead node, fallback": {**CASES["dead node, fallback"], **FIXED6},
    "fixed 6-state, drilling, lossy hops": {**DRILL_LOSSY, **FIXED6},
    "fixed 6-state, drilling, levelling off": {**DRILL_LOSSY, **FIXED6, "filter.levelling": "off"},
    "fixed 6-state, 89 deg, decouple": {**BASE, **FIXED6, "motion.inclination_deg": 89.0,
                                        "filter.singularity": "decouple"},
})


@pytest.mark.parametrize("name", list(SIX_STATE))
def test_compiled_engine_matches_the_event_engine_with_six_states(name):
    event, compiled = _both(SIX_STATE[name])
    assert_identical(event, compiled)
    assert any(n.update_mask.any() for n in compiled.nodes)
    assert all(n.singular_ticks is not None for n in compiled.nodes if n.running.any())
    if "89 deg" in name:
        assert sum(int(n.singular_ticks.sum()) for n in compiled.nodes) > 0  # the singular path was compared too


@pytest.mark.parametrize("name", ["6-state, drilling, lossy hops", "fixed 6-state, drilling, lossy hops"])
def test_six_state_runs_are_deterministic(name):
    s = Scenario().with_overrides(**SIX_STATE[name])
    assert_identical(simulate_chain(s), simulate_chain(s))


def _in_windows(ticks: int, width: int):
    return [(k0, min(k0 + width, ticks)) for k0 in range(0, ticks, width)]


def _contiguous(a, k0, k1):
    return np.ascontiguousarray(a[k0:k1] if a.ndim == 1 else a[:, k0:k1])


FIRMWARE_TICK_ARGS = (4, 5, 6, 7, 8, 11, 12, 13, 14, 15, 16, 18, 19, 22, 23, 24, 25, 26, 27, 28, 29, 30)
""":func:`filters.run_node_firmware`'s per-tick arrays (by position); its outputs from 22 on."""


@pytest.mark.parametrize("name", ["fixed, drilling, every tick, dead node",
                                  "fixed, drilling, arbitrary schedule, per-node clocks"])
def test_the_firmware_passes_in_windows_of_ticks_give_the_same_run(monkeypatch, name):
    """Phase 2's firmware loop, frame decoding and frame encoding take a window of a node's ticks (lanes carried,
    the senders' frames from a later tick on, the frames' seq from the window's first tick): run in windows of 23
    ticks, and with each sender's frames cut before the first one taken, every record is the same as in one pass."""
    over = {**FIXED[name], "simulation.engine": "compiled"}
    whole = simulate_chain(Scenario().with_overrides(**over))
    firmware, receive, send = (engine.filters.run_node_firmware, engine.frame_pass.receive_frames,
                               engine.frame_pass.send_frames)
    calls = {"firmware": 0, "receive": 0, "send": 0}

    def firmware_windows(*args):
        k_end = args[9]
        for k0, k1 in _in_windows(k_end, 23) or [(0, 0)]:
            a = [_contiguous(x, k0, k1) if i in FIRMWARE_TICK_ARGS else x for i, x in enumerate(args)]
            a[9], a[10] = k1 - k0, k0 == 0
            firmware(*a)
            for i in FIRMWARE_TICK_ARGS[13:]:
                args[i][:, k0:k1] = a[i]
            calls["firmware"] += 1

    def receive_from_first_taken(src_node, src_tick, k_first, k_end, up_frames, up_first, *rest):
        taken = [src_tick[src_node == s] for s in (1, 2)]
        first = np.array([int(j.min()) if j.size else 0 for j in taken], np.int64)
        cut = tuple(np.ascontiguousarray(f[:, j:]) for f, j in zip(up_frames, first))
        receive(src_node, src_tick, k_first, k_end, cut, first, *rest)
        calls["receive"] += int(first.any())

    def send_windows(node_id, first_tick, every, running, k_first, k_end, k_base, applied, t, *rest):
        *words, frames, scratch, r0, r1 = rest
        worst = 0
        for w0, w1 in _in_windows(t.size, 23):
            lo, hi = max(k_first, w0), min(k_end, w1)
            if lo >= hi:
                continue
            out = _contiguous(frames, w0, w1)
            worst = min(worst, send(node_id, first_tick, every, running[w0:w1].copy(), lo - w0, hi - w0, w0,
                                    _contiguous(applied, w0, w1), t[w0:w1].copy(),
                                    *(_contiguous(x, w0, w1) for x in words), out, scratch, r0, r1))
            frames[:, w0:w1] = out
            calls["send"] += 1
        return worst

    monkeypatch.setattr(engine.filters, "run_node_firmware", firmware_windows)
    monkeypatch.setattr(engine.frame_pass, "receive_frames", receive_from_first_taken)
    monkeypatch.setattr(engine.frame_pass, "send_frames", send_windows)
    assert_identical(whole, simulate_chain(Scenario().with_overrides(**over)))
    assert calls["firmware"] > 40 and calls["receive"] > 0 and calls["send"] > 10
