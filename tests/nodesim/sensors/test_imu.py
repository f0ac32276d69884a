"""Full IMU model: quantisation, clipping, misalignment, temperature, noise statistics, per-tick averaging, catalogue."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from nodesim.errors import NodesimError
from nodesim.sensors import noise
from nodesim.sensors.catalogue import available_sensors, build_imu_spec, iscwsa_from_datasheet, load_sensor
from nodesim.sensors.imu import TriadSpec, average_per_tick
from nodesim.units import DEG, G0_M_S2

MPU = load_sensor("MPU6500")


def _quiet_gyro(**kw):
    base = dict(name="g", full_scale=250 * DEG, lsb_per_unit=131 / DEG)
    base.update(kw)
    return TriadSpec(**base)


def test_mpu6500_defaults_131_lsb_per_deg_s_and_16384_lsb_per_g():
    imu = MPU.imu_spec()
    assert math.isclose(imu.gyro.lsb_per_unit * DEG, 131.0)
    assert math.isclose(imu.accel.lsb_per_unit * G0_M_S2, 16384.0)
    g = _quiet_gyro().measure(np.array([[1.0, -2.0, 0.5]]) * DEG, np.random.default_rng(0), 0.01)
    assert g.counts.dtype == np.int16
    assert g.counts.tolist() == [[131, -262, 66]]  # 65.5 rounds to even
    assert np.allclose(g.value, g.counts / 131 * DEG)


def test_full_scale_clipping_and_int16_range():
    g = _quiet_gyro().measure(np.array([[300.0, -400.0, 249.0]]) * DEG, np.random.default_rng(0), 0.01)
    assert g.counts.tolist() == [[32750, -32750, 32619]]
    acc = TriadSpec("a", full_scale=2 * G0_M_S2, lsb_per_unit=16384 / G0_M_S2)
    a = acc.measure(np.array([[3 * G0_M_S2, -3 * G0_M_S2, 0.0]]), np.random.default_rng(0), 0.01)
    assert a.counts.tolist() == [[32767, -32768, 0]]


@settings(max_examples=30, deadline=None)
@given(st.floats(-240, 240), st.floats(-240, 240), st.floats(-240, 240))
def test_quantisation_error_at_most_half_an_lsb(x, y, z):
    spec = _quiet_gyro()
    true = np.array([[x, y, z]]) * DEG
    out = spec.measure(true, np.random.default_rng(0), 0.01)
    assert np.all(np.abs(out.value - true) <= 0.5 * spec.lsb + 1e-15)


def test_misalignment_bias_and_temperature_enter_the_deterministic_part():
    m = np.array([[1.01, 0.002, 0.0], [0.0, 0.99, -0.003], [0.001, 0.0, 1.0]])
    spec = TriadSpec("a", full_scale=20.0, lsb_per_unit=1e3, misalignment=m, bias=[0.1, -0.2, 0.3],
                     bias_temp_coeff=[0.01, 0.0, 0.0], scale_temp_coeff=1e-3)
    u = np.array([[1.0, 2.0, -3.0]])
    assert np.allclose(spec.deterministic(u), m @ u[0] + [0.1, -0.2, 0.3])
    hot = spec.deterministic(u, temperature_c=np.array([35.0]))
    assert np.allclose(hot, (1 + 0.01) * (m @ u[0]) + [0.1, -0.2, 0.3] + [0.1, 0.0, 0.0])


def test_gauss_markov_stationary_variance_and_correlation():
    rng = np.random.default_rng(5)
    x = noise.gauss_markov(rng, (400, 2000), 2.0, 10.0, 1.0)
    assert np.var(x) == pytest.approx(4.0, rel=0.05)
    lag = np.mean(x[:, 10:] * x[:, :-10]) / np.var(x)
    assert lag == pytest.approx(math.exp(-1.0), abs=0.03)


def test_white_noise_averaged_over_a_tick_has_sigma_density_over_sqrt_t():
    imu = MPU.imu_spec(gyro_bias_stability_deg_s=0.0)
    t = imu.sample_times(600.0)
    g = imu.gyro.measure(np.zeros((t.size, 3)), np.random.default_rng(9), imu.dt_s)
    ticks = np.arange(1, 1100) / 1.9
    avg = average_per_tick(t, g.value, ticks)
    assert np.std(avg[:, 2]) == pytest.approx(7.38e-3 * DEG / math.sqrt(1 / 1.9), rel=0.08)


def test_average_per_tick_non_integer_ratio():
    t = np.arange(0, 10.001, 0.1)
    v = np.stack([t, 2 * t, np.ones_like(t)], axis=-1)
    ticks = np.array([1.0, 2.5, 4.0])
    out = average_per_tick(t, v, ticks)
    # tick 1 covers (1.0, 2.5]: samples 1.1 .. 2.5 (15 samples)
    assert out[1, 0] == pytest.approx(np.mean(np.arange(11, 26) / 10))
    assert np.allclose(out[:, 2], 1.0)
    with pytest.raises(NodesimError, match="no sensor sample"):
        average_per_tick(t, v, np.array([1.0, 1.05]))


def test_same_seed_same_counts_other_seed_differs():
    imu = MPU.imu_spec()
    z = np.zeros((500, 3))
    a = imu.gyro.measure(z, np.random.default_rng(1), imu.dt_s).counts
    b = imu.gyro.measure(z, np.random.default_rng(1), imu.dt_s).counts
    c = imu.gyro.measure(z, np.random.default_rng(2), imu.dt_s).counts
    assert (a == b).all() and not (a == c).all()


@pytest.mark.parametrize(
    "kw,match",
    [
        ({"white_density": -1.0}, "white_density.*>= 0"),
        ({"gm_sigma": [0.0, -1e-3, 0.0]}, "gm_sigma.*>= 0"),
        ({"gm_tau_s": 0.0}, "gm_tau_s.*> 0"),
        ({"flicker_tau_min_s": -1.0}, "flicker_tau_min_s.*> 0"),
        ({"full_scale": 0.0}, "full_scale.*> 0"),
        ({"lsb_per_unit": -5.0}, "lsb_per_unit.*> 0"),
        ({"misalignment": [[1, 0, 0], [0, 1, 0], [1, 0, 0]]}, "not invertible"),
        ({"misalignment": np.eye(2)}, "3x3"),
        ({"full_scale": 2000 * DEG}, "int16"),
    ],
)
def test_impossible_sensor_spec_is_rejected(kw, match):
    with pytest.raises(NodesimError, match=match):
        _quiet_gyro(**kw)


def test_catalogue_has_the_five_sensors_and_rejects_unknown_names():
    assert set(available_sensors()) == {"mpu6500", "vn100t", "stim300", "ipst_rqh", "dip"}
    assert load_sensor("vn-100t").name == "VN-100T"
    assert load_sensor("iPST-RQH").name == "iPST-RQH"
    with pytest.raises(NodesimError, match="unknown sensor 'adxl'"):
        load_sensor("adxl")
    with pytest.raises(NodesimError, match="not an IMU"):
        load_sensor("DIP").imu_spec()
    with pytest.raises(NodesimError, match="unknown model keys"):
        MPU.imu_spec(gyro_arw=1.0)
    with pytest.raises(NodesimError, match="missing"):
        build_imu_spec("x", {"sample_rate_hz": 10.0})


@pytest.mark.parametrize("name", ["MPU6500", "VN-100T", "STIM300", "iPST-RQH"])
def test_every_imu_in_the_catalogue_builds_and_measures(name):
    imu = load_sensor(name).imu_spec()
    g, a = imu.measure(np.zeros((50, 3)), np.tile([0.0, 0.0, G0_M_S2], (50, 1)), np.random.default_rng(0), np.random.default_rng(1))
    assert g.counts.shape == a.counts.shape == (50, 3)
    assert abs(a.value[:, 2].mean() - G0_M_S2) < 0.05 * G0_M_S2


def test_table_4_16_and_v1_values_in_the_mpu6500_entry():
    """Thesis table 4.16 (ISCWSA magnitudes) and table V.1 (Allan) as stored, units in the key names."""
    assert MPU.iscwsa["accel_bias_xy_m_s2"] == 5.886e-1 and MPU.iscwsa["accel_bias_z_m_s2"] == 5.378e-6
    assert MPU.model["gyro_arw_deg_per_sqrt_s"] == [8.9e-3, 6.9e-3, 7.38e-3]
    assert MPU.model["gyro_bias_stability_deg_s"] == [7.9e-3, 3.83e-3, 3.33e-3]


def test_datasheet_mapping_section_4_1_3_dip_and_stim300():
    """Thesis 4.1.3 / table 4.4: DIP +/-2 mm per 25 m -> 0.004584 deg -> 7.85e-4 m/s^2; table 4.10 STIM300."""
    dip = iscwsa_from_datasheet(load_sensor("DIP"))
    assert dip["accel_bias_deg"] == pytest.approx(0.004584, rel=1e-3)
    assert dip["accel_bias_xy_m_s2"] == pytest.approx(7.85e-4, rel=1e-3)
    assert dip["scale_factor_m_s2"] == pytest.approx(9.81e-5, rel=1e-3)
    assert dip["depth_stretch_m_per_m"] == pytest.approx(1.4e-4)
    stim = iscwsa_from_datasheet(load_sensor("STIM300"))
    assert stim["accel_bias_xy_m_s2"] == pytest.approx(4.905e-4, rel=1e-4)
    assert stim["accel_bias_z_m_s2"] == pytest.approx(1.222e-8, rel=5e-3)
    assert stim["gyro_drift_deg_s"] == pytest.approx(1.39e-4, rel=2e-3)
    # table 4.10 prints 2.5e-4 deg/s/sqrt(Hz) for 0.15 deg/sqrt(h); the conversion (eq 3.59) gives 2.5e-3
    assert stim["gyro_arw_deg_s_per_sqrt_hz"] == pytest.approx(10 * load_sensor("STIM300").iscwsa["gyro_arw_deg_s_per_sqrt_hz"])
