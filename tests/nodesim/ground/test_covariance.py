"""ISCWSA engine: running sums against the station-pair form, properties, thesis 4.1.2 worked example."""

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from nodesim.errors import NodesimError
from nodesim.ground.covariance import Site, propagate
from nodesim.ground.derivatives import survey_derivatives
from nodesim.ground.ellipsoid import confidence_scale, ellipsoid_axes, horizontal_ellipse, nev_to_hla
from nodesim.ground.errormodel import ErrorModel, ErrorSource
from nodesim.ground.reference import propagate_pairwise
from nodesim.ground.survey import make_survey
from nodesim.ground.tools import load_tool
from nodesim.validation.checks_ground import worked_example_sigmas

surveys = st.integers(3, 12).flatmap(
    lambda n: st.tuples(
        st.lists(st.floats(0.5, 40.0), min_size=n - 1, max_size=n - 1),
        st.lists(st.floats(0.0, 120.0), min_size=n, max_size=n),
        st.lists(st.floats(0.0, 359.9), min_size=n, max_size=n),
    )
)


def _survey(parts):
    steps, inc, azi = parts
    md = np.concatenate([[0.0], np.cumsum(steps)])
    return make_survey(md, inc, azi)


@settings(max_examples=25, deadline=None)
@given(surveys, st.sampled_from(["vn100t", "mpu6500_filtered", "dip"]))
def test_running_sums_equal_station_pair_sums(parts, tool):
    s = _survey(parts)
    model = load_tool(tool)
    fast = propagate(s, model).cov_nev_m2
    slow = propagate_pairwise(s, model)
    atol = 1e-12 * max(np.abs(slow).max(), 1e-30)  # round-off of a different summation order
    np.testing.assert_allclose(fast, slow, rtol=1e-10, atol=atol)
    # and the per-source path adds up to the same total
    np.testing.assert_allclose(propagate(s, model, per_source=True).cov_nev_m2, fast, rtol=1e-10, atol=atol)


@settings(max_examples=25, deadline=None)
@given(surveys, st.floats(0.1, 10.0))
@example(([1.0] * 7 + [2.0, 3.0, 32.5], [0.0] * 11, [0.0] * 10 + [27.0]), 7.3)  # a 1e-19 round-off cross term
def test_covariance_is_psd_and_scales_with_magnitude_squared(parts, k):
    s = _survey(parts)
    model = load_tool("stim300")
    scaled = ErrorModel("x", tuple(ErrorSource(x.code, x.weight, x.magnitude * k, x.unit, x.propagation) for x in model.sources))
    c1 = propagate(s, model).cov_nev_m2
    c2 = propagate(s, scaled).cov_nev_m2
    # a cross term that is exactly 0 in one run can be 1e-20 of round-off in the other: judge the round-off
    # against the matrix scale, as the running-sum test above does
    np.testing.assert_allclose(c2, k**2 * c1, rtol=1e-9, atol=1e-12 * max(np.abs(c2).max(), 1e-30))
    eig = np.linalg.eigvalsh(c1)
    assert np.all(eig >= -1e-12 * max(1.0, np.abs(eig).max()))


def test_systematic_grows_quadratically_random_linearly():
    """A constant 0.1 deg inclination error on a 45 deg straight hole: systematic variance ~ L^2,
    random variance ~ L (thesis eqs I.16/I.17)."""
    n = 41
    s = make_survey(np.arange(n) * 10.0, np.full(n, 45.0), np.zeros(n))
    sys_ = propagate(s, ErrorModel("s", (ErrorSource("I", "INC", 0.1, "deg", "S"),))).cov_nev_m2
    rnd = propagate(s, ErrorModel("r", (ErrorSource("I", "INC", 0.1, "deg", "R"),))).cov_nev_m2
    ratio_sys = sys_[40, 0, 0] / sys_[20, 0, 0]
    ratio_rnd = rnd[40, 0, 0] / rnd[20, 0, 0]
    # the tie-on station carries no error, so the first half course (5 m) is error-free
    assert ratio_sys == pytest.approx((395.0 / 195.0) ** 2, rel=1e-9)
    assert ratio_rnd == pytest.approx(2.0, rel=0.05)
    # systematic: the position error is exactly (L - 5 m) * 0.1 deg along the high side
    assert np.sqrt(sys_[40, 0, 0] + sys_[40, 2, 2]) == pytest.approx(395 * np.radians(0.1), rel=1e-12)
    # W and G propagate like S for a single leg
    for mode in ("W", "G"):
        c = propagate(s, ErrorModel(mode, (ErrorSource("I", "INC", 0.1, "deg", mode),))).cov_nev_m2
        np.testing.assert_allclose(c, sys_)


