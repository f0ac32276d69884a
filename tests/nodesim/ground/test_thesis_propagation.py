"""The thesis-replica propagation (nodesim.ground.thesis_propagation): its rules on hand-computable surveys,
and the wellbore-1 rows it reproduces against the thesis tables (tests/data/thesis/wb1_tool_tables.json)."""

import json
import math
from pathlib import Path

import numpy as np
import pytest

from nodesim.errors import NodesimError
from nodesim.ground import make_survey, position_uncertainty, propagate
from nodesim.ground.covariance import Site, Uncertainty
from nodesim.ground.errormodel import ErrorModel, ErrorSource
from nodesim.ground.thesis_propagation import (
    ThesisRules,
    ThesisUncertainty,
    propagate_thesis,
    scale_to_match,
    station_levers,
)
from nodesim.ground.tools import load_tool

G = 9.81
SITE = Site(gravity_m_s2=G, dip_deg=0.0)
TABLES = json.loads((Path(__file__).resolve().parents[2] / "data" / "thesis" / "wb1_tool_tables.json").read_text())


def src(code, weight, magnitude, unit="rad", propagation="R"):
    return ErrorSource(code, weight, magnitude, unit, propagation)


def run(survey, *sources, rules=None, name="t"):
    return propagate_thesis(survey, ErrorModel(name, tuple(sources)), SITE, rules=rules or ThesisRules())


# -- the half lever at the last station ------------------------------------------------------------------


def test_levers_are_the_half_courses_either_side_and_half_at_the_last_station():
    assert station_levers([0, 2, 4, 6]).tolist() == [0.0, 2.0, 2.0, 1.0]
    assert station_levers([0, 1, 4, 10]).tolist() == [0.0, 2.0, 4.5, 3.0]  # (1+3)/2, (3+6)/2, 6/2


def test_row_k_is_a_running_sum_with_the_half_lever_only_at_the_last_station():
    """Vertical hole, azimuth 0, inclination error 0.01 rad at every station (dt/dI = (1, 0, 0)): N per station
    = lever * 0.01 = 0.02, 0.02, 0.01 m.  Row 2 of the 3-station survey keeps the full lever; the same survey cut
    at station 2 gives it a half lever."""
    s3 = make_survey([0, 2, 4, 6], [0, 0, 0, 0], [0, 0, 0, 0])
    u = run(s3, src("I", "INC", 0.01, propagation="S"))
    assert u.sigma_nev_m[:, 0] == pytest.approx([0.0, 0.02, 0.04, 0.05])
    s2 = make_survey([0, 2, 4], [0, 0, 0], [0, 0, 0])
    assert run(s2, src("I", "INC", 0.01, propagation="S")).sigma_nev_m[:, 0] == pytest.approx([0.0, 0.02, 0.03])
    # the standard ISCWSA method puts a half lever at every row's own station: 0.01, 0.03, 0.05
    iscwsa = propagate(s3, ErrorModel("t", (src("I", "INC", 0.01, propagation="S"),)), SITE, method="balanced_tangential")
    assert np.sqrt(iscwsa.cov_nev_m2[:, 0, 0]) == pytest.approx([0.0, 0.01, 0.03, 0.05])


# -- random vs systematic summation ----------------------------------------------------------------------


def test_random_terms_add_in_quadrature_and_systematic_ones_add_magnitudes():
    """Vertical hole turning from azimuth 0 to 180: dt/dI = (+1, 0, 0) then (-1, 0, 0).  With dI = 0.01 rad the
    station contributions to N are +0.02 and -0.01 m: random sqrt(0.02^2 + 0.01^2), systematic |+0.02| + |-0.01|
    (the signed sum, 0.01, is not what the thesis does)."""
    s = make_survey([0, 2, 4], [0, 0, 0], [0, 0, 180])
    r = run(s, src("I", "INC", 0.01, propagation="R"))
    sy = run(s, src("I", "INC", 0.01, propagation="S"))
    assert r.sigma_nev_m[-1, 0] == pytest.approx(math.hypot(0.02, 0.01))
    assert sy.sigma_nev_m[-1, 0] == pytest.approx(0.03)
    both = run(s, src("R", "INC", 0.01, propagation="R"), src("S", "INC", 0.01, propagation="S"))
    assert both.random_nev_m[-1, 0] == pytest.approx(math.hypot(0.02, 0.01))
    assert both.systematic_nev_m[-1, 0] == pytest.approx(0.03)
    assert both.sigma_nev_m[-1, 0] == pytest.approx(math.hypot(math.hypot(0.02, 0.01), 0.03))  # C = C_rand + C_syst


