"""The chain's 6-state filter (issue 24): the lane kernel both engines run is the checked float filter
(firmware_model.six_state_filter.SixStateFilter, itself checked against filterpy) step by step; the twist
conversion; the levelled start; the chain runs it and counts the ticks inside the singularity margin."""

import math

import numpy as np
import pytest

from firmware_model.six_state_filter import SixStateFilter, SixStateFilterConfig, body_to_nav
from nodesim.chain.compiled import six_state_float_kernel as ssk
from nodesim.chain.metrics import per_realization_metrics, singularity_warning, summarize
from nodesim.chain.network import simulate_chain
from nodesim.chain.six_state import level_attitude
from nodesim.scenario.schema import Scenario
from nodesim.sensors.sample_truth import sensor_force

CFG = dict(dt_s=1 / 1.9, arw_rad_per_sqrt_s=(3e-4, 4e-4, 5e-4), bias_instability_rad_s=1e-4)


@pytest.mark.parametrize("discretisation", ["rotation", "euler"])
@pytest.mark.parametrize("singularity", ["hold", "decouple"])
def test_lane_kernel_follows_the_six_state_filter(discretisation, singularity):
    """Predict and yaw updates through a tilted spin that passes the singularity margin: the kernel's lanes keep
    the numpy filter's attitude, biases and P to rounding."""
    cfg = SixStateFilterConfig(**CFG, discretisation=discretisation, singularity=singularity,
                               singularity_margin_rad=math.radians(10.0))
    R = 3
    rng = np.random.default_rng(1)
    att0 = np.array([[0.3, 1.2, 0.1], [-0.2, 0.05, 2.0], [1.0, -1.3, -0.5]])
    ref = SixStateFilter(cfg, R, att0, 1e-3)
    lanes = ssk.init_states(cfg, att0, np.full((R, 3), 1e-3))
    params, singular = ssk.kernel_params(cfg), np.zeros(R, np.int64)
    # "euler" is unstable under rotation (its docstring): two trajectories 1 ulp apart part ~x1.8 a tick in this case
    # (1e-16 -> 1e-10 in 25 ticks), so it is compared over 12 ticks, where the parting is still below 1e-10
    for k in range(60 if discretisation == "rotation" else 12):
        rates = rng.normal(0, 0.3, (R, 3)) + np.array([0.0, 0.0, 1.0])
        ref.predict(rates)
        ssk.predict_lanes(lanes, rates, params, singular, np.ones(R, bool))
        if k % 3 == 0:
            y, v, mask = rng.normal(0, 3, R), rng.uniform(1e-5, 1e-3, R), rng.random(R) < 0.7
            ref.update(y, v, mask=mask)
            for r in np.flatnonzero(mask):
                ssk.update(lanes[r], y[r], v[r])
        np.testing.assert_allclose(lanes[:, :3], ref.attitude_rad, rtol=0, atol=1e-9)
        np.testing.assert_allclose(lanes[:, 3:6], ref.bias_rad_s, rtol=0, atol=1e-12)
        # P to rounding, normwise per element: |dP_ij| <= 1e-9 sqrt(P_ii P_jj) (off-diagonal terms cancel)
        p, want = lanes[:, ssk.P:ssk.P + 36].reshape(R, 6, 6), ref.covariance
        d = np.sqrt(np.einsum("rii->ri", want))
        assert np.all(np.abs(p - want) <= 1e-9 * d[:, :, None] * d[:, None, :])
    np.testing.assert_array_equal(singular, ref.singular_ticks)
    assert singular.sum() > 0  # the case reached the margin


def test_twist_is_the_z_y_z_sum_of_the_attitude():
    """psi + c(phi, theta) = atan2(C10 - C01, C00 + C11) of C_b^n, and a tube turned by psi_t about its own axis from
    the untwisted tilted frame (the sensor model's geometry, inclination I, azimuth A) has twist psi_t."""
    rng = np.random.default_rng(2)
    att = np.c_[rng.uniform(-1.4, 1.4, 50), rng.uniform(-1.4, 1.4, 50), rng.uniform(-3, 3, 50)]
    c = body_to_nav(att)
    want = np.arctan2(c[:, 1, 0] - c[:, 0, 1], c[:, 0, 0] + c[:, 1, 1])
    got = np.array([ssk.twist_rad(np.r_[a, np.zeros(39)]) for a in att])
    np.testing.assert_allclose(np.angle(np.exp(1j * (got - want))), 0.0, atol=1e-12)
    inc, azi, twist = np.radians(70.0), np.radians(30.0), np.radians([-170.0, -20.0, 0.0, 45.0, 160.0])
    f = sensor_force(np.full(5, inc), np.full(5, azi), twist)  # the chain's IMU truth, up-hole z
    lev = level_attitude(f, twist)
    tilt = np.degrees(np.arccos(np.cos(lev[:, 0]) * np.cos(lev[:, 1])))
    np.testing.assert_allclose(tilt, 70.0, atol=1e-9)  # levelled: the tube's inclination
    back = np.array([ssk.twist_rad(np.r_[a, np.zeros(39)]) for a in lev])
    np.testing.assert_allclose(back, twist, atol=1e-12)


LAB = {"chain.nodes": 3, "simulation.duration_s": 200.0, "simulation.realizations": 2,
       "metrics.window_start_s": 60.0, "metrics.window_end_s": 200.0, "filter.states": 6}


def test_a_six_state_run_counts_no_singular_tick_near_vertical_and_some_near_horizontal():
    """At 2 deg the Z-Y-X pitch never nears 90 deg; at 89 deg the tilt sits mostly in the roll, but the string's spin
    takes the pitch through the 5 deg margin now and then: the summary counts the node-ticks and the warning says
    so."""
    out = {}
    for inc in (2.0, 89.0):
        s = Scenario().with_overrides(**LAB, **{"motion.inclination_deg": inc})
        m = summarize(per_realization_metrics(simulate_chain(s), s.metrics))
        out[inc] = m
        assert np.isfinite(m["rms_yaw_error_deg"])
    assert out[2.0]["singular_ticks"] == 0 and singularity_warning(out[2.0]) is None
    assert out[89.0]["singular_ticks"] > 0
    msg = singularity_warning(out[89.0])
    assert "singular_ticks" in msg and "filter.singularity_margin_deg" in msg


def test_a_two_state_run_has_no_singular_ticks_key():
    s = Scenario().with_overrides(**{**LAB, "filter.states": 2, "chain.nodes": 1, "simulation.duration_s": 80.0,
                                     "metrics.window_end_s": 80.0})
    assert "singular_ticks" not in summarize(per_realization_metrics(simulate_chain(s), s.metrics))
