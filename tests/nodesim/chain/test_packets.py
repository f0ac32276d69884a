"""Reference selection from a node's inbox: newest fresh packet per realization; stale and duplicate
packets ignored and counted (thesis digest 2.6: sequence numbers and packet age); links and loss draws."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from nodesim.chain.links import LossDraws
from nodesim.chain.mac import Link
from nodesim.chain.radio import simple_channel
from nodesim.scenario.schema import Scenario
from nodesim.chain.packets import EstimatePacket, select_reference
from nodesim.rng.streams import RunStreams


def _pkt(seq, t_read, valid, yaw=None):
    valid = np.asarray(valid, dtype=bool)
    y = np.full(valid.shape, float(seq) if yaw is None else yaw)
    return EstimatePacket(1, seq, t_read, y, np.full(valid.shape, 0.01 * (seq + 1)), np.zeros(valid.shape), valid)


def test_newest_valid_packet_wins_per_realization():
    inbox = [_pkt(3, 10.0, [1, 1, 0]), _pkt(4, 10.5, [1, 0, 0])]
    sel = select_reference(inbox, np.array([-1, -1, -1]), 10.6, max_age_s=1.5)
    assert sel.have.tolist() == [True, True, False]
    assert sel.seq.tolist() == [4, 3, -1]
    assert sel.yaw_rad[:2].tolist() == [4.0, 3.0]
    assert np.isnan(sel.t_read_s[2])


def test_duplicates_and_stale_packets_are_ignored_and_counted():
    last = np.array([5, 2])
    inbox = [_pkt(5, 10.0, [1, 1])]  # realization 0 already used seq 5: duplicate; realization 1 has not
    sel = select_reference(inbox, last, 10.1, max_age_s=1.5)
    assert sel.have.tolist() == [False, True]
    assert sel.duplicate.tolist() == [1, 0]
    stale = select_reference([_pkt(6, 5.0, [1, 1])], last, 10.0, max_age_s=1.5)  # 5 s old
    assert not stale.have.any()
    assert stale.stale.tolist() == [1, 1]


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.tuples(st.integers(0, 20), st.floats(0.0, 5.0), st.lists(st.booleans(), min_size=4, max_size=4)),
             max_size=6, unique_by=lambda x: x[0]),
    st.lists(st.integers(-1, 20), min_size=4, max_size=4),
)
def test_selection_is_the_max_fresh_new_seq(packets, last):
    """Property: the chosen seq is the largest valid seq > last with age <= max age, else none."""
    t_use, max_age = 5.0, 2.0
    inbox = [_pkt(seq, t, valid) for seq, t, valid in packets]
    last = np.array(last)
    sel = select_reference(inbox, last, t_use, max_age)
    for r in range(4):
        ok = [seq for seq, t, valid in packets if valid[r] and seq > last[r] and t_use - t <= max_age]
        assert sel.seq[r] == (max(ok) if ok else -1)
        assert sel.have[r] == bool(ok)
        dups = sum(1 for seq, _, valid in packets if valid[r] and seq <= last[r])
        assert sel.duplicate[r] == dups


def test_loss_draws_do_not_depend_on_block_size():
    streams = RunStreams(seed=3, n_nodes=2)
    a = LossDraws([streams.link(r, 0) for r in range(3)], block=7)
    b = LossDraws([streams.link(r, 0) for r in range(3)], block=256)
    xa = np.stack([a.next_uniform() for _ in range(20)])
    xb = np.stack([b.next_uniform() for _ in range(20)])
    assert (xa == xb).all()


def test_simple_link_delays_and_loses_with_the_given_probability():
    """radio.model = "simple", mac.enabled = false: one attempt, link_delay_s, link_loss_probability."""
    streams = RunStreams(seed=9, n_nodes=1)
    s = Scenario().with_overrides(**{"chain.link_delay_s": 0.02, "chain.link_loss_probability": 0.3})
    link = Link(simple_channel(s, "l", 2000), LossDraws([streams.link(r, 0) for r in range(2000)]), s.mac)
    tr = link.transfer(1.0, np.ones(2000, dtype=bool), None, None)
    assert np.all(tr.arrival_s[tr.delivered] == 1.02)
    assert abs((~tr.delivered).mean() - 0.3) < 0.04  # 2000 Bernoulli draws: sigma ~ 0.01
    assert link.stats.lost.sum() == (~tr.delivered).sum()
    for prob, expect in ((0.0, True), (1.0, False)):
        s = Scenario().with_overrides(**{"chain.link_loss_probability": prob})
        link = Link(simple_channel(s, "l", 5), LossDraws([streams.link(r, 0) for r in range(5)]), s.mac)
        assert (link.transfer(0.0, np.ones(5, dtype=bool), None, None).delivered == expect).all()


def test_next_uniforms_equal_successive_single_draws_across_block_ends():
    streams = RunStreams(seed=4, n_nodes=1)
    a = LossDraws([streams.link(r, 0) for r in range(3)], block=5)
    b = LossDraws([streams.link(r, 0) for r in range(3)], block=5)
    masks = [np.array([1, 0, 1], bool), np.array([1, 1, 1], bool), np.array([0, 1, 1], bool)] * 4
    for m in masks:
        pair = a.next_uniforms(3, m)
        single = np.stack([b.next_uniform(m) for _ in range(3)], axis=1)
        assert np.array_equal(pair, single, equal_nan=True)


def test_the_receiver_decodes_the_estimate_frame_and_drops_a_corrupted_one():
    """Fixed firmware: the packet carries the 27-byte estimate frame; select_reference takes yaw and P_yy from the
    decoded bytes, and a frame whose CRC fails is not used (an older good frame is) and is counted."""
    from nodesim.chain.packets import estimate_frame

    R = 3
    yaw, var = np.array([-2**31, 5, 2**31 - 1]), np.array([1 << 24, 7, 0])
    old = estimate_frame(2, 10, 1_000_000, yaw - 1, var + 1, np.zeros(R), np.ones(R))
    new = estimate_frame(2, 11, 1_500_000, yaw, var, np.zeros(R), np.ones(R))
    assert new.shape == (R, 27) and new.dtype == np.uint8
    new[1, 9] ^= 0x10  # one bit of realization 1's yaw
    pkts = [EstimatePacket(2, s, t, np.zeros(R), np.zeros(R), np.zeros(R), np.ones(R, bool), frame=f)
            for s, t, f in ((10, 1.0, old), (11, 1.5, new))]
    sel = select_reference(pkts, np.full(R, -1), 2.0, 10.0)
    assert list(sel.seq) == [11, 10, 11]
    assert list(sel.yaw_raw) == [yaw[0], yaw[1] - 1, yaw[2]]
    assert list(sel.var_raw) == [var[0], var[1] + 1, var[2]]
    assert list(sel.crc_rejected) == [0, 1, 0]
