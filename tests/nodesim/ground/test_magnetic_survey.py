"""Forward/inverse magnetic survey conversion (HV eqs 3.6-3.9, SV eqs 1-2, 7; digest sections 2-4)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from nodesim.errors import NodesimError
from nodesim.ground.magnetic_survey import (
    FieldReference,
    apply_errors,
    check_triads,
    correct,
    params_array,
    survey_from_readings,
    tool_readings,
)
from nodesim.ground.msa_surveys import hv_mcm_sheet, hv_spreadsheet2, published_numbers
from nodesim.sensors.magnetometer import magnetic_survey
from nodesim.units import DEG

PUB = published_numbers()


def closed_form(tf, inc, azi, ref):
    """The printed forward model (SV eq 2, HV 3.6 with the By typo corrected) - an independent oracle."""
    t, i, a = np.radians(tf), np.radians(inc), np.radians(azi)
    bh, bv = ref.bh_ut, ref.bv_ut
    g = np.stack([-np.cos(t) * np.sin(i), np.sin(t) * np.sin(i), np.cos(i)], axis=-1)
    bx = bh * (np.cos(t) * np.cos(i) * np.cos(a) - np.sin(t) * np.sin(a)) - bv * np.cos(t) * np.sin(i)
    by = bh * (-np.sin(t) * np.cos(i) * np.cos(a) - np.cos(t) * np.sin(a)) + bv * np.sin(t) * np.sin(i)
    bz = bh * np.sin(i) * np.cos(a) + bv * np.cos(i)
    return g, np.stack([bx, by, bz], axis=-1)


@settings(max_examples=60, deadline=None)
@given(
    tf=st.floats(0, 360),
    inc=st.floats(0.5, 179.5),
    azi=st.floats(0, 359.9),
    b=st.floats(20, 70),
    dip=st.floats(-85, 85),
)
def test_forward_matches_printed_equations_and_inverts(tf, inc, azi, b, dip):
    ref = FieldReference(b, dip)
    g, bb = tool_readings(tf, inc, azi, ref)
    g0, b0 = closed_form(tf, inc, azi, ref)
    np.testing.assert_allclose(g, g0, atol=1e-12)
    np.testing.assert_allclose(bb, b0, atol=1e-9)
    s = survey_from_readings(g, bb)
    assert abs(np.degrees(s.inc_rad) - inc) < 1e-9
    assert abs((np.degrees(s.azi_rad) - azi + 180) % 360 - 180) < 1e-7
    assert abs((np.degrees(s.toolface_rad) - tf + 180) % 360 - 180) < 1e-7
    assert abs(s.b_total_ut - b) < 1e-9 and abs(np.degrees(s.dip_rad) - dip) < 1e-7


def test_azimuth_uses_atan2_over_the_full_circle():
    """HV Fig 3-2: a plain arctan folds azimuths into (-90, 90); atan2 recovers every quadrant."""
    azi = np.arange(0.0, 360.0, 15.0)
    g, b = tool_readings(np.full(azi.size, 40.0), np.full(azi.size, 60.0), azi, FieldReference(51, 72))
    np.testing.assert_allclose(np.degrees(survey_from_readings(g, b).azi_rad), azi, atol=1e-9)


def test_same_azimuth_as_the_sensor_package_inverse():
    """Tool frame = sensor body frame with z reversed: the sensors' magnetic_survey gives the same angles."""
    rng = np.random.default_rng(2)
    tf, inc, azi = rng.uniform(0, 360, 50), rng.uniform(1, 120, 50), rng.uniform(0, 360, 50)
    g, b = tool_readings(tf, inc, azi, FieldReference(48, 60))
    flip = np.array([1.0, 1.0, -1.0])
    i2, a2 = magnetic_survey(-g * flip, b * flip)
    s = survey_from_readings(g, b)
    np.testing.assert_allclose(i2, s.inc_rad, atol=1e-12)
    np.testing.assert_allclose(np.cos(a2 - s.azi_rad), 1.0, atol=1e-12)