def test_balanced_tangential_derivative_matrix_of_the_covariance_thesis():
    """SV eqs 34-38: D_mat(k) = dDr_k/dp_k + dDr_{k+1}/dp_k with columns MD, I, A."""
    s = make_survey([0, 30, 70, 100], [0, 10, 25, 30], [0, 40, 60, 65])
    d = survey_derivatives(s)
    k = 2
    i, a, md = s.inc_rad, s.azi_rad, s.md_m
    p = md[k + 1] - md[k - 1]
    expected = 0.5 * np.array(
        [
            [np.sin(i[k - 1]) * np.cos(a[k - 1]) - np.sin(i[k + 1]) * np.cos(a[k + 1]), p * np.cos(i[k]) * np.cos(a[k]), -p * np.sin(i[k]) * np.sin(a[k])],
            [np.sin(i[k - 1]) * np.sin(a[k - 1]) - np.sin(i[k + 1]) * np.sin(a[k + 1]), p * np.cos(i[k]) * np.sin(a[k]), p * np.sin(i[k]) * np.cos(a[k])],
            [np.cos(i[k - 1]) - np.cos(i[k + 1]), -p * np.sin(i[k]), 0.0],
        ]
    )
    got = np.stack([d.d_k[x][k] + d.d_k1[x][k] for x in "DIA"], axis=-1)
    np.testing.assert_allclose(got, expected, atol=1e-12)


def test_thesis_worked_example_4_1_2():
    """Thesis 4.1.2: station 2 at MD 3 m, I 5 deg, A 30 deg.  0.01 deg inclination error: N 2.259e-4,
    E 1.304e-4, TVD 2.284e-5 m; matrix route with the accelerometer bias: 0.000225, 0.0001299,
    0.00002273 m; gyro bias 0.01 deg/s over 100 s: |N| 1.141e-3, E 1.976e-3, TVD 0."""
    r = worked_example_sigmas()
    np.testing.assert_allclose(r["inclination 0.01 deg (first-principles route)"], [2.259e-4, 1.304e-4, 2.284e-5], rtol=1.2e-3)
    np.testing.assert_allclose(r["accelerometer x/y bias (matrix route)"], [2.25e-4, 1.299e-4, 2.273e-5], rtol=1e-3)
    np.testing.assert_allclose(r["z-gyro bias 0.01 deg/s over 100 s"], [1.141e-3, 1.976e-3, 0.0], rtol=1e-3, atol=1e-15)


def test_gyro_drift_error_is_linear_in_time_and_signed_like_the_thesis():
    """dA = t * bias (thesis eq 2.6): doubling the elapsed time doubles the position error; the north
    error of the worked example is negative (the thesis quotes magnitudes, digest 1.6)."""
    src = ErrorSource("G", "GYRO-DRIFT", 0.01, "deg/s", "S")
    m = ErrorModel("g", (src,))
    s1 = make_survey([0, 3], [0, 5], [0, 30], time_s=[0, 100])
    s2 = make_survey([0, 3], [0, 5], [0, 30], time_s=[0, 200])
    c1 = propagate(s1, m, method="balanced_tangential").cov_nev_m2[1]
    c2 = propagate(s2, m, method="balanced_tangential").cov_nev_m2[1]
    assert c2[0, 0] == pytest.approx(4 * c1[0, 0])
    assert c1[0, 1] < 0  # N and E errors have opposite signs: N negative, E positive


