"""Monte Carlo of MSA + MCM against HV Table 9 (scenario 1) and Table 11 (scenario 3); vectorisation, progress."""

import numpy as np
import pytest

from nodesim.errors import NodesimError
from nodesim.ground.magnetic_survey import FieldReference, params_array
from nodesim.ground.msa_montecarlo import HV_SCENARIOS, MonteCarloConfig, run_monte_carlo, run_monte_carlo_loop
from nodesim.ground.msa_surveys import published_numbers, trajectory
from nodesim.validation.checks_magnetic import mc_tolerance

REF = FieldReference(51.0, 72.0)
TRUTH = params_array([1.1, 0.95, 1.25], [0.25, 0.295, -0.335])
PUB = published_numbers()
M_TEST = 600


def run(name, scenario=1, m=M_TEST, seed=21, **kw):
    cfg = MonteCarloConfig(**{**HV_SCENARIOS[scenario].__dict__, "replications": m, "seed": seed, **kw})
    return run_monte_carlo(trajectory(name), REF, TRUTH, cfg, progress=False)


@pytest.mark.parametrize("name", ["hv1", "hv2", "hv4", "hv5", "hv6"])
def test_hv_table9_final_position_1_96_sigma(name):
    """HV Table 9: N and E 1.96-sigma within 3 standard errors of the ratio of two sample stds (M = 600 vs 300)."""
    res = run(name)
    tol = mc_tolerance(M_TEST, 300)
    published = PUB["hv_table9"][name]["position"]
    for idx in (0, 1):
        assert res.position_spread_m[idx] == pytest.approx(published[idx], rel=tol), (name, idx)
    assert res.converged.all()


def test_hv_table9_survey1_parameters():
    """HV Table 9, Survey 1: 1.96-sigma of the three biases and three scales."""
    res = run("hv1")
    pub = PUB["hv_table9"]["hv1"]
    np.testing.assert_allclose(res.theta_spread, pub["bias"] + pub["scale"], rtol=mc_tolerance(M_TEST, 300))
    assert np.abs(res.theta.mean(axis=0) - TRUTH).max() < 0.01  # unbiased


def test_hv_table11_scenario3_survey1():
    """HV Table 11: the dip error dominates (57 m North at 1.96 sigma instead of 0.31 m)."""
    res = run("hv1", scenario=3)
    pub = PUB["hv_table11"]["hv1"]
    tol = mc_tolerance(M_TEST, 300)
    assert res.position_spread_m[0] == pytest.approx(pub[0], rel=tol)
    assert res.position_spread_m[1] == pytest.approx(pub[1], rel=tol)


def test_ill_conditioned_surveys_documented_gap():
    """HV S3/S7 (scenario 1) are not reproduced: with several starts ours are far smaller than HV's 5.77/61.6 m.

    Measured gap recorded here (HV's GRG stops early on these nearly singular problems, digest 14)."""
    s3 = run("hv3", m=300, n_starts=4)
    s7 = run("hv7", m=300, n_starts=4)
    assert 1.5 < s3.position_spread_m[0] < 5.77 / 1.3  # ours ~2.8-3.2 m
    assert 2.0 < s7.position_spread_m[0] < 61.55 / 5  # ours ~3.8 m


def test_single_start_hits_the_local_minimum_on_survey3():
    """Digest 6.4: single starts on S3 sometimes end in a spurious minimum; multi-start removes the outliers."""
    one = run("hv3", m=300, n_starts=1)
    four = run("hv3", m=300, n_starts=4)
    assert one.position_spread_m[0] > 5 * four.position_spread_m[0]
    assert one.cost.max() > 10 * four.cost.max()


def test_vectorised_equals_per_replication_loop():
    cfg = MonteCarloConfig(replications=20, n_starts=2, seed=4, sigma_b_nt=107.0, sigma_dip_deg=0.16)
    vec = run_monte_carlo(trajectory("hv5"), REF, TRUTH, cfg, progress=False)
    loop = run_monte_carlo_loop(trajectory("hv5"), REF, TRUTH, cfg)
    np.testing.assert_allclose(vec.final_nev_m, loop.final_nev_m, rtol=0, atol=1e-9)
    np.testing.assert_allclose(vec.theta, loop.theta, rtol=0, atol=1e-12)


def test_deterministic_and_seed_dependent():
    a, b, c = run("hv2", m=50, seed=1), run("hv2", m=50, seed=1), run("hv2", m=50, seed=2)
    np.testing.assert_array_equal(a.final_nev_m, b.final_nev_m)
    assert not np.array_equal(a.final_nev_m, c.final_nev_m)
    assert a.as_dict() == b.as_dict()


def test_spread_scales_with_noise():
    """Physics: with no reference error the spread is linear in the noise (small-noise regime)."""
    lo = run("hv1", m=200, seed=3, noise_nt=1.0)
    hi = run("hv1", m=200, seed=3, noise_nt=4.0)
    assert hi.position_spread_m[0] / lo.position_spread_m[0] == pytest.approx(4.0, rel=0.02)


def test_k_sigma_and_sampling_error():
    res = run("hv1", m=51, k_sigma=3.0)
    assert res.position_spread_m[0] == pytest.approx(3.0 * np.std(res.final_nev_m[:, 0], ddof=1))
    assert res.sampling_rel_error == pytest.approx(0.1)


def test_no_progress_output_when_not_a_tty(capsys):
    cfg = MonteCarloConfig(replications=10, chunk=3)
    run_monte_carlo(trajectory("hv1"), REF, TRUTH, cfg)
    out = capsys.readouterr()
    assert out.out == "" and out.err == ""


def test_progress_bar_when_asked(capsys):
    run_monte_carlo(trajectory("hv1"), REF, TRUTH, MonteCarloConfig(replications=10, chunk=5), progress=True)
    out = capsys.readouterr()
    assert "10/10" in out.err and out.out == ""  # the bar is on stderr: stdout stays for results


@pytest.mark.parametrize(
    "kw, key",
    [({"replications": 1}, "replications"), ({"noise_nt": -1.0}, "noise_nt"), ({"sigma_dip_deg": np.nan}, "sigma_dip_deg"), ({"k_sigma": 0.0}, "k_sigma")],
)
def test_bad_config(kw, key):
    with pytest.raises(NodesimError, match=key):
        MonteCarloConfig(**kw)


def test_bad_truth():
    with pytest.raises(NodesimError, match="truth"):
        run_monte_carlo(trajectory("hv1"), REF, [0, 0, 0, 1, 1], MonteCarloConfig(replications=2))
