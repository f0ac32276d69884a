"""The soil RSS gap between the published equations and the thesis figures (thesis 5.1.2, Figs 5.2-5.4).

Thesis: RSS about -54.5 dBm at 1 % VWC and -95.1 dBm at 80 % VWC (868 MHz, 0.3 m, P_t = 2 dBm).  The gap is
measured here, and candidate unit errors are tested: only a VWC-independent offset can fit both endpoints.  An
offset leaves the 1 % -> 80 % span unchanged, so one soil must give the published 40.6 dB span by itself: none of
the sand/clay grid does, pure clay comes closest (39.9 dB), and with it 30 dB (dBW labelled dBm) fits the 80 %
endpoint within 2 dB but not the 1 % one (the constant that fits both is ~27.9 dB).
"""

import numpy as np
import pytest

from channel import soil
from channel.budget import SOIL_868_BUDGET
from nodesim.validation.checks_channel import HYPOTHESIS_SOIL, _composition_grid

THESIS_1, THESIS_80 = -54.5, -95.1


def rss(vwc, d=0.3, sand=0.5, clay=0.15):
    s = soil.Soil(sand=sand, clay=clay, vwc=vwc)
    return SOIL_868_BUDGET.received_power_dbm(soil.soil_path_loss(868e6, d, s).path_loss_db)


def test_measured_gap_for_the_default_soil():
    gap_1 = float(rss(0.01)) - THESIS_1
    gap_80 = float(rss(0.8)) - THESIS_80
    assert gap_1 == pytest.approx(27.9, abs=0.2)
    assert gap_80 == pytest.approx(43.9, abs=0.2)


def test_no_soil_of_the_grid_gives_the_published_span_and_clay_comes_closest():
    """Thesis span 1 % -> 80 % = 40.6 dB.  For one soil the model's span is at most 39.9 dB (pure clay); 43 dB is
    reached only by taking the best soil at 1 % and the worst at 80 %, two different soils."""
    sand, clay = _composition_grid()
    spans = rss(0.01, sand=sand, clay=clay) - rss(0.8, sand=sand, clay=clay)
    k = int(np.argmax(spans))
    assert spans[k] == pytest.approx(39.9, abs=0.1)
    assert spans[k] < THESIS_1 - THESIS_80
    assert (sand[k], clay[k]) == (HYPOTHESIS_SOIL["sand"], HYPOTHESIS_SOIL["clay"])
    mixed = float(np.max(rss(0.01, sand=sand, clay=clay)) - np.min(rss(0.8, sand=sand, clay=clay)))
    assert mixed == pytest.approx(43.0, abs=0.1)


def test_unit_errors_in_distance_or_water_content_do_not_explain_the_gap():
    """d in cm or VWC in percent make the 80 % loss hundreds of dB: not the thesis's -95 dBm."""
    cm = float(rss(0.8, d=30.0))
    assert cm < -1000
    # VWC in percent: 1 % -> m_v = 1 happens to give about -54 dBm, but 80 % would be m_v = 80 (outside the model)
    with pytest.raises(Exception):
        rss(80.0)


def test_dbw_hypothesis_with_one_soil_fits_80_percent_but_not_1_percent():
    """One soil (pure clay) for both endpoints, 30 dB off: 80 % within 2 dB, 1 % 2.45 dB too low; the constant
    that would fit this soil is 27.9 dB, within 0.4 dB of both endpoints (the digest's 28.5 dB is close)."""
    at_1, at_80 = (float(v) for v in rss(np.array([0.01, 0.8]), **HYPOTHESIS_SOIL))
    assert at_80 - 30.0 == pytest.approx(THESIS_80, abs=2.0)
    assert at_1 - 30.0 - THESIS_1 == pytest.approx(-2.45, abs=0.05)
    fitted = ((at_1 - THESIS_1) + (at_80 - THESIS_80)) / 2.0
    assert fitted == pytest.approx(27.9, abs=0.05)
    assert abs(at_1 - fitted - THESIS_1) < 0.4 and abs(at_80 - fitted - THESIS_80) < 0.4
