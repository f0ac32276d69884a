"""The 6-state fixed filter (firmware_model.six_state_fixed) against the float 6-state filter it implements
(firmware_model.six_state_filter, default "rotation"/"hold"), within a bound derived from the formats; and its
configuration checks (each a FirmwareError naming the key)."""

import math

import numpy as np
import pytest

from firmware_model import cordic
from firmware_model.errors import FirmwareError
from firmware_model.six_state_filter import (SixStateFilter, SixStateFilterConfig, euler_rate_matrix,
                                             inverse_euler_rate_matrix)
from firmware_model.six_state_fixed import SixStateFixedConfig, SixStateFixedFilter, SixStateFixedFormats
from firmware_model.fixedpoint import QFormat

DEG = math.pi / 180.0
DT = 1 / 1.9
N = cordic.MAX_ITERATIONS


def _float_config(**kw):
    base = dict(dt_s=DT, arw_rad_per_sqrt_s=7.38e-3 * DEG, bias_instability_rad_s=3.33e-3 * DEG)
    base.update(kw)
    return SixStateFilterConfig(**base)


def _quantised(rates_rad_s):
    """The rates as the fixed filter holds them (Q16.16 deg/s), so both filters see the same input."""
    return np.round(np.asarray(rates_rad_s) / DEG * 2**16) / 2**16 * DEG


def _tick_bound_rad(max_tilt_rad):
    """Worst-case attitude error one tick adds (rad), from the formats (six_state_fixed docstring):
    the CORDIC vectoring residual 2^-(n-1) + (n + 4) 2^-27 (cordic.py), plus the effect of the errors of the
    strapdown matrix entries C+ (each a sum of 3 products of a trig value, error <= b_sc = atan(2^-(n-1)) +
    (2n + 1) 2^-30 (cordic.sin_cos), with an Exp entry, error <= 4 LSB of Q2.30: 3 rounded products and a sum;
    4 roundings of 0.5 LSB), amplified by at most 2 / cos(tilt) in atan2, plus the binary angle's half LSB."""
    b_v = 2.0 ** -(N - 1) + (N + 4) * 2.0**-27
    b_sc = math.atan(2.0 ** -(N - 1)) + (2 * N + 1) * 2.0**-30
    d_c = 3 * (2 * b_sc + 4 * 2.0**-30) + 4 * 0.5 * 2.0**-30
    return b_v + 2 * d_c / math.cos(max_tilt_rad) + 0.5 * 2.0**-32 * 2 * math.pi


def _wrapped(d):
    return (np.asarray(d) + math.pi) % (2 * math.pi) - math.pi


def _run(rates_fn, ticks, attitude0, update_every=0, ref_fn=None, ref_var=0.0):
    cfg = _float_config()
    flt = SixStateFilter(cfg, 1, initial_attitude_rad=attitude0)
    fix = SixStateFixedFilter(SixStateFixedConfig.from_filter_config(cfg), 1, initial_attitude_rad=attitude0)
    err, e_norm, e_inv_norm, tilt = [], 1.0, 1.0, 0.0
    for k in range(ticks):
        w = _quantised(rates_fn(k))
        flt.predict(w)
        fix.predict(w)
        a = flt.attitude_rad[0]
        e_norm = max(e_norm, np.linalg.norm(euler_rate_matrix(a[0], math.sin(a[1]), math.cos(a[1])), 2))
        e_inv_norm = max(e_inv_norm, np.linalg.norm(inverse_euler_rate_matrix(a[0], a[1]), 2))
        if update_every and k % update_every == 0:
            ref = ref_fn(k)
            flt.update(ref, ref_var)
            fix.update(ref, ref_var)
        tilt = max(tilt, float(np.max(np.abs(flt.attitude_rad[0, :2]))))
        err.append(np.abs(_wrapped(fix.attitude_rad[0] - flt.attitude_rad[0])))
    return np.array(err), e_norm * e_inv_norm, tilt, flt, fix


PROFILES = {  # (gyro rates (rad/s) at tick k, initial attitude (rad))
    "drilling 60 deg/s": (lambda k: [0.0, 0.0, 60 * DEG], [2 * DEG, -1.5 * DEG, 0.0]),
    "static": (lambda k: [0.0, 0.0, 0.0], [3 * DEG, 1 * DEG, 40 * DEG]),
    "small tilts, slow rotation": (lambda k: [0.05 * DEG * math.sin(0.1 * k), 0.04 * DEG * math.cos(0.07 * k),
                                             10 * DEG], [1 * DEG, 2 * DEG, -30 * DEG]),
}


