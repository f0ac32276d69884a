"""Steel wall resistivity model (channel.steel), thesis Table 5.1 grades."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from channel import steel
from channel.errors import ChannelError


def test_reproduces_the_aisi_1020_handbook_points_it_is_anchored_to():
    rho = steel.carbon_steel_resistivity_ohm_m(np.array([0.0, 100.0, 200.0]), 0.20)
    np.testing.assert_allclose(rho, [0.159e-6, 0.219e-6, 0.292e-6], rtol=2e-3)
    assert float(steel.carbon_steel_resistivity_ohm_m(20.0, 0.10)) == pytest.approx(0.143e-6, rel=5e-3)  # AISI 1010


def test_documented_example_values():
    assert float(steel.carbon_steel_resistivity_ohm_m(20.0, 0.26)) == pytest.approx(0.186e-6, rel=5e-3)
    assert float(steel.carbon_steel_resistivity_ohm_m(200.0, 0.26)) == pytest.approx(0.320e-6, rel=5e-3)


@given(t=st.floats(-20, 390), c=st.floats(0.05, 0.39))
def test_rises_with_temperature_and_carbon(t, c):
    r = steel.carbon_steel_resistivity_ohm_m(t, c)
    assert steel.carbon_steel_resistivity_ohm_m(t + 10, c) > r
    assert steel.carbon_steel_resistivity_ohm_m(t, c + 0.01) > r


def test_every_table_5_1_grade_is_inside_the_model_range():
    for grade, c in steel.API5L_CARBON_WT_PCT.items():
        assert steel.grade_carbon_wt_pct(grade) == c
        assert steel.CARBON_MIN_WT_PCT <= c <= steel.CARBON_MAX_WT_PCT
    assert steel.grade_carbon_wt_pct("x-60 smls") == 0.26


def test_bad_input():
    with pytest.raises(ChannelError, match="carbon_wt_pct must be in"):
        steel.carbon_steel_resistivity_ohm_m(20.0, 1.22)
    with pytest.raises(ChannelError, match="temperature_c"):
        steel.carbon_steel_resistivity_ohm_m(900.0, 0.26)
    with pytest.raises(ChannelError, match="grade must be one of"):
        steel.grade_carbon_wt_pct("X99")
