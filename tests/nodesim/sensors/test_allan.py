"""Allan variance: estimator against a naive reference, closed loop on a simulated MPU6500 (thesis table V.1)."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from nodesim.sensors.allan import FLICKER_FLOOR_FACTOR, naive_overlapping_adev, overlapping_adev, plot_adev, read_noise
from nodesim.errors import NodesimError
from nodesim.sensors.catalogue import load_sensor
from nodesim.units import DEG


def test_cumsum_estimator_equals_naive_cluster_means():
    y = np.random.default_rng(3).standard_normal(400)
    clusters = np.array([1, 2, 3, 7, 20, 50, 133, 200])
    fast = overlapping_adev(y, 0.1, clusters)
    assert np.allclose(fast.adev, naive_overlapping_adev(y, 0.1, clusters), rtol=1e-10)
    assert np.allclose(fast.tau_s, clusters * 0.1)


def test_flicker_floor_factor_is_eq_v34_plateau():
    assert math.isclose(FLICKER_FLOOR_FACTOR, 0.6643, abs_tol=1e-4)


def test_error_of_estimate_eq_v30():
    curve = overlapping_adev(np.random.default_rng(0).standard_normal(1000), 1.0, np.array([1, 10, 100]))
    assert np.allclose(curve.relative_error, 1 / np.sqrt(2 * (1000 / np.array([1, 10, 100]) - 1)))


@settings(max_examples=25, deadline=None)
@given(st.floats(1e-3, 1e3), st.integers(0, 2**32 - 1))
def test_adev_scales_linearly_with_the_signal(scale, seed):
    y = np.random.default_rng(seed).standard_normal(300)
    a = overlapping_adev(y, 0.5).adev
    assert np.allclose(overlapping_adev(scale * y, 0.5).adev, scale * a, rtol=1e-9)


def test_white_noise_has_slope_minus_half_and_adev_n_over_sqrt_tau():
    n_density, dt = 0.02, 0.01
    y = n_density / math.sqrt(dt) * np.random.default_rng(1).standard_normal(200_000)
    curve = overlapping_adev(y, dt)
    ok = curve.relative_error < 0.05
    assert np.allclose(curve.adev[ok], n_density / np.sqrt(curve.tau_s[ok]), rtol=0.12)


@pytest.mark.parametrize("axis,arw_deg,bs_deg", [(0, 8.9e-3, 7.9e-3), (1, 6.9e-3, 3.83e-3), (2, 7.38e-3, 3.33e-3)])
def test_closed_loop_mpu6500_2h_65hz_recovers_table_v1_within_10_percent(axis, arw_deg, bs_deg):
    """Thesis appendix V / table V.1: 2 h static MPU6500 log at 65 Hz; simulate it, read ARW and bias stability."""
    imu = load_sensor("MPU6500").imu_spec()
    assert imu.sample_rate_hz == 65.0
    k = int(7200 * imu.sample_rate_hz) + 1
    samples = imu.gyro.measure(np.zeros((k, 3)), np.random.default_rng(2026 + axis), imu.dt_s)
    noise = read_noise(overlapping_adev(samples.value[:, axis], imu.dt_s))
    assert noise.arw / DEG == pytest.approx(arw_deg, rel=0.10)
    # configured coefficient B = table value / 0.664; the tool returns B
    assert noise.bias_instability * FLICKER_FLOOR_FACTOR / DEG == pytest.approx(bs_deg, rel=0.10)


def test_bad_input_is_rejected():
    with pytest.raises(NodesimError, match="not finite"):
        overlapping_adev(np.array([1.0, np.nan, 2.0, 3.0]), 1.0)
    with pytest.raises(NodesimError, match="dt_s"):
        overlapping_adev(np.ones(10), 0.0)
    with pytest.raises(NodesimError, match="at least 3"):
        overlapping_adev(np.ones(2), 1.0)
    with pytest.raises(NodesimError, match="cluster sizes"):
        overlapping_adev(np.ones(10), 1.0, np.array([6]))


def test_plot_writes_png(tmp_path):
    curve = overlapping_adev(np.random.default_rng(0).standard_normal(2000), 0.1)
    plot_adev({"white": curve}, tmp_path / "adev.png")
    assert (tmp_path / "adev.png").read_bytes()[:4] == b"\x89PNG"


def test_overlapping_adev_equals_allantools_oadev():
    """allantools (an independent implementation, pyproject [test] extra) gives the same overlapping Allan
    deviation of a white + random-walk rate series at every cluster size (IEEE Std 952, eq. of oadev)."""
    allantools = pytest.importorskip("allantools")
    rng = np.random.default_rng(5)
    dt_s = 0.01
    rate = rng.normal(0.0, 1.0, 20_000) + np.cumsum(rng.normal(0.0, 0.002, 20_000))
    ours = overlapping_adev(rate, dt_s)
    taus, adev, _, _ = allantools.oadev(rate, rate=1.0 / dt_s, data_type="freq", taus=ours.tau_s)
    # allantools stops one cluster size earlier (it needs m < N/2 where eq V.29 allows m = N/2)
    common = np.isin(np.round(ours.tau_s / dt_s), np.round(taus / dt_s))
    assert common.sum() == taus.size >= ours.tau_s.size - 1
    assert np.allclose(adev, ours.adev[common], rtol=1e-9)


@pytest.mark.parametrize("name,axis", [("MPU6500", 2), ("VN-100T", 2)])
def test_allantools_is_an_independent_oracle_of_the_allan_validation_rows(name, axis):
    """The Allan rows of ``nodesim validate`` (self-consistency: table V.1 in, table V.1 read back) rest on our
    own Allan deviation.  allantools' oadev of the very series those rows read (the simulated 2 h static gyro,
    468 001 samples at 65 Hz for the MPU6500, 288 001 at 40 Hz for the VN-100T) agrees with ours to rel 1e-9 at
    every common cluster size, and the noise terms read from allantools' curve equal ours to rel 1e-9."""
    allantools = pytest.importorskip("allantools")
    from nodesim.sensors.allan import AllanCurve
    from nodesim.validation.checks_sensors import RECORD_S, allan_static_log

    samples, dt_s = allan_static_log(name)
    rate = samples[:, axis]
    assert rate.size == int(RECORD_S / dt_s) + 1 > 250_000
    ours = overlapping_adev(rate, dt_s)
    taus, adev, _, _ = allantools.oadev(rate, rate=1.0 / dt_s, data_type="freq", taus=ours.tau_s)
    common = np.isin(np.round(ours.tau_s / dt_s), np.round(taus / dt_s))
    assert common.sum() == taus.size >= ours.tau_s.size - 1  # allantools needs m < N/2, ours allows m = N/2
    assert np.allclose(adev, ours.adev[common], rtol=1e-9, atol=0.0)
    oracle = AllanCurve(tau_s=taus, adev=adev, clusters=ours.clusters[common], n_samples=rate.size)
    ours_noise, oracle_noise = read_noise(ours), read_noise(oracle)
    assert oracle_noise.arw == pytest.approx(ours_noise.arw, rel=1e-9)
    assert oracle_noise.bias_instability == pytest.approx(ours_noise.bias_instability, rel=1e-9)
