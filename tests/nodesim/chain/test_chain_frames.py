"""Estimate frames in the chain: both engines send the bytes of :mod:`firmware_model.frames` and the receivers
decode them (issue 19, item 3); the frames a node sent are part of its records."""

import numpy as np
import pytest

from firmware_model import frames as fr
from nodesim.chain.network import simulate_chain
from nodesim.scenario.schema import Scenario

LOSSY_FIXED = {
    "chain.nodes": 4, "simulation.duration_s": 160.0, "simulation.realizations": 3,
    "metrics.window_start_s": 60.0, "metrics.window_end_s": 160.0, "radio.model": "channel",
    "radio.shadowing_sigma_db": 0.0, "radio.soil.distance_m": 2.0, "radio.soil.vwc": 0.275, "mac.enabled": True,
    "filter.implementation": "fixed",
}


@pytest.mark.parametrize("engine", ["event", "compiled"])
def test_the_sent_frames_carry_the_senders_words_and_the_receivers_use_them(engine):
    run = simulate_chain(Scenario().with_overrides(**{**LOSSY_FIXED, "simulation.engine": engine}))
    for n in run.nodes[:-1]:
        f = n.estimate_frames
        sent = f[:, :, 0] == fr.ESTIMATE
        assert sent.sum() > 50 and not f[:, :, 0][~sent].any()
        values, ok = fr.decode(fr.ESTIMATE, f[sent])
        assert ok.all()
        r, k = np.nonzero(sent)
        assert (values[:, fr.field_index(fr.ESTIMATE, "node")] == n.node_id).all()
        assert (values[:, fr.field_index(fr.ESTIMATE, "seq")] == k).all()  # the sender's ticks since power-up (lab: from t = 0)
        assert (values[:, fr.field_index(fr.ESTIMATE, "t_read_us")] == np.rint(n.t_s[k] * 1e6)).all()
        assert np.array_equal(n.update_mask[sent], np.ones(sent.sum(), bool))  # sent where it applied an update
    assert not run.nodes[-1].estimate_frames.any()  # the bottom node sends none


def _drilling(tubes=2, **over):
    per_tube = 60.0 + 120.0 + 40.0
    return Scenario().with_overrides(**{
        "motion.kind": "drilling", "chain.nodes": tubes, "simulation.duration_s": tubes * per_tube,
        "metrics.window_start_s": 0.0, "metrics.window_end_s": tubes * per_tube, "simulation.realizations": 3,
        "filter.implementation": "fixed", "radio.model": "channel", "radio.shadowing_sigma_db": 0.0,
        "radio.soil.distance_m": 0.5, "mac.enabled": True, **over})


def test_surveys_go_up_as_survey_frames_and_the_ground_station_decodes_them():
    from nodesim.chain.packets import decode_survey, survey_sigmas_rad
    from nodesim.chain.run_tables import survey_columns
    from nodesim.units import rad_to_deg

    scenario = _drilling()
    run = simulate_chain(scenario)
    bits = scenario.mac.preamble_bits + 8 * fr.SURVEY_BYTES
    for up, hop in zip(run.up_links, run.hops):  # airtime and PER from the 25-byte survey frame
        assert up.channel.airtime_s == bits / scenario.radio.bit_rate_bps
        assert np.array_equal(up.channel.per_data_table, -np.expm1(bits * np.log1p(-hop.ber_table)))
    table = survey_columns(run)
    assert len(run.surveys) == 2
    for g in run.surveys:
        p, node = g.packet, run.nodes[g.packet.node_id - 1]
        assert g.frame.shape == (3, fr.SURVEY_BYTES)
        values, ok = fr.decode(fr.SURVEY, g.frame)
        assert ok.all() and (values[:, 0] == p.station).all() and (values[:, 1] == p.node_id).all()
        got = decode_survey(g.frame)
        sel = table["station"] == p.station
        # the words are the firmware's: the table's angles are the node's records, bit for bit
        assert np.array_equal(table["inclination_deg"][sel], rad_to_deg(node.inclination_rad[:, p.tick]))
        assert np.array_equal(table["azimuth_deg"][sel], rad_to_deg(node.azimuth_rad[:, p.tick]))
        sig_i, sig_a = survey_sigmas_rad(node.accel_sigma_m_s2, run.moving_average_points,
                                         node.true_inclination_rad[p.tick], node.yaw_var_rad2[:, p.tick])
        lsb = 2 * np.pi / 2**20
        assert np.all(np.abs(got["sigma_a_rad"] - sig_a) <= lsb / 2) and abs(got["sigma_i_rad"][0] - sig_i) <= lsb / 2


