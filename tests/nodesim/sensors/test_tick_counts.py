"""The per-tick count sums of nodesim.sensors.tick_counts / chain_imu: tick_sum agrees in distribution with
per_sample (chi-square on 10^5 tick sums per case), clipping is counted, and the chain reads them."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.stats import chi2_contingency

from nodesim.chain.network import simulate_chain
from nodesim.chain.metrics import per_realization_metrics, summarize
from nodesim.errors import NodesimError, ScenarioError
from nodesim.scenario.schema import Scenario
from nodesim.sensors import tick_counts as tc
from nodesim.sensors.chain_imu import ChainImu

N_SUMS = 100_000


def _per_sample(rng, mu, sigma, n, lo, hi, sums=N_SUMS):
    w = rng.standard_normal((sums * n, 1))
    s, clipped = tc.per_sample_sums(np.full((sums * n, 1), mu), sigma, w, np.full(sums, n), lo, hi)
    return s[:, 0], clipped


def _direct(rng, mu, sigma, n, sums=N_SUMS):
    return tc.tick_sum_draw(np.full(sums, n * mu), n, sigma, rng.standard_normal(sums))


def _same_distribution(a, b) -> float:
    """p-value of a chi-square two-sample test on bins of >= ~50 expected counts each."""
    both = np.concatenate([a, b])
    edges = np.unique(np.quantile(both, np.linspace(0, 1, 41)))
    edges[-1] += 1
    ca, _ = np.histogram(a, edges)
    cb, _ = np.histogram(b, edges)
    keep = (ca + cb) > 0
    return chi2_contingency(np.stack([ca[keep], cb[keep]]))[1]


@pytest.mark.parametrize("mu, sigma, n", [(4454.3, 7.8, 34), (-12.61, 1.0, 35), (16384.25, 28.0, 34),
                                          (0.5, 0.8, 34), (1000.0, 3.5, 100)])
def test_tick_sum_agrees_with_per_sample_in_distribution(mu, sigma, n):
    rng = np.random.default_rng(19)
    a, clipped = _per_sample(rng, mu, sigma, n, -32768, 32767)
    b = _direct(rng, mu, sigma, n)
    assert clipped.sum() == 0
    assert _same_distribution(a, b) > 1e-3
    assert a.mean() == pytest.approx(n * mu, abs=5 * math.sqrt(n * (sigma**2 + 1 / 12) / N_SUMS))
    assert a.var() == pytest.approx(n * (sigma**2 + 1 / 12), rel=0.03)


def test_the_test_detects_a_wrong_variance():
    """The chi-square above can fail: a direct draw without the q^2/12 term at sigma = 0.3 LSB is rejected."""
    rng = np.random.default_rng(3)
    a, _ = _per_sample(rng, 0.5, 0.3, 34, -32768, 32767)
    b = np.rint(34 * 0.5 + math.sqrt(34) * 0.3 * rng.standard_normal(N_SUMS))
    assert _same_distribution(a, b) < 1e-6


def test_near_full_scale_falls_back_and_per_sample_clips():
    """At |mu| + 5 sigma >= full scale the direct draw is not valid; the per-sample sums clip at 32750 (250 deg/s x
    131) and count every clipped reading; the direct draw there would be wrong (mean past the clip)."""
    lo, hi = tc.count_limits(250 * 131.0)
    assert (lo, hi) == (-32750, 32750)
    assert not tc.tick_sum_valid(np.array(32740.0), 7.8, lo, hi)
    assert tc.tick_sum_valid(np.array(32700.0), 7.8, lo, hi)
    assert not tc.tick_sum_valid(np.array(0.0), 0.5, lo, hi)  # sigma below 0.8 LSB
    rng = np.random.default_rng(5)
    a, clipped = _per_sample(rng, 32745.0, 7.8, 34, lo, hi, sums=20_000)
    assert a.max() <= 34 * hi and clipped.sum() > 0
    assert a.mean() < 34 * 32745.0 - 34  # clipping pulls the sum below n mu
    b = _direct(rng, 32745.0, 7.8, 34, sums=20_000)
    assert _same_distribution(a, b) < 1e-6


@settings(max_examples=40, deadline=None)
@given(st.floats(0.0, 40000.0), st.floats(0.0, 40000.0), st.floats(0.8, 30.0))
def test_clipped_count_is_monotone_in_the_rate_and_zero_inside_the_range(mu1, mu2, sigma):
    lo, hi = tc.count_limits(250 * 131.0)
    w = np.random.default_rng(0).standard_normal((340, 1))
    c = [tc.per_sample_sums(np.full((340, 1), m), sigma, w, np.full(10, 34), lo, hi)[1].sum() for m in (mu1, mu2)]
    if mu1 <= mu2:
        assert c[0] <= c[1]
    if max(mu1, mu2) + 6 * sigma < hi:
        assert c[0] == 0 and c[1] == 0


def test_sample_windows_count_the_samples_since_the_last_tick():
    t = np.arange(10) / 1.9 + 0.06
    first, n = tc.sample_windows(t, 1 / 1.9, 65.0)
    assert n.sum() == np.floor(t[-1] * 65) - np.floor((t[0] - 1 / 1.9) * 65)
    assert set(n) <= {34, 35}
    assert np.all(first[1:] == first[:-1] + n[:-1])
    with pytest.raises(NodesimError, match="sample_rate_hz"):
        tc.sample_windows(t, 1 / 1.9, 1.0)


def test_sample_windows_equal_the_floors_of_the_tick_edges_on_random_clocks():
    """The compiled pass gives what its definition gives in numpy, floor(edges rate) with edges (t_0 - dt, t_0, ...),
    for clocks of random offset, period, length and sample rate; a tick with no sample is refused."""
    rng = np.random.default_rng(20)
    refused = 0
    for _ in range(300):
        dt, rate = rng.uniform(0.01, 2.0), float(rng.choice([65.0, 100.0, 1000.0, 64.9999, 3.3]))
        t = rng.uniform(-5.0, 500.0) + np.arange(int(rng.integers(1, 3000))) * dt
        last = np.floor(np.concatenate([[t[0] - dt], t]) * rate).astype(np.int64)
        if np.diff(last).min() < 1:
            refused += 1
            with pytest.raises(NodesimError, match="reads no sensor sample"):
                tc.sample_windows(t, dt, rate)
            continue
        first, n = tc.sample_windows(t, dt, rate)
        assert np.array_equal(first, last[:-1] + 1) and np.array_equal(n, np.diff(last))
    assert 0 < refused < 300


def test_mpu6500_sensitivities_follow_the_ranges():
    for dps, lsb in ((250, 131.0), (500, 65.5), (1000, 32.8), (2000, 16.4)):
        assert ChainImu.from_scenario(Scenario().with_overrides(**{"sensor.gyro_full_scale_dps": dps})).gyro_lsb_per_deg_s == lsb
    for g, lsb in ((2, 16384.0), (4, 8192.0), (8, 4096.0), (16, 2048.0)):
        assert ChainImu.from_scenario(Scenario().with_overrides(**{"sensor.accel_full_scale_g": g})).accel_lsb_per_g == lsb
    imu = ChainImu.from_scenario(Scenario())
    assert imu.gyro_sigma_lsb == pytest.approx(7.38e-3 * math.sqrt(65) * 131, rel=1e-12)  # ~7.8 LSB: tick_sum valid


@pytest.mark.parametrize("key, value", [("sensor.gyro_full_scale_dps", 300), ("sensor.accel_full_scale_g", 3),
                                        ("sensor.sampling", "fifo"), ("sensor.sample_rate_hz", 0.0),
                                        ("sensor.sample_rate_hz", 1e5), ("sensor.residual_tilt_sigma_deg", -0.1),
                                        ("sensor.residual_tilt_sigma_deg", 11.0)])
def test_sensor_keys_reject_out_of_range_values(key, value):
    with pytest.raises(ScenarioError, match=key.split(".")[1]):
        Scenario().with_overrides(**{key: value})


def test_defaults_cite_the_thesis():
    s = Scenario().sensor
    assert (s.gyro_full_scale_dps, s.accel_full_scale_g, s.sampling, s.sample_rate_hz) == (250, 2, "tick_sum", 65.0)
    assert s.residual_tilt_sigma_deg == 0.0422  # thesis table 4.20


def _run(**over):
    s = Scenario().with_overrides(**{"sensor.model": "mpu6500_counts", "simulation.realizations": 4, "simulation.duration_s": 120.0,
                                     "metrics.window_start_s": 60.0, "metrics.window_end_s": 120.0, **over})
    return s, simulate_chain(s)


def test_chain_signals_are_the_counts_in_si_and_deterministic():
    s, run = _run()
    _, again = _run()
    n = run.nodes[0]
    assert np.array_equal(n.gyro_rad_s, again.nodes[0].gyro_rad_s)
    assert np.array_equal(n.specific_force, again.nodes[0].specific_force)
    assert np.all(n.adc_clipped_samples == 0)


def test_tick_sum_and_per_sample_read_the_same_sensor_on_the_chain():
    """Mean tick gyro and inclination agree between the modes within their noise (16 realizations x 228 ticks)."""
    _, a = _run(**{"simulation.realizations": 16})
    _, b = _run(**{"simulation.realizations": 16, "sensor.sampling": "per_sample"})
    ga, gb = a.nodes[0].gyro_rad_s, b.nodes[0].gyro_rad_s
    se = math.sqrt(2 / ga.size) * ga.std()
    assert abs(ga.mean() - gb.mean()) < 5 * se
    assert ga.std() == pytest.approx(gb.std(), rel=0.05)


def test_azimuth_error_grows_with_the_residual_tilt():
    """A sensor-frame tilt eps moves the measured high side by eps: at 2 deg inclination the azimuth error is about
    eps / sin(2 deg) (thesis eq 1.3), so the RMS azimuth error grows with residual_tilt_sigma_deg and at the thesis's
    0.0422 deg (table 4.20) dominates the accelerometer-noise floor (~0.085 deg).  Window well after the rotation."""
    quiet = {"sensor.model": "mpu6500_counts", "simulation.realizations": 16, "simulation.duration_s": 300.0, "motion.slow_turns": 0.0,
             "motion.fast_turns": 0.0, "metrics.window_start_s": 150.0, "metrics.window_end_s": 300.0}
    azi = []
    for tilt in (0.0, 0.0422, 0.2):
        s = Scenario().with_overrides(**{**quiet, "sensor.residual_tilt_sigma_deg": tilt})
        azi.append(summarize(per_realization_metrics(simulate_chain(s), s.metrics))["rms_azimuth_error_deg"])
    assert azi[0] < azi[1] < azi[2]
    assert azi[1] > 0.0422 / math.sin(math.radians(2.0)) / 3  # ~1.2 deg expected: tilt-dominated
    assert azi[2] == pytest.approx(0.2 / math.sin(math.radians(2.0)), rel=0.5)


@settings(max_examples=50, deadline=None)
@given(st.floats(0.0, 3.2), st.floats(0.0, 6.3), st.floats(-1e3, 1e3))
def test_sensor_force_is_the_body_frame_gravity(inc, azi, yaw):
    from nodesim.sensors.sample_truth import sensor_force
    from nodesim.sensors.magnetometer import specific_force_body

    assert np.allclose(sensor_force(inc, azi, yaw), specific_force_body(inc, azi, yaw), rtol=0, atol=1e-12)


def test_the_alignment_offset_removes_the_residual_tilt_on_the_lab_profile():
    """Thesis 4.2.3: (max + min) / 2 of the transverse axes over the two slow calibration turns, subtracted from
    every later reading (firmware.alignment): with a 0.2 deg residual tilt (~5.7 deg of azimuth at 2 deg
    inclination without it) the error after the rotation falls back to within the alignment's own noise of the
    untilted run; 'none' keeps the tilt; the fixed firmware does the same in integers."""
    base = {"sensor.model": "mpu6500_counts", "simulation.realizations": 8, "motion.fast_turns": 0.0, "simulation.duration_s": 400.0,
            "metrics.window_start_s": 300.0, "metrics.window_end_s": 400.0}

    def azi(**over):
        s = Scenario().with_overrides(**{**base, **over})
        return summarize(per_realization_metrics(simulate_chain(s), s.metrics))["rms_azimuth_error_deg"]

    untilted = azi(**{"sensor.residual_tilt_sigma_deg": 0.0, "firmware.alignment": "none"})
    tilted = azi(**{"sensor.residual_tilt_sigma_deg": 0.2, "firmware.alignment": "none"})
    aligned = azi(**{"sensor.residual_tilt_sigma_deg": 0.2})  # auto: the lab's slow rotation
    aligned_fixed = azi(**{"sensor.residual_tilt_sigma_deg": 0.2, "filter.implementation": "fixed"})
    assert tilted > 2.0 and untilted < 0.2
    assert aligned < 1.5 * untilted and aligned_fixed < 1.5 * untilted
    assert aligned_fixed == pytest.approx(aligned, abs=0.01)


def test_alignment_key_is_checked_and_auto_follows_the_motion():
    from nodesim.chain.estimator import alignment_window_s

    s = Scenario().with_overrides(**{"sensor.model": "mpu6500_counts"})
    assert alignment_window_s(s) == pytest.approx((50.0, 250.0))  # 2 turns at 3.6 deg/s after 50 s static
    assert alignment_window_s(s.with_overrides(**{"firmware.alignment": "none"})) is None
    assert alignment_window_s(s.with_overrides(**{"motion.slow_turns": 0.5})) is None  # auto: no full turn
    assert alignment_window_s(s.with_overrides(**{"motion.kind": "drilling"})) is None  # auto: no slow rotation
    with pytest.raises(ScenarioError, match="firmware.alignment"):
        s.with_overrides(**{"motion.slow_turns": 0.5, "firmware.alignment": "slow_rotation"})
    with pytest.raises(ScenarioError, match="alignment"):
        s.with_overrides(**{"firmware.alignment": "max_min"})