def test_systematic_terms_add_magnitudes_across_sources_too():
    s = make_survey([0, 2], [0, 0], [0, 0])  # one station, lever 1 m, dt/dI = (1, 0, 0)
    u = run(s, src("a", "INC", 0.01, propagation="S"), src("b", "INC", 0.02, propagation="S"))
    assert u.sigma_nev_m[-1, 0] == pytest.approx(0.03)  # eq I.16: arithmetic over sources, not sqrt(0.01^2 + 0.02^2)


def test_the_tool_rules_set_the_mode_not_the_tool_file():
    """The tool files mark the accelerometer bias S; the replica's rules decide (IMUs random, DIP systematic)."""
    s = make_survey([0, 2, 4], [0, 0, 0], [0, 0, 180])
    f = G * math.sin(0.01)
    bias = src("ABXY-TI1S", "ABXY-TI1", f, "m/s2", "S")
    assert run(s, bias, rules=ThesisRules(sensor_mode="R")).sigma_nev_m[-1, 0] == pytest.approx(math.hypot(0.02, 0.01))
    assert run(s, bias, rules=ThesisRules(sensor_mode="S")).sigma_nev_m[-1, 0] == pytest.approx(0.03)


# -- the accelerometer bias enters the inclination only ----------------------------------------------------


def test_accelerometer_bias_is_an_inclination_error_asin_f_over_g():
    """Horizontal hole to the north (dt/dI = (0, 0, -1)): the bias moves TVD only; ISCWSA's toolface part
    (ABXY-TI2) is the same printed bias and is folded into the one term."""
    s = make_survey([0, 2, 4], [90, 90, 90], [0, 0, 0])
    f = 0.5 * G  # asin(0.5) = pi/6, not f/g = 0.5
    u = run(s, src("ABXY-TI1S", "ABXY-TI1", f, "m/s2"), src("ABXY-TI2S", "ABXY-TI2", f, "m/s2"))
    assert [t.code for t in u.terms] == ["ABXY-TI1S"]
    assert u.skipped[0][0] == "ABXY-TI2S" and "already counted as ABXY-TI1S" in u.skipped[0][1]
    assert u.terms[0].d_inc_rad[1:] == pytest.approx(math.pi / 6)
    assert np.all(u.terms[0].d_azi_rad == 0)
    d = math.pi / 6
    assert u.sigma_nev_m[-1] == pytest.approx([0.0, 0.0, math.hypot(2 * d, 1 * d)], abs=1e-12)


def test_thesis_worked_example_geometry():
    """Thesis 4.1.2: station 2 at MD 3 m, I 5 deg, A 30 deg, dI = 0.01 deg (f_xy = 1.712168e-3 m/s^2), no error at
    station 1: 1/2 * 3 m * dt/dI * dI = 2.2586e-4 / 1.3040e-4 / 2.282e-5 m (the thesis prints 2.259e-4, 1.304e-4,
    2.284e-5)."""
    s = make_survey([0, 3], [0, 5], [0, 30])
    u = run(s, src("ABXY-TI1S", "ABXY-TI1", 1.712168e-3, "m/s2"))
    assert u.sigma_nev_m[-1] == pytest.approx([2.2586e-4, 1.3040e-4, 2.282e-5], rel=2e-3)


def test_z_bias_keeps_first_order_effect_and_scale_factor_two_readings():
    s = make_survey([0, 2], [0, 30], [0, 0])
    z = run(s, src("ABZ", "ABZ", 1e-3, "m/s2"))
    assert z.terms[0].d_inc_rad[1] == pytest.approx(0.5 * 1e-3 / G)
    sf = src("ASXY-TI1S", "ASXY-TI1", 1e-3, "-")
    assert run(s, sf).terms[0].d_inc_rad[1] == pytest.approx(1e-3 * 0.5 * math.cos(math.radians(30)))
    assert run(s, sf, rules=ThesisRules(scale_factor_as_angle=True)).terms[0].d_inc_rad[1] == pytest.approx(math.asin(1e-3))


