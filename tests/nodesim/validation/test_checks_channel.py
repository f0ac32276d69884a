"""The soil rows of ``nodesim validate`` (thesis 5.1.2): the direct rows and the span row are reproductions and
fail, the dBW rows are hypotheses that use one soil for both endpoints and say what they assume, and every row at
80 % VWC flags that the water content exceeds the soil's porosity."""

import numpy as np
import pytest

from channel import soil
from channel.budget import SOIL_868_BUDGET
from nodesim.validation import checks_channel


def _rss(vwc, sand, clay):
    s = soil.Soil(sand=sand, clay=clay, vwc=vwc)
    return float(SOIL_868_BUDGET.received_power_dbm(soil.soil_path_loss(868e6, 0.3, s).path_loss_db))


@pytest.fixture(scope="module")
def rows():
    return {c.name: c for c in checks_channel.soil_rss()}


def test_direct_and_span_rows_are_failing_reproductions(rows):
    direct = [c for c in rows.values() if "sandy loam" in c.name]
    assert len(direct) == 3 and all(c.kind == "reproduction" and not c.ok for c in direct)
    span = rows["soil: RSS span 1 % -> 80 % VWC, sandy loam [dB]"]
    assert span.published == pytest.approx(-54.5 - -95.1)
    assert span.ours == pytest.approx(_rss(0.01, 0.5, 0.15) - _rss(0.8, 0.5, 0.15))


def test_hypothesis_rows_use_one_soil_and_state_the_soil_and_the_offset(rows):
    hyp = [c for c in rows.values() if c.kind == "hypothesis"]
    assert [c.published for c in hyp] == [-54.5, -95.1]
    sand, clay = checks_channel.HYPOTHESIS_SOIL["sand"], checks_channel.HYPOTHESIS_SOIL["clay"]
    for c, vwc in zip(hyp, (0.01, 0.8)):
        assert c.ours == pytest.approx(_rss(vwc, sand, clay) - 30.0)
        assert f"sand {sand:g} / clay {clay:g}" in c.note and "constant 30 dB offset" in c.note
    # the span of the two hypothesis rows is the chosen soil's own span (one soil, not a best and a worst)
    assert hyp[0].ours - hyp[1].ours == pytest.approx(_rss(0.01, sand, clay) - _rss(0.8, sand, clay))


def test_rows_at_80_percent_flag_the_porosity_and_rows_at_1_percent_do_not(rows):
    porosity = 1.0 - 1.5 / 2.66
    for name, c in rows.items():
        flagged = f"porosity {porosity:.3f}" in c.note
        assert flagged == ("80 %" in name), name


def test_porosity_note_is_empty_below_the_porosity():
    assert checks_channel.porosity_note(0.4, 0.5, 0.15) == ""
    assert "exceeds" in checks_channel.porosity_note(0.44, 0.5, 0.15)
    assert np.isclose(soil.Soil().porosity, 1.0 - 1.5 / 2.66)
