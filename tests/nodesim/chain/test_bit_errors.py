"""``mac.bit_errors``: bit errors drawn from the hop's BER, decoded by the receiver (nodesim.chain.bit_errors)."""

import numpy as np
import pytest
from scipy import stats

from channel import per
from firmware_model import frames as fr
from nodesim.chain import bit_errors as be
from nodesim.chain.links import LossDraws
from nodesim.chain.mac import Link
from nodesim.chain.network import simulate_chain
from nodesim.chain.radio import HopChannel
from nodesim.errors import NodesimError
from nodesim.rng.streams import RunStreams
from nodesim.scenario.radio_sections import MacSection
from nodesim.scenario.schema import Scenario

KINDS = [fr.ESTIMATE, fr.SURVEY]


def _channel(ber: float, R: int, preamble_bits: int, frame_bytes: int) -> HopChannel:
    bits = preamble_bits + 8 * frame_bytes
    table = np.full((1, R), ber)
    return HopChannel("h", "soil", 10.0, per.per_from_ber(table, bits), np.zeros((1, R)), np.zeros((1, R)), 0.0,
                      0.0, bits / 38400.0, 0.0, ber_table=table, per_preamble_table=per.per_from_ber(table, preamble_bits))


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("ber", [3e-4, 1e-3, 4e-3])
def test_the_measured_loss_per_try_is_the_per_of_the_frame(ber, kind):
    """One try per frame (no ARQ): lost = preamble error or a CRC rejection; over 60,000 tries the loss count is
    binomial with p = PER = 1 - (1 - BER)^(preamble + 8 x bytes) (two-sided exact test at 1e-4; the PER without
    the preamble's bits, 1 - (1 - BER)^(8 x bytes), is rejected at the two larger BERs)."""
    R, n = 600, 100
    mac = MacSection(enabled=False, bit_errors=True)
    ch = _channel(ber, R, mac.preamble_bits, fr.LENGTHS[kind])
    streams = RunStreams(seed=11, n_nodes=1)
    link = Link(ch, LossDraws(streams.link_batch(R, 1)), mac, errors=be.FrameErrors(kind, streams.bit_error_keys(R, 1)))
    for i in range(n):
        link.transfer(float(i), np.ones(R, bool), None, None)
    tries = int(link.stats.attempts.sum())
    lost = tries - int(link.stats.delivered.sum())
    p = float(per.per_from_ber(ber, mac.preamble_bits + 8 * fr.LENGTHS[kind]))
    assert tries == R * n
    assert stats.binomtest(lost, tries, p).pvalue > 1e-4, (lost / tries, p)
    assert link.stats.crc_rejected.sum() > 0
    if ber >= 1e-3:
        p_frame_only = float(per.per_from_ber(ber, 8 * fr.LENGTHS[kind]))
        assert stats.binomtest(lost, tries, p_frame_only).pvalue < 1e-4


def test_flipped_bits_are_independent_with_the_ber():
    """Chi-square of the flip count per 216-bit frame against Binomial(216, BER), and every bit position
    flips at the BER."""
    ber, n = 0.01, 40_000
    counts = np.zeros(n, dtype=np.int64)
    per_bit = np.zeros(8 * fr.ESTIMATE_BYTES)
    for i in range(n):
        buf = np.zeros(fr.ESTIMATE_BYTES, np.uint8)
        counts[i] = be.flip_bits(np.uint64(987654321), i, ber, buf)
        per_bit += np.unpackbits(buf)
    kmax = 7
    observed = np.array([(counts == k).sum() for k in range(kmax)] + [(counts >= kmax).sum()])
    pk = stats.binom.pmf(np.arange(kmax), 216, ber)
    expected = n * np.append(pk, 1 - pk.sum())
    assert stats.chisquare(observed, expected).pvalue > 1e-4
    assert stats.chisquare(per_bit, np.full(per_bit.size, per_bit.mean())).pvalue > 1e-4
    assert abs(per_bit.mean() / n - ber) < 5 * np.sqrt(ber / n / per_bit.size)