# -- gyro terms and their lever ---------------------------------------------------------------------------


def test_gyro_drift_is_an_azimuth_error_g_t_over_the_sin_i_lever_or_without_it():
    """I = 30 deg, A = 90 deg (east): L = sinI (-sinA, cosA, 0) = (-0.5, 0, 0).  Drift 1e-4 rad/s at t = 100, 200 s:
    dA = 0.01, 0.02 rad; levers 2 m and 1 m; systematic: |N| = 2*0.5*0.01 + 1*0.5*0.02 = 0.02 m, 0.04 m without
    the sin I."""
    s = make_survey([0, 2, 4], [30, 30, 30], [90, 90, 90], time_s=[0, 100, 200])
    drift = src("GYRO-DRIFT", "GYRO-DRIFT", 1e-4, "rad/s", "S")
    u = run(s, drift, rules=ThesisRules(gyro_mode="S"))
    assert u.terms[0].d_azi_rad.tolist() == pytest.approx([0.0, 0.01, 0.02])
    assert u.sigma_nev_m[-1] == pytest.approx([0.02, 0.0, 0.0], abs=1e-15)
    no_sin = run(s, drift, rules=ThesisRules(gyro_mode="S", gyro_lever_sin_i=False))
    assert no_sin.sigma_nev_m[-1, 0] == pytest.approx(0.04)
    arw = run(s, src("GYRO-ARW", "GYRO-RW", 1e-3, "rad/s"), rules=ThesisRules(gyro_mode="R"))
    assert arw.terms[0].d_azi_rad[1:] == pytest.approx([1e-3 * 10, 1e-3 * math.sqrt(200)])


def test_unknown_weight_is_a_clear_error():
    s = make_survey([0, 2], [0, 5], [0, 0])
    with pytest.raises(NodesimError, match=r"MBZ \(weight MBZ\) has no thesis rule; supported weights: ABXY-TI1"):
        run(s, src("MBZ", "MBZ", 70.0, "nT", "S"))


def test_scale_to_match_inverts_a_systematic_and_a_random_term():
    s = make_survey([0, 2], [0, 0], [0, 0])  # lever 1 m, dt/dI = (1, 0, 0)
    u = run(s, src("S", "INC", 0.01, propagation="S"), src("R", "INC", 0.03, propagation="R"))
    # N = hypot(0.03, c * 0.01): c = sqrt(0.05^2 - 0.03^2) / 0.01 = 4
    assert scale_to_match(u, "S", 1, 0, 0.05) == pytest.approx(4.0)
    # N = hypot(c * 0.03, 0.01): c = sqrt(0.05^2 - 0.01^2) / 0.03
    assert scale_to_match(u, "R", 1, 0, 0.05) == pytest.approx(math.sqrt(0.0024) / 0.03)
    assert math.isnan(scale_to_match(u, "S", 1, 0, 0.02))  # below the random term alone
    with pytest.raises(NodesimError, match="no term 'X'"):
        scale_to_match(u, "X", 1, 0, 0.05)


def test_position_uncertainty_selects_the_propagation():
    s = make_survey([0, 2, 4], [0, 1, 2], [0, 10, 20])
    m = load_tool("ipst_rqh")
    assert isinstance(position_uncertainty(s, m), Uncertainty)
    t = position_uncertainty(s, m, propagation="thesis")
    assert isinstance(t, ThesisUncertainty)
    assert t.cov_nev_m2.shape == (3, 3, 3) and np.allclose(t.cov_nev_m2[-1], np.diag(t.sigma_nev_m[-1] ** 2))
    with pytest.raises(NodesimError, match="propagation 'bogus' unknown; allowed: iscwsa, thesis"):
        position_uncertainty(s, m, propagation="bogus")


def test_survey_sigmas_are_random_terms():
    s = make_survey([0, 2, 4], [0, 0, 0], [0, 0, 180], sigma_inc_deg=[0, 0.5, 0.5])
    u = propagate_thesis(s, ErrorModel("none", ()), SITE)
    d = math.radians(0.5)
    assert u.sigma_nev_m[-1, 0] == pytest.approx(math.hypot(2 * d, d))


