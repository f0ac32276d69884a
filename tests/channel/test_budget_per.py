"""Link budget (thesis eq 5.1), shadowing, Gilbert-Elliott bursts, noise floor, BER and PER."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from channel import budget, per
from channel.errors import ChannelError


def test_budget_arithmetic_and_thesis_defaults():
    assert budget.PIPE_5G_BUDGET.max_path_loss_db == 110.0  # thesis 5.2.5: 10 dBm in, -100 dBm sensitivity
    assert budget.SOIL_868_BUDGET.max_path_loss_db == 112.0  # thesis 5.1.2: 2 dBm, -110 dBm
    b = budget.LinkBudget(2.0, -110.0, tx_gain_dbi=1.5, rx_gain_dbi=-3.0, other_losses_db=2.0)
    assert float(b.received_power_dbm(40.0)) == pytest.approx(2 + 1.5 - 3 - 2 - 40)
    assert float(b.margin_db(40.0)) == pytest.approx(-41.5 + 110)
    assert float(b.allowed_path_loss_db(10.0)) == pytest.approx(b.max_path_loss_db - 10)
    assert float(b.received_power_dbm(np.inf)) == -np.inf
    with pytest.raises(ChannelError, match="other_losses_db"):
        budget.LinkBudget(2.0, -110.0, other_losses_db=-1.0)
    with pytest.raises(ChannelError, match="path_loss_db"):
        b.received_power_dbm(np.nan)


def test_shadowing_is_deterministic_and_has_the_asked_spread():
    a = budget.shadowed_path_loss_db(80.0, 4.0, np.random.default_rng(7), size=200_000)
    b = budget.shadowed_path_loss_db(80.0, 4.0, np.random.default_rng(7), size=200_000)
    np.testing.assert_array_equal(a, b)
    assert a.mean() == pytest.approx(80.0, abs=0.05) and a.std() == pytest.approx(4.0, rel=0.01)
    with pytest.raises(ChannelError, match="Generator"):
        budget.shadowed_path_loss_db(80.0, 4.0, np.random, size=3)
    with pytest.raises(ChannelError, match="sigma_db"):
        budget.shadowed_path_loss_db(80.0, -1.0, np.random.default_rng(0))


def test_gilbert_elliott_stationary_loss_and_burst_length():
    ge = budget.GilbertElliott(p_good_to_bad=0.02, p_bad_to_good=0.25, loss_good=0.01, loss_bad=0.9)
    lost, bad = ge.simulate(20_000, np.random.default_rng(3), batch=16)
    assert lost.mean() == pytest.approx(ge.mean_loss_rate, rel=0.05)
    assert bad.mean() == pytest.approx(ge.stationary_bad, rel=0.05)
    # mean bad-run length = 1 / p_bad_to_good
    runs = []
    for row in bad[:4]:
        edges = np.flatnonzero(np.diff(np.r_[0, row.astype(int), 0]))
        runs.extend(edges[1::2] - edges[::2])
    assert np.mean(runs) == pytest.approx(ge.mean_burst_length, rel=0.1)
    again, _ = ge.simulate(20_000, np.random.default_rng(3), batch=16)
    np.testing.assert_array_equal(lost, again)


def test_gilbert_elliott_bad_parameters():
    with pytest.raises(ChannelError, match="p_bad_to_good"):
        budget.GilbertElliott(p_bad_to_good=0.0)
    with pytest.raises(ChannelError, match="loss_bad"):
        budget.GilbertElliott(loss_bad=1.5)


def test_noise_floor_is_minus_174_dbm_per_hz():
    assert float(per.noise_floor_dbm(1.0)) == pytest.approx(-173.98, abs=0.01)
    assert float(per.noise_floor_dbm(100e3, 8.0)) == pytest.approx(-173.98 + 50 + 8, abs=0.01)


@settings(max_examples=50, deadline=None)
@given(g=st.floats(0.0, 60.0))
def test_ber_closed_forms(g):
    assert float(per.ber(g)) == pytest.approx(0.5 * np.exp(-g / 2), rel=1e-6, abs=1e-300)  # orthogonal FSK
    assert float(per.ber(g, "dbpsk")) == pytest.approx(0.5 * np.exp(-g))
    # ordering at equal Eb/N0: BPSK <= DBPSK <= non-coherent FSK; coherent FSK <= non-coherent FSK
    assert per.ber(g, "bpsk") <= per.ber(g, "dbpsk") + 1e-300 <= per.ber(g) + 2e-300
    assert per.ber(g, "fsk_coherent") <= per.ber(g) + 1e-300


def test_narrower_fsk_index_costs_snr():
    g = np.array([5.0, 10.0, 20.0])
    assert np.all(per.ber(g, modulation_index=0.5) > per.ber(g, modulation_index=1.0))


@settings(max_examples=40, deadline=None)
@given(p1=st.floats(-125, -80), dp=st.floats(0.1, 10), n=st.integers(8, 2048))
def test_per_falls_with_power_and_rises_with_frame_length(p1, dp, n):
    a = float(per.packet_error_rate(p1, n))
    assert float(per.packet_error_rate(p1 + dp, n)) <= a
    assert float(per.packet_error_rate(p1, n + 8)) >= a
    assert 0.0 <= a <= 1.0


def test_per_from_ber_small_ber_accuracy():
    assert float(per.per_from_ber(1e-12, 1000)) == pytest.approx(1e-9, rel=1e-6)


def test_default_radio_sensitivity_is_near_the_cc1101_figure():
    """Default assumptions give BER 1e-3 at -109.2 dBm (thesis 5.1.2: CC1101/AMB8420 -110 dBm)."""
    assert per.sensitivity_dbm() == pytest.approx(-109.2, abs=0.1)


def test_draw_packet_success_is_deterministic():
    rx = np.full(10_000, -106.0)
    a = per.draw_packet_success(rx, 160, np.random.default_rng(11))
    b = per.draw_packet_success(rx, 160, np.random.default_rng(11))
    np.testing.assert_array_equal(a, b)
    assert 1 - a.mean() == pytest.approx(float(per.packet_error_rate(-106.0, 160)), abs=0.02)


def test_bad_radio_is_a_clear_error():
    with pytest.raises(ChannelError, match="modulation must be one of"):
        per.Radio(modulation="qam")
    with pytest.raises(ChannelError, match="bandwidth_hz"):
        per.Radio(bandwidth_hz=0)
    with pytest.raises(ChannelError, match="frame_bits"):
        per.per_from_ber(0.1, 0)


def test_link_quality_when_nothing_arrives():
    q = per.link_quality(np.array([-np.inf, -200.0, -60.0]), 160)
    assert q["packet_error_rate"][0] == pytest.approx(1.0) and q["ber"][0] == pytest.approx(0.5)
    assert q["packet_error_rate"][2] == 0.0
    with pytest.raises(ChannelError, match="rx_power_dbm"):
        per.link_quality(np.nan, 160)