@pytest.mark.parametrize("kind", KINDS)
def test_every_single_and_double_bit_error_is_detected(kind):
    rng = np.random.default_rng(3)
    nf = len(fr.FIELDS[kind])
    values = rng.integers(0, 2**15, size=(1, nf))
    frame = fr.encode(kind, values)[0][0]
    nbits = 8 * frame.size
    flips = []
    for a in range(nbits):
        for b in range(a, nbits):  # b == a: one bit
            f = frame.copy()
            f[a // 8] ^= 1 << (7 - a % 8)
            if b != a:
                f[b // 8] ^= 1 << (7 - b % 8)
            flips.append(f)
    _, ok = fr.decode(kind, np.array(flips))
    assert not ok.any()


@pytest.mark.parametrize("kind", KINDS)
def test_acceptance_depends_on_the_error_pattern_only(kind):
    """What the MAC decides on the all-zero frame (frame_try) is what the receiver decodes on the real bytes: for
    random patterns (almost all rejected) and for codeword patterns (a valid frame xor the zero frame: accepted,
    payload changed)."""
    rng = np.random.default_rng(5)
    nf, n = len(fr.FIELDS[kind]), fr.LENGTHS[kind]
    zero = be.zero_frame(kind)
    real = fr.encode(kind, rng.integers(0, 2**15, size=(200, nf)))[0]
    random_patterns = rng.integers(0, 256, size=(200, n), dtype=np.uint8)
    codewords = fr.encode(kind, rng.integers(0, 2**15, size=(200, nf)))[0] ^ zero
    for patterns, expect in ((random_patterns, None), (codewords, True)):
        _, on_zero = fr.decode(kind, zero ^ patterns)
        values, on_real = fr.decode(kind, real ^ patterns)
        assert np.array_equal(on_zero, on_real)
        if expect:
            assert on_real.all()
            assert (values != fr.decode(kind, real)[0]).any(axis=1).all()
        else:
            assert on_real.mean() < 0.01


def test_an_undetected_corruption_reaches_the_receiver_in_the_bytes():
    """A try whose flips pass the CRC: Link.received gives the sent bytes with those flips; they decode (CRC
    holds) to other words."""
    kind, ber = fr.ESTIMATE, 0.3
    key = np.uint64(42)
    zero, work, vals = be.zero_frame(kind), np.zeros(fr.ESTIMATE_BYTES, np.uint8), np.zeros(7, np.int64)
    try_no = next(i for i in range(2_000_000)
                  if be.frame_try(key, i, ber, zero, work, fr.ESTIMATE_LAYOUT, kind, vals)[1]
                  and be.frame_try(key, i, ber, zero, work, fr.ESTIMATE_LAYOUT, kind, vals)[0] > 0)
    sent = fr.encode(kind, np.array([[3, 7, 1000, 123456, 99, -5, 8]] * 2))[0]
    mac = MacSection(enabled=True, bit_errors=True)
    link = Link(_channel(ber, 2, 56, 27), LossDraws([np.random.default_rng(0)] * 2), mac,
                errors=be.FrameErrors(kind, np.array([key, key])))
    from nodesim.chain.mac import Transfer
    tr = Transfer(np.array([True, True]), np.zeros(2), np.zeros(2), np.array([try_no, -1]), np.array([ber, 0.0]))
    got = link.received(sent, tr)
    assert np.array_equal(got[1], sent[1]) and not np.array_equal(got[0], sent[0])
    values, ok = fr.decode(kind, got)
    assert ok.all() and (values[0] != values[1]).any()
    assert np.array_equal(sent, fr.encode(kind, np.array([[3, 7, 1000, 123456, 99, -5, 8]] * 2))[0])  # not mutated


GOOD = {"chain.nodes": 3, "simulation.duration_s": 120.0, "simulation.realizations": 2,
        "metrics.window_start_s": 60.0, "metrics.window_end_s": 120.0, "radio.model": "channel",
        "radio.shadowing_sigma_db": 0.0, "radio.soil.distance_m": 0.5, "mac.enabled": True,
        "filter.implementation": "fixed"}


def test_bit_errors_on_a_clean_hop_change_nothing():
    """BER ~ 0 on every hop: the same run with and without bit errors (no flip, the same draws)."""
    off = simulate_chain(Scenario().with_overrides(**GOOD))
    on = simulate_chain(Scenario().with_overrides(**GOOD, **{"mac.bit_errors": True}))
    assert max(float(h.ber_table.max()) for h in on.hops[1:]) < 1e-9
    for a, b in zip(off.nodes, on.nodes):
        assert np.array_equal(a.yaw_est_rad, b.yaw_est_rad, equal_nan=True)
        assert np.array_equal(a.estimate_frames, b.estimate_frames)
    assert sum(x.stats.crc_rejected.sum() for x in on.down_links) == 0


def test_rejected_frames_are_retried_and_nothing_else_is_lost():
    """Lossy hops: a rejected try is never a delivering one (rejected + delivered <= tries); a frame that was not
    delivered (nor queue-dropped) used all 1 + max_retries tries; every update below the top node used a frame
    its sender sent, decoded to the sender's words."""
    over = {**GOOD, "radio.soil.distance_m": 2.0, "radio.soil.vwc": 0.275, "mac.bit_errors": True,
            "simulation.realizations": 3}
    scenario = Scenario().with_overrides(**over)
    run = simulate_chain(scenario)
    tries = 1 + scenario.mac.max_retries
    for x in run.down_links[1:]:
        s = x.stats
        assert s.crc_rejected.sum() > 10 and s.undetected.sum() == 0
        assert (s.crc_rejected + s.delivered <= s.attempts).all()
        assert ((s.frames - s.delivered - s.dropped) * tries <= s.attempts - s.delivered).all()
        assert (s.frames - s.delivered).sum() > 0  # some ran out of tries
    for above, n in zip(run.nodes[:-1], run.nodes[1:]):
        sent = above.estimate_frames[:, :, 0] == fr.ESTIMATE
        assert fr.decode(fr.ESTIMATE, above.estimate_frames[sent])[1].all()
        assert n.update_mask.sum() <= sent.sum()


@pytest.mark.parametrize("over, match", [
    ({"mac.bit_errors": "yes"}, "bit_errors"),
    ({"mac.bit_errors": 1}, "bit_errors"),
    ({"mac.bit_errors": True, "radio.model": "simple", "filter.implementation": "fixed"}, "radio.model = 'channel'"),
    ({"mac.bit_errors": True, "radio.model": "channel", "filter.implementation": "float"}, "filter.implementation"),
])
def test_bad_bit_errors_settings_are_refused(over, match):
    with pytest.raises(NodesimError, match=match):
        Scenario().with_overrides(**over)


@pytest.mark.parametrize("engine", ["event", "compiled"])
def test_bit_errors_are_seeded_per_realization(engine):
    """Realization 2 of a 3-realization run is the 1-realization run with first_realization = 2 (its own
    bit-error keys), and another seed draws other errors."""
    over = {**GOOD, "radio.soil.distance_m": 2.0, "radio.soil.vwc": 0.275, "mac.bit_errors": True,
            "simulation.engine": engine}
    batch = simulate_chain(Scenario().with_overrides(**{**over, "simulation.realizations": 3}))
    one = simulate_chain(Scenario().with_overrides(**{**over, "simulation.realizations": 1,
                                                      "simulation.first_realization": 2}))
    other = simulate_chain(Scenario().with_overrides(**{**over, "simulation.realizations": 3, "seed": 99}))
    for a, b in zip(batch.down_links, one.down_links):
        assert a.stats.crc_rejected[2] == b.stats.crc_rejected[0] and a.stats.attempts[2] == b.stats.attempts[0]
    for a, b in zip(batch.nodes, one.nodes):
        assert np.array_equal(a.yaw_est_rad[2], b.yaw_est_rad[0]) and np.array_equal(a.estimate_frames[2],
                                                                                      b.estimate_frames[0])
    assert any(not np.array_equal(a.stats.crc_rejected, b.stats.crc_rejected)
               for a, b in zip(batch.down_links[1:], other.down_links[1:]))