def test_survey_frames_get_bit_errors_rejected_and_retried():
    scenario = _drilling(**{"radio.soil.distance_m": 2.0, "radio.soil.vwc": 0.275, "mac.bit_errors": True,
                            "mac.max_retries": 8, "simulation.realizations": 8})
    run = simulate_chain(scenario)
    up = run.up_links
    assert sum(x.stats.crc_rejected.sum() for x in up) > 0
    for g in run.surveys:
        got = fr.decode(fr.SURVEY, g.frame)[1]
        assert got[g.packet.valid].all()  # what arrived passed its CRC at every hop


def test_a_frame_longer_than_the_radio_takes_is_refused():
    from nodesim.errors import NodesimError
    from nodesim.scenario.radio_sections import MacSection

    assert MacSection().frame_bits(fr.SURVEY_BYTES) == 56 + 200
    with pytest.raises(NodesimError, match="does not fit the MAC"):
        MacSection().frame_bits(256)


@pytest.mark.parametrize("every_tick", [False, True])
def test_a_run_in_windows_takes_the_words_the_bytes_would_carry(every_tick):
    """A run in windows makes no frame bytes (no bit errors there): the words its receivers take
    (frame_pass.receive_words) equal those decoded from the frames send_frames makes (frame_pass.receive_frames), and
    send_frames into no frame ticks (no bytes) gives its status with the bytes, also where a word does not fit its
    field, which check_sent names."""
    from nodesim.chain.compiled import frame_pass as fp
    from nodesim.errors import NodesimError

    rng = np.random.default_rng(11)
    R, K = 3, 400
    applied, running = rng.random((R, K)) < 0.5, rng.random(K) < 0.8
    t = np.arange(K) / 1.9 + 40_000.0  # past the 2^32 us the frame's timer wraps at
    yaw, var, rate, bias = (rng.integers(-2 ** 31, 2 ** 31, (R, K)) for _ in range(4))
    yaw[0, :50] += 2 ** 33  # a binary angle beyond 32 bits: the frame's wrap
    words = np.zeros((R, 7), np.int64)

    def statuses(var_raw):
        frames = np.zeros((R, K, fr.ESTIMATE_BYTES), np.uint8)
        sent = fp.send_frames(7, 3, every_tick, running, 5, K, 70_000, applied, t, yaw, var_raw, rate, bias, frames,
                              words, 0, R)
        return sent, fp.send_frames(7, 3, every_tick, running, 5, K, 70_000, applied, t, yaw, var_raw, rate, bias,
                                    np.zeros((R, 0, fr.ESTIMATE_BYTES), np.uint8), words, 0, R), frames

    sent, checked, frames = statuses(var)
    assert sent == checked == 0
    src = np.where(rng.random((R, K)) < 0.6, rng.integers(1, 3, (R, K)), 0).astype(np.int8)
    src[:, :5] = 0  # only ticks that sent a frame are taken
    taken = (applied | (every_tick & running)[None, :])
    src[~taken] = 0
    tick = np.tile(np.arange(K, dtype=np.int32), (R, 1))
    from_bytes = np.zeros((R, K), np.int64), np.zeros((R, K), np.int64)
    from_words = np.zeros((R, K), np.int64), np.zeros((R, K), np.int64)
    first = np.zeros(2, np.int64)
    fp.receive_frames(src, tick, 0, K, (frames, frames), first, *from_bytes, 0, R)
    fp.receive_words(src, tick, 0, K, (yaw, yaw), (var, var), first, *from_words, 0, R)
    assert (src > 0).sum() > 300 and (yaw[0, :50] != from_words[0][0, :50])[src[0, :50] > 0].all()
    assert np.array_equal(from_bytes[0], from_words[0]) and np.array_equal(from_bytes[1], from_words[1])
    too_wide = var.copy()
    too_wide[1, np.flatnonzero(taken[1])[-1]] = 2 ** 31  # P_yy is a signed 32-bit field that rejects
    sent, checked, _ = statuses(too_wide)
    assert sent == checked == -(1 + fr.EST_PYY)
    with pytest.raises(NodesimError, match="node 7: its P_yy word does not fit"):
        fp.check_sent(checked, 7)