# -- wellbore 1 against the thesis tables ------------------------------------------------------------------


@pytest.fixture(scope="module")
def wb1():
    from nodesim.validation.checks_ground_wb1 import wellbore1_survey

    survey = wellbore1_survey()
    return {name: propagate_thesis(survey, load_tool(name), SITE) for name in
            ("dip", "vn100t", "stim300", "ipst_rqh", "mpu6500", "mpu6500_filtered")}  # fmt: skip


def ratio(wb1, name, axis_key):
    t = TABLES["tables"][name]
    axis = ("B_cm", "A_cm", "TVD_cm").index(axis_key)
    ours = t["sigma"] * 100.0 * wb1[name].sigma_nev_m[1:, axis]
    return ours / np.asarray(t[axis_key])


@pytest.mark.parametrize(
    "name, axis, stations, rel",
    [
        ("ipst_rqh", "A_cm", range(1, 11), 0.09),  # table 4.14: one random inclination term (SS1 +8 %)
        ("ipst_rqh", "TVD_cm", (4, 5, 7, 8, 9, 10), 0.05),
        ("dip", "B_cm", range(4, 11), 0.10),  # table 4.5: systematic inclination terms
        ("dip", "A_cm", range(4, 11), 0.17),
        ("stim300", "B_cm", range(3, 11), 0.11),  # table 4.11: systematic drift, lever without sin I
        ("vn100t", "B_cm", range(1, 8), 0.21),  # table 4.8, SS1-SS7 only
    ],
)
def test_reproduced_rows(wb1, name, axis, stations, rel):
    r = ratio(wb1, name, axis)
    for k in stations:
        assert abs(r[k - 1] - 1) <= rel, (name, axis, k, r[k - 1])


@pytest.mark.parametrize(
    "name, axis, station, value",
    [
        ("dip", "B_cm", 1, 0.48),  # the table's SS1 is twice its later steps
        ("ipst_rqh", "B_cm", 10, 1.61),  # the table's B stops growing after SS4
        ("ipst_rqh", "TVD_cm", 6, 1.44),  # 0.006 printed twice
        ("vn100t", "B_cm", 10, 1.36),  # grows slower than a constant drift after SS7
        ("stim300", "A_cm", 1, 0.13),  # SS1 A/B = 43: neither an inclination nor an azimuth error
        ("mpu6500", "B_cm", 10, 0.139),  # needs a 23x drift
        ("mpu6500", "A_cm", 10, 0.598),
    ],
)
def test_recorded_gaps(wb1, name, axis, station, value):
    assert ratio(wb1, name, axis)[station - 1] == pytest.approx(value, abs=0.01)


def test_dip_tvd_has_the_shape_of_a_random_term_over_the_lever(wb1):
    """Table 4.5 TVD: 2.1 cm sqrt(k) for SS1-SS9 and 2.1 cm sqrt(9.25) at SS10 (the half lever): the replica's
    shape to 0.4 % at every station, at 1/37.5 of the size (the printed 1.4e-4 m/m cable stretch)."""
    pub = np.asarray(TABLES["tables"]["dip"]["TVD_cm"])
    ours = wb1["dip"].sigma_nev_m[1:, 2]
    assert ours / ours[0] == pytest.approx(pub / pub[0], rel=4e-3)
    assert ours[-1] / ours[0] == pytest.approx(math.sqrt(9.25), rel=2e-3)  # + the inclination terms' small TVD
    c = [scale_to_match(wb1["dip"], "DSF-STRETCH", k, 2, pub[k - 1] / 200.0) for k in range(1, 11)]
    assert c == pytest.approx([37.5] * 10, rel=4e-3)


def test_ss1_b_over_a_is_cot_a1_for_inclination_dominated_tools(wb1):
    cot = abs(1 / math.tan(math.radians(248.2)))
    for name in ("dip", "ipst_rqh", "mpu6500"):
        u = wb1[name].sigma_nev_m[1]
        t = TABLES["tables"][name]
        assert u[0] / u[1] == pytest.approx(cot, rel=1e-3)
        assert t["B_cm"][0] / t["A_cm"][0] == pytest.approx(cot, rel=0.1)