def test_hla_ellipsoid_and_confidence():
    cov = np.array([[[4.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 0.25]]])
    axes, vecs = ellipsoid_axes(cov)
    np.testing.assert_allclose(axes[0], [2.0, 1.0, 0.5])
    major, minor, azi = horizontal_ellipse(cov)
    assert (major[0], minor[0], azi[0]) == pytest.approx((2.0, 1.0, 0.0))
    hla = nev_to_hla(cov, np.radians([90.0]), np.radians([90.0]))  # horizontal, heading east
    np.testing.assert_allclose(np.diag(hla[0]), [0.25, 4.0, 1.0], atol=1e-12)  # H = up, L = south, A = east
    assert confidence_scale("1") == 1.0 and confidence_scale("2") == 2.0
    assert confidence_scale("95", 1) == pytest.approx(1.959964, rel=1e-6)
    assert confidence_scale("95", 2) == pytest.approx(2.447747, rel=1e-6)
    assert confidence_scale("95", 3) == pytest.approx(2.795483, rel=1e-6)
    with pytest.raises(NodesimError, match="sigma level"):
        confidence_scale("7")


def test_tie_on_station_has_no_error_and_tie_on_rule_only_changes_first_course():
    s = make_survey([0, 30, 60], [0, 10, 20], [0, 30, 30])
    m = ErrorModel("i", (ErrorSource("I", "INC", 0.1, "deg", "R"),))
    c = propagate(s, m).cov_nev_m2
    assert np.all(c[0] == 0)
    tie = ErrorModel("i", m.sources, surface_tie_on=True)
    c_tie = propagate(s, tie).cov_nev_m2
    assert c_tie[1, 2, 2] == pytest.approx(4 * c[1, 2, 2])  # e*_1 uses the whole first course


def test_unknown_weight_propagation_or_unit_are_clear_errors():
    with pytest.raises(NodesimError, match="unknown weighting function 'NOPE'"):
        ErrorSource("X", "NOPE", 1.0, "deg", "S")
    with pytest.raises(NodesimError, match="propagation 'Q' unknown"):
        ErrorSource("X", "AZ", 1.0, "deg", "Q")
    with pytest.raises(NodesimError, match="unit 'furlong' unknown"):
        ErrorSource("X", "AZ", 1.0, "furlong", "S")
    with pytest.raises(NodesimError, match="magnitude must be finite"):
        ErrorSource("X", "AZ", float("nan"), "deg", "S")
    with pytest.raises(NodesimError, match="duplicate source code"):
        ErrorModel("m", (ErrorSource("X", "AZ", 1, "deg", "S"), ErrorSource("X", "INC", 1, "deg", "S")))
    with pytest.raises(NodesimError, match="no source 'Y'"):
        ErrorModel("m", (ErrorSource("X", "AZ", 1, "deg", "S"),)).without("Y")


def test_site_defaults_are_iscwsa_gravity():
    assert Site().gravity_m_s2 == 9.80665


def test_survey_sigmas_enter_as_random_direct_terms():
    """A simulated filter's per-station azimuth sigma (thesis 4.2.4: 0.25 deg) carried by the survey gives
    the same covariance as an explicit random AZ term of that magnitude; varying sigmas match the
    station-pair sums."""
    md, inc, azi = [0, 20, 40, 60, 80], [0, 5, 10, 15, 20], [0, 30, 35, 40, 45]
    with_col = make_survey(md, inc, azi, sigma_azi_deg=[0.25] * 5, sigma_inc_deg=[0.01] * 5)
    plain = make_survey(md, inc, azi)
    explicit = ErrorModel("e", (ErrorSource("A", "AZ", 0.25, "deg", "R"), ErrorSource("I", "INC", 0.01, "deg", "R")))
    u = propagate(with_col, ErrorModel("none", ()))
    assert {s.code for s in u.model.sources} == {"SURVEY-INC", "SURVEY-AZ"}
    np.testing.assert_allclose(u.cov_nev_m2, propagate(plain, explicit).cov_nev_m2, rtol=1e-12)
    varying = make_survey(md, inc, azi, sigma_azi_deg=[0, 0.1, 0.5, 1.0, 0.2])
    np.testing.assert_allclose(
        propagate(varying, ErrorModel("none", ())).cov_nev_m2, propagate_pairwise(varying, ErrorModel("none", ())), rtol=1e-12
    )
    with pytest.raises(NodesimError, match="station 2: sigma_azi_deg -1 must be finite and >= 0"):
        make_survey(md, inc, azi, sigma_azi_deg=[0, -1, 0, 0, 0])
    with pytest.raises(NodesimError, match="sigma_inc_deg has 2 values for 5 stations"):
        make_survey(md, inc, azi, sigma_inc_deg=[0, 1])
