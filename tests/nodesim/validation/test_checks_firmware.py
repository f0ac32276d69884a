"""The firmware validation checks (nodesim validate) compute what they claim, and the gap to the thesis's
fig 4.11b B = 5 figure is recorded rather than hidden."""

from nodesim.validation import checks_firmware


def test_tuning_checks_record_b1_and_b5():
    """Thesis fig 4.11b: ~82.8 s (B = 5), ~177.98 s (B = 1).  Ours (lab models, 8 realizations, the default
    filter.b_tuning = 'process_noise'): B = 1 within 25 %; B = 5 within 25 % too, at the short end (~66 s: between
    fig 4.11b's 82.8 s and the thesis's separate continuous-mode ~46 s, which the note names); with B as a noise
    gain (Q x B^2, the reading before issue 21) B = 5 took ~42 s and missed."""
    b5, b1, ratio = checks_firmware.tuning_convergence()
    assert b1.ok and abs(b1.ours / 177.98 - 1.0) <= 0.25
    assert b5.ok and 0.75 <= b5.ours / 82.8 < 1.0 and "46 s" in b5.note and "process_noise" in b5.note
    assert ratio.ours == b1.ours / b5.ours and ratio.ok and ratio.ours > 1.0


def test_fixed_filter_tracks_float_on_the_lab_profile():
    """Digest 2.7 acceptance: RMS |psi_fixed - psi_float| < 0.01 deg, no saturation with default formats."""
    cont, win, sat = checks_firmware.fixed_vs_float()
    assert cont.ok and win.ok and sat.ok
    assert 0.0 < cont.ours < 0.01 and 0.0 < win.ours < 0.01
    assert sat.ours == 0.0
    assert {c.kind for c in (cont, win, sat)} == {"self_consistency"}  # our fixed filter against our float filter