@pytest.mark.parametrize("profile", sorted(PROFILES))
def test_open_loop_attitude_within_the_quantisation_bound(profile):
    """Predict only, 400 ticks (210 s): each tick adds at most e_tick = _tick_bound_rad per axis, and an earlier
    error is carried by the later ticks' maps, to first order Phi11_N ... Phi11_k = E(Theta_N) R E(Theta_k)^-1
    (Phi11 = E(Theta+) Exp(-rho) E(Theta)^-1 telescopes; R a rotation), of 2-norm <= kappa = max |E| max |E^-1|
    over the run, so after N ticks |dTheta| <= sqrt(3) e_tick N kappa."""
    rates, att0 = PROFILES[profile]
    ticks = 400
    err, kappa, tilt, _, fix = _run(rates, ticks, att0)
    bound = math.sqrt(3) * _tick_bound_rad(tilt + 0.01) * ticks * kappa
    assert bound < 0.05 * DEG  # the bound itself is small: the test can tell a wrong model from rounding
    assert err.max() <= bound, (np.degrees(err.max()), np.degrees(bound))
    assert fix.overflow_counts == {}


def test_closed_loop_yaw_meets_the_acceptance_and_the_covariance_tracks():
    """620 s at the drilling 60 deg/s with an encoder reference every tick (R = (0.1015 deg)^2, digest 2.6): the
    yaw within 0.01 deg of the float filter (the fixed-point acceptance of thesis digest 2.7), and P_psi_psi
    within N 9 LSB of p_aa (each tick rounds at most 18 products and sums at 0.5 LSB into P_psi_psi; the
    updates contract earlier errors)."""
    ticks = int(620 / DT)
    truth = lambda k: ((k + 1) * DT * 60 * DEG) % (2 * math.pi)  # noqa: E731
    err, _, _, flt, fix = _run(lambda k: [0.0, 0.0, 60 * DEG], ticks, [2 * DEG, -1.5 * DEG, 0.0], update_every=1,
                               ref_fn=truth, ref_var=(0.1015 * DEG) ** 2)
    assert np.degrees(err[:, 2].max()) < 0.01
    lsb_rad2 = QFormat(32, 24).lsb * DEG**2
    assert abs(fix.yaw_variance_rad2[0] - flt.yaw_variance_rad2[0]) <= ticks * 9 * lsb_rad2


def test_roll_pitch_yaw_update_tracks_the_float_update():
    """The 3 x 3 update (sequential scalar updates) equals the float batch update up to rounding."""
    rates, att0 = PROFILES["small tilts, slow rotation"]
    cfg = _float_config()
    flt, fix = SixStateFilter(cfg, 2, att0), SixStateFixedFilter(SixStateFixedConfig.from_filter_config(cfg), 2, att0)
    for k in range(100):
        w = _quantised(rates(k))
        flt.predict(w), fix.predict(w)
        args = (0.1, (0.3 * DEG) ** 2, np.array([True, k % 2 == 0]), [[0.5 * DEG, -0.5 * DEG]] * 2,
                [[(0.5 * DEG) ** 2] * 2] * 2)
        flt.update(*args), fix.update(*args)
    assert np.degrees(np.abs(_wrapped(fix.attitude_rad - flt.attitude_rad)).max()) < 1e-3
    assert np.abs(fix.covariance - flt.covariance).max() < 1e-3 * np.abs(flt.covariance).max()


# ---- configuration checks --------------------------------------------------------------------------------------
@pytest.mark.parametrize("kwargs, fragments", [
    (dict(discretisation="euler"), ("discretisation = 'euler'", "allowed: rotation")),
    (dict(arw_rad_per_sqrt_s=-1e-4), ("arw_rad_per_sqrt_s", ">= 0")),
    (dict(tuning_b=-5.0), ("tuning_b", "> 0")),
    (dict(bias_tau_s=-500.0), ("bias_tau_s", "> 0")),
    (dict(initial_angle_sigma_rad=10 * DEG), ("formats.p_aa", "too narrow", "initial_angle_sigma_rad")),
    (dict(initial_bias_sigma_rad_s=0.1 * DEG), ("formats.p_bb", "too narrow", "initial_bias_sigma_rad_s")),
    (dict(initial_bias_sigma_rad_s=1e-5 * DEG), ("formats.p_bb", "too coarse", "initial_bias_sigma_rad_s")),
    (dict(singularity_margin_rad=1 * DEG), ("singularity_margin_rad", "formats.transition")),
    (dict(tuning_a=1e3), ("tuning_a", "formats.noise_sqrt")),
])
def test_bad_configurations_are_rejected_naming_the_key(kwargs, fragments):
    with pytest.raises(FirmwareError) as info:
        SixStateFixedConfig.from_filter_config(_float_config(**kwargs))
    for fragment in fragments:
        assert fragment in str(info.value)