def test_mpu6500_needs_a_drift_about_24x_the_printed_one(wb1):
    pub = np.asarray(TABLES["tables"]["mpu6500"]["B_cm"]) / 100.0
    c = np.array([scale_to_match(wb1["mpu6500"], "GYRO-DRIFT", k, 0, pub[k - 1]) for k in range(5, 11)])
    assert np.all((c > 22) & (c < 29)), c
    assert c[-1] == pytest.approx(23.1, abs=0.1)


def test_filtered_differs_from_unfiltered_under_the_replica_not_under_iscwsa(wb1):
    """The filter replaces the gyro terms by a random 0.25 deg azimuth term; the replica's accelerometer term is
    random, so what the filter removes shows: B at SS10 drops 12.11 -> 11.46 cm (1 sigma) with the printed drift,
    and ~7.6-fold with the drift table 4.17 needs.  Under ISCWSA the systematic 60 mg bias hides it (4 digits)."""
    from nodesim.validation.checks_ground_wb1 import wellbore1_survey, wellbore1_table

    unf, filt = wb1["mpu6500"].sigma_nev_m[-1], wb1["mpu6500_filtered"].sigma_nev_m[-1]
    assert unf[0] / filt[0] == pytest.approx(1.056, abs=0.005)
    assert filt[0] < unf[0] and filt[1] <= unf[1]
    assert 100 * filt[:2] == pytest.approx([11.46, 34.65], abs=0.01)
    iscwsa = wellbore1_table(("mpu6500", "mpu6500_filtered"))
    assert iscwsa["mpu6500"][-1, 0] == pytest.approx(iscwsa["mpu6500_filtered"][-1, 0], rel=1e-3)

    m = load_tool("mpu6500")
    scaled = ErrorModel(m.name, tuple(
        ErrorSource(s.code, s.weight, s.magnitude * (23.1 if s.code == "GYRO-DRIFT" else 1.0), s.unit, s.propagation)
        for s in m.sources))  # fmt: skip
    big = propagate_thesis(wellbore1_survey(), scaled, SITE).sigma_nev_m[-1]
    assert 100 * big[0] == pytest.approx(87.0, abs=0.1)
    assert big[0] / filt[0] == pytest.approx(7.6, abs=0.05)
    assert TABLES["tables"]["mpu6500"]["B_cm"][-1] / TABLES["filtered_mpu6500_ss10_1sigma_cm"]["B_cm"] == pytest.approx(9.46, abs=0.01)


def test_validation_rows(wb1):
    from nodesim.validation.checks_ground_wb1_thesis import wellbore1_thesis

    rows = {c.name: c for c in wellbore1_thesis()}
    assert len(rows) == 22
    ok = sorted(n for n, c in rows.items() if c.ok)
    assert ok == sorted([
        "WB1 thesis replica dip: SS10 B [cm]", "WB1 thesis replica dip: SS10 A [cm]",
        "WB1 thesis replica stim300: SS10 B [cm]", "WB1 thesis replica ipst_rqh: SS10 A [cm]",
        "WB1 thesis replica ipst_rqh: SS10 TVD [cm]", "WB1 thesis replica mpu6500_filtered: SS10 A [cm]",
        "WB1 thesis replica dip: SS1 B/A", "WB1 thesis replica ipst_rqh: SS1 B/A", "WB1 thesis replica mpu6500: SS1 B/A",
        "WB1 thesis replica dip: TVD SS10 / SS1",
    ])  # fmt: skip
    assert {c.tolerance for c in rows.values()} == {"rel 0.2"}
    assert {c.kind for c in rows.values() if "SS1 B/A" in c.name} == {"reproduction"}
    assert {c.kind for c in rows.values() if "SS1 B/A" not in c.name} == {"hypothesis"}
    for c in rows.values():
        assert c.note, c.name
    assert "needs 0.23 deg/s drift, 23x the printed 0.01 deg/s" in rows["WB1 thesis replica mpu6500: SS10 B [cm]"].note
    assert "37.5x the printed" in rows["WB1 thesis replica dip: SS10 TVD [cm]"].note
    filt = rows["WB1 thesis replica mpu6500_filtered: SS10 B [cm]"]
    assert filt.ours == pytest.approx(11.46, abs=0.01) and "unfiltered under the same rules 12.1 cm" in filt.note