def test_hv_spreadsheet_triads_and_uncorrected_survey():
    """HV Fig 8-1 (digest 13.1): clean and measured triads to 2 decimals, T/I/A/dip/B without MSA to 1 decimal."""
    pub = PUB["hv_spreadsheet2"]
    traj = hv_spreadsheet2()
    ref = FieldReference(pub["b_total_ut"], pub["dip_deg"])
    g, b = tool_readings(traj.toolface_deg, traj.inc_deg, traj.azi_deg, ref)
    b_m = apply_errors(b, params_array(pub["scale"], pub["bias_ut"]))
    s = survey_from_readings(g, b_m)
    for row in pub["rows"]:
        k = int(np.searchsorted(traj.md_m, row["md_m"]))
        np.testing.assert_allclose(g[k], row["g"], atol=0.005 + 1e-12)
        np.testing.assert_allclose(b[k], row["b_clean"], atol=0.005 + 1e-12)
        np.testing.assert_allclose(b_m[k], row["b_meas"], atol=0.005 + 1e-12)
        assert abs(np.degrees(s.toolface_rad[k]) - row["tf_deg"]) < 0.05
        assert abs(np.degrees(s.inc_rad[k]) - row["inc_deg"]) < 0.05
        assert abs(np.degrees(s.dip_rad[k]) - row["dip_deg"]) < 0.05
        assert abs(s.b_total_ut[k] - row["b_total_ut"]) < 0.05
        if row["azi_deg"] is not None:
            assert abs(np.degrees(s.azi_rad[k]) - row["azi_deg"]) < 0.05
    for md, azi in pub["more_azimuths_deg"].items():
        k = int(np.searchsorted(traj.md_m, float(md)))
        assert abs(np.degrees(s.azi_rad[k]) - azi) < 0.05, md


def test_hv_mcm_sheet_raw_triads():
    """HV Fig 8-3 raw data (B 50 uT, dip 80 deg): field triads to 2 decimals."""
    pub = PUB["hv_mcm_sheet"]
    raw = np.array(pub["raw"])
    _, b = tool_readings(raw[:, 1], raw[:, 2], raw[:, 3], FieldReference(pub["b_total_ut"], pub["dip_deg"]))
    np.testing.assert_allclose(b, raw[:, 4:], atol=0.005 + 1e-12)
    assert hv_mcm_sheet().md_m[-1] == 6700.0


def test_correction_inverts_the_error_model():
    rng = np.random.default_rng(0)
    b = rng.normal(size=(30, 3)) * 40
    theta = params_array([1.1, 0.95, 1.25], [0.25, 0.295, -0.335])
    np.testing.assert_allclose(correct(apply_errors(b, theta), theta), b, atol=1e-12)


def test_bad_triads_get_clear_errors():
    g, b = tool_readings([25, 115, 205], [10, 20, 30], [40, 40, 40], FieldReference(50, 60))
    b_nan = b.copy()
    b_nan[1, 2] = np.nan
    with pytest.raises(NodesimError, match="station 2: magnetometer"):
        survey_from_readings(g, b_nan)
    b_zero = b.copy()
    b_zero[2] = 0.0
    with pytest.raises(NodesimError, match="station 3: magnetometer triad is zero"):
        check_triads(g, b_zero)
    with pytest.raises(NodesimError, match="must both be"):
        check_triads(g[:, :2], b[:, :2])
    with pytest.raises(NodesimError, match="station 1: inc_deg"):
        tool_readings([0.0], [np.nan], [0.0], FieldReference(50, 60))


@pytest.mark.parametrize("b, dip, key", [(0.0, 10.0, "b_total_ut"), (np.nan, 10.0, "b_total_ut"), (50.0, 90.0, "dip_deg")])
def test_bad_reference(b, dip, key):
    with pytest.raises(NodesimError, match=key):
        FieldReference(b, dip)


def test_inclination_above_90_degrees():
    """HV Survey 6 reaches I = 110 deg: atan2 inclination covers (90, 180)."""
    g, b = tool_readings(30.0, 110.0, 193.0, FieldReference(51, 72))
    s = survey_from_readings(g, b)
    assert abs(s.inc_rad / DEG - 110.0) < 1e-9 and abs(s.azi_rad / DEG - 193.0) < 1e-9