def test_narrow_formats_are_rejected_naming_the_key():
    with pytest.raises(FirmwareError, match="formats.p_ab"):
        SixStateFixedConfig(_float_config(initial_angle_sigma_rad=5 * DEG),
                            formats=SixStateFixedFormats(p_ab=QFormat(32, 38)))
    with pytest.raises(FirmwareError, match="formats.unit"):
        SixStateFixedConfig(_float_config(), formats=SixStateFixedFormats(unit=QFormat(32, 28)))
    with pytest.raises(FirmwareError, match="formats.rate"):
        SixStateFixedConfig(_float_config(), formats=SixStateFixedFormats(rate=QFormat(16, 4)))


def test_the_default_build_passes_its_checks_with_the_thesis_tuning():
    cfg = SixStateFixedConfig.from_filter_config(_float_config())
    assert cfg.params().shape == (121,) and "SixStateFixedFilter" in repr(SixStateFixedFilter(cfg, 1))


LEVEL = dict(levelling=True, levelling_rate_rad_s=0.5 * DEG, levelling_force_sigma_m_s2=2.87e-3)


@pytest.mark.parametrize("filter_kwargs, counts_per_m_s2, fragments", [
    ({}, 0.0, ("accel_counts_per_m_s2 = 0.0", "levelling", "> 0")),
    ({}, float("nan"), ("accel_counts_per_m_s2",)),
    (dict(levelling_rate_rad_s=1e-7 * DEG), 1670.0, ("levelling_rate_rad_s", "formats.rate")),
    (dict(levelling_force_sigma_m_s2=10.0), 1670.0, ("levelling_force_sigma_m_s2", "formats.level_sigma")),
    (dict(levelling_force_sigma_m_s2=1e-12), 1670.0, ("levelling_force_sigma_m_s2", "formats.level_sigma")),
])
def test_bad_levelling_builds_are_rejected_naming_the_key(filter_kwargs, counts_per_m_s2, fragments):
    with pytest.raises(FirmwareError) as info:
        SixStateFixedConfig.from_filter_config(_float_config(**{**LEVEL, **filter_kwargs}),
                                               accel_counts_per_m_s2=counts_per_m_s2)
    for fragment in fragments:
        assert fragment in str(info.value)


def test_a_levelling_build_levels_a_static_lane_only():
    """SixStateFixedFilter.level: a static lane (rates = its start bias) moves to the accelerometer's roll and
    pitch (f = C_n^b [0, 0, g] at roll 3 deg, pitch -2 deg, as count sums), a turning one (1 deg/s) does not;
    without levelling nothing moves."""
    s_a, n = 1670.0, 100
    roll, pitch = 3 * DEG, -2 * DEG
    force = 9.81 * np.array([-math.sin(pitch), math.sin(roll) * math.cos(pitch), math.cos(roll) * math.cos(pitch)])
    sums = np.rint(force * s_a * n).astype(np.int64)
    cfg = SixStateFixedConfig.from_filter_config(_float_config(**LEVEL), accel_counts_per_m_s2=s_a)
    fix = SixStateFixedFilter(cfg, 2, initial_attitude_rad=np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0]]))
    assert fix.level([[0, 0, 0], [0, 0, 1 * DEG]], sums, n) == 1
    att = fix.attitude_rad
    assert np.abs(att[0, :2] - [roll, pitch]).max() < 0.01 * DEG  # P0 (1 deg sigma) >> R ((sigma_f / g)^2)
    assert np.array_equal(att[1], [0.0, 0.0, 0.0])
    off = SixStateFixedFilter(SixStateFixedConfig.from_filter_config(_float_config()), 1)
    assert off.level([0, 0, 0], sums, n) == 0 and np.array_equal(off.attitude_rad[0], [0.0, 0.0, 0.0])
