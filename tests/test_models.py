"""Kinematics, survey resolution, schedules and the float yaw filter of the walking skeleton."""

import math

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from firmware_model.survey_resolution import circular_moving_average, resolve_survey
from firmware_model.yaw_filter import FloatYawFilter, YawFilterConfig
from nodesim.motion.rotation import LabRotationProfile
from nodesim.io.rundir import atomic_write_with
from nodesim.scenario.schedules import UpdateSchedule
from nodesim.sensors.magnetometer import specific_force_body
from nodesim.sensors.encoder import RotaryEncoder
from nodesim.units import DEG


def test_lab_profile_angles_and_timings():
    p = LabRotationProfile(inclination_rad=2 * DEG, azimuth_rad=0.0)
    slow, fast = p.phases
    assert slow.start_s == 50.0 and math.isclose(slow.end_s, 250.0)  # 2 turns at 3.6 deg/s = 200 s
    assert math.isclose(fast.start_s, 260.0)
    assert math.isclose(fast.end_s - fast.start_s, 7200.0 / 71.0)  # 20 turns at 71 deg/s
    assert math.isclose(p.yaw_rad(1000.0), (720 + 7200) * DEG)
    assert p.rate_rad_s(100.0) == 3.6 * DEG and p.rate_rad_s(255.0) == 0.0


def test_north_tilt_gives_zero_azimuth_and_yaw_error_maps_to_azimuth():
    f = specific_force_body(5 * DEG, 0.0, np.array(0.7))
    inc, azi = resolve_survey(f, np.array(0.7))
    assert math.isclose(float(inc), 5 * DEG, abs_tol=1e-12)
    assert math.isclose(float(np.remainder(azi + 1, 2 * math.pi) - 1), 0.0, abs_tol=1e-12)
    _, azi_err = resolve_survey(f, np.array(0.7 + 0.01))
    assert math.isclose(float(azi_err), 0.01, abs_tol=1e-12)  # dA/dpsi = 1 (thesis digest 1.2)


@given(st.floats(0.5, 179.5), st.floats(0.0, 359.9), st.floats(-1e4, 1e4))
def test_inclination_independent_of_yaw(inc_deg, azi_deg, yaw_deg):
    f = specific_force_body(inc_deg * DEG, azi_deg * DEG, np.array(yaw_deg * DEG))
    inc, azi = resolve_survey(f, np.array(yaw_deg * DEG))
    assert math.isclose(float(inc), inc_deg * DEG, abs_tol=1e-9)
    assert abs(math.remainder(float(azi) - azi_deg * DEG, 2 * math.pi)) < 1e-9


def test_circular_average_across_north():
    x = np.array([359.0, 1.0, 359.0, 1.0]) * DEG
    assert abs(math.remainder(float(circular_moving_average(x, 4)[-1]), 2 * math.pi)) < 1e-12


def test_encoder_quantisation_sigma_matches_thesis_digest():
    enc = RotaryEncoder(1024)
    assert math.isclose(enc.step_rad / DEG, 0.3515625)
    assert math.isclose(enc.quantisation_sigma_rad / DEG, 0.1015, rel_tol=1e-3)
    assert float(enc.read_rad(0.15 * DEG)) == 0.0  # below half a count
    assert math.isclose(float(enc.read_rad(0.2 * DEG)), 0.3515625 * DEG)  # above half a count


def test_schedules():
    dt = 1 / 1.9
    t = np.arange(0, 200, dt)
    assert UpdateSchedule("continuous").mask(t, dt).all()
    assert not UpdateSchedule("none").mask(t, dt).any()
    w = UpdateSchedule("windowed", update_s=20, timeout_s=30).mask(t, dt)
    assert math.isclose(w.mean(), 20 / 50, abs_tol=0.02)
    single = UpdateSchedule("single", single_rate_hz=0.1).mask(t, dt)
    assert single.sum() == 20  # t = 0, 10, ..., 190


def _filter(realizations=4, tuning_b=5.0):
    cfg = YawFilterConfig(
        dt_s=1 / 1.9, arw_rad_per_sqrt_s=7.38e-3 * DEG, bias_instability_rad_s=3.33e-3 * DEG, bias_tau_s=500.0, tuning_b=tuning_b
    )
    return FloatYawFilter(cfg, realizations)


def test_bias_converges_with_continuous_updates_and_outage_grows_at_bias_rate():
    true_bias = -0.02 * DEG
    kf = _filter()
    yaw = np.zeros(4)
    for _ in range(1200):
        kf.predict(np.full(4, true_bias))
        kf.update(yaw, (0.1015 * DEG) ** 2)
    assert np.allclose(kf.bias_rad_s, true_bias, atol=0.001 * DEG)
    # outage: the residual (here, a bias step of 0.01 deg/s the filter has not seen) makes yaw drift linearly
    start, p_start = kf.yaw_rad.copy(), kf.yaw_variance_rad2.copy()
    for _ in range(190):  # 100 s
        kf.predict(np.full(4, true_bias + 0.01 * DEG))
    assert np.allclose(kf.yaw_rad - start, 0.01 * DEG * 100, rtol=0.01)
    assert (kf.yaw_variance_rad2 > 10 * p_start).all()  # variance grows without updates


def test_higher_tuning_b_converges_faster():
    def steps_to_converge(b):
        kf = _filter(1, tuning_b=b)
        for _ in range(3000):  # reach the steady-state covariance with a zero bias
            kf.predict(np.zeros(1))
            kf.update(np.zeros(1), (0.1015 * DEG) ** 2)
        for k in range(5000):  # then the bias steps to -0.02 deg/s (thesis 4.2.3)
            kf.predict(np.array([-0.02 * DEG]))
            kf.update(np.zeros(1), (0.1015 * DEG) ** 2)
            if abs(kf.bias_rad_s[0] + 0.02 * DEG) < 0.002 * DEG:
                return k
        return 5000

    assert steps_to_converge(5.0) < steps_to_converge(1.0)


def test_atomic_write_leaves_nothing_on_failure(tmp_path):
    target = tmp_path / "plot.png"

    def failing(p):
        p.write_bytes(b"half")
        raise RuntimeError("interrupted")

    try:
        atomic_write_with(target, failing)
    except RuntimeError:
        pass
    assert list(tmp_path.iterdir()) == []
