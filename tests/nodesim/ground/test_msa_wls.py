"""WLS estimate (SV Ch 4, Table 7) and covariance-method propagation (SV Ch 5, Tables 10-11)."""

import numpy as np
import pytest

from nodesim.errors import NodesimError
from nodesim.ground.magnetic_survey import FieldReference, apply_errors, params_array, tool_readings
from nodesim.ground.msa_surveys import published_numbers, trajectory
from nodesim.ground.wls import covariance_position, design_matrix, parameter_error_model, wls_estimate

REF = FieldReference(51.0, 72.0)
PUB = published_numbers()


def clean(name):
    t = trajectory(name)
    return t, tool_readings(t.toolface_deg, t.inc_deg, t.azi_deg, REF)[1]


@pytest.mark.parametrize("name", ["sv2", "sv3"])
def test_sv_table7_wls_estimate_and_3_sigma_to_printed_digits(name):
    """SV Table 7, tests 2 and 3: estimates and 3 sqrt(diag U) to the 4 printed decimals."""
    p = PUB["sv_wls_table7"][name]
    _, b = clean(name)
    res = wls_estimate(b, apply_errors(b, params_array(p["truth_scale"], p["truth_bias_ut"])))
    ours = np.concatenate([res.bias_ut, res.scale])
    np.testing.assert_allclose(np.round(ours, 4), p["estimate"], atol=1e-12)
    np.testing.assert_allclose(np.round(3 * res.sigma, 4), p["three_sigma"], atol=1e-12)


def test_sv_table7_test4_3_sigma():
    """SV Table 7, test 4: U does not depend on the measurements, so 3 sigma reproduces from the trajectory alone."""
    _, b = clean("sv4")
    res = wls_estimate(b, b)
    np.testing.assert_allclose(np.round(3 * res.sigma, 4), PUB["sv_wls_table7"]["sv4"]["three_sigma"], atol=1e-12)


def test_sv_table7_test1_not_reproduced():
    """SV Table 7 T1 is not reproduced with the Table 5 inputs (digest 14): measured gap kept as a record."""
    p = PUB["sv_wls_table7"]["sv1"]
    _, b = clean("sv1")
    res = wls_estimate(b, apply_errors(b, params_array(p["truth_scale"], p["truth_bias_ut"])))
    assert res.bias_ut[2] == pytest.approx(1.9900, abs=1e-4)  # SV prints 0.1787
    assert abs(res.bias_ut[2] - p["estimate"][2]) > 1.0


def test_information_form_equals_gain_form():
    """U H^T R^-1 dy (ours) == P H^T (H P H^T + R)^-1 dy (SV eq 19 as printed): matrix inversion lemma."""
    _, b = clean("sv2")
    dy_m = apply_errors(b, params_array([1.01, 0.99, 1.02], [0.1, -0.2, 0.3]))
    res = wls_estimate(b, dy_m, noise_ut=0.05)
    h = design_matrix(b)
    p = np.diag([0.07**2] * 3 + [0.0016**2] * 3)
    gain = p @ h.T @ np.linalg.solve(h @ p @ h.T + 0.05**2 * np.eye(h.shape[0]), (dy_m - b).ravel())
    np.testing.assert_allclose(res.dx, gain, rtol=1e-9, atol=1e-12)


def test_wls_prior_limit():
    """With a very loose prior and tiny noise WLS returns the exact errors (noise-free data)."""
    _, b = clean("sv3")
    truth = params_array([1.05, 0.97, 1.1], [0.2, -0.1, 0.4])
    res = wls_estimate(b, apply_errors(b, truth), sigma_bias_ut=1e3, sigma_scale=1e3, noise_ut=1e-6)
    np.testing.assert_allclose(np.concatenate([res.bias_ut, res.scale]), truth, atol=1e-6)


@pytest.mark.parametrize("name", ["sv1", "sv2", "sv3", "sv4"])
def test_sv_covariance_ratio_and_gap(name):
    """SV Tables 10/11: the systematic/random ratio matches within the input rounding (5 %); the absolute
    3-sigma values are 10-32 % below SV's (unexplained, digest 14): both recorded."""
    p = PUB["sv_covariance"][name]
    t = trajectory(name)
    sig = np.array(p["table5_three_sigma"]) / 3
    r = 3 * np.sqrt(np.diag(covariance_position(t.md_m, t.inc_deg, t.azi_deg, sig, REF, "R")[-1]))
    s = 3 * np.sqrt(np.diag(covariance_position(t.md_m, t.inc_deg, t.azi_deg, sig, REF, "S")[-1]))
    assert s[0] / r[0] == pytest.approx(p["systematic"][0] / p["random"][0], rel=0.05)
    for ours, theirs in ((r[0], p["random"][0]), (s[0], p["systematic"][0])):
        assert 0.70 < ours / theirs < 0.92


def test_systematic_exceeds_random_and_is_linear_in_sigma():
    t = trajectory("sv2")
    sig = np.array([0.02, 0.02, 1.0, 0.01, 0.01, 0.03])
    r = covariance_position(t.md_m, t.inc_deg, t.azi_deg, sig, REF, "R")[-1]
    s = covariance_position(t.md_m, t.inc_deg, t.azi_deg, sig, REF, "S")[-1]
    s2 = covariance_position(t.md_m, t.inc_deg, t.azi_deg, 2 * sig, REF, "S")[-1]
    assert s[0, 0] > r[0, 0] and s[1, 1] > r[1, 1]
    np.testing.assert_allclose(s2, 4 * s, rtol=1e-12)


def test_bad_input():
    _, b = clean("sv2")
    with pytest.raises(NodesimError, match="noise_ut"):
        wls_estimate(b, b, noise_ut=0.0)
    with pytest.raises(NodesimError, match="stations >= 2"):
        wls_estimate(b[:1], b[:1])
    bad = b.copy()
    bad[0, 0] = np.nan
    with pytest.raises(NodesimError, match="station 1"):
        wls_estimate(bad, b)
    with pytest.raises(NodesimError, match="sigma_theta"):
        parameter_error_model([1, 2, 3], "R")
    t = trajectory("sv2")
    with pytest.raises(NodesimError, match="propagation"):
        covariance_position(t.md_m, t.inc_deg, t.azi_deg, np.ones(6), REF, "G")


def test_wls_sigmas_propagate_to_position():
    """Item 4: WLS parameter sigmas through the covariance method; systematic > random, both finite."""
    p = PUB["sv_wls_table7"]["sv2"]
    t, b = clean("sv2")
    res = wls_estimate(b, apply_errors(b, params_array(p["truth_scale"], p["truth_bias_ut"])))
    r = covariance_position(t.md_m, t.inc_deg, t.azi_deg, res.sigma, REF, "R")
    s = covariance_position(t.md_m, t.inc_deg, t.azi_deg, res.sigma, REF, "S")
    assert r.shape == (len(t), 3, 3) and np.all(np.isfinite(s))
    assert s[-1, 0, 0] > r[-1, 0, 0] > 0
