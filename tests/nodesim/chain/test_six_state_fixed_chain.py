"""The fixed-point 6-state node firmware (firmware_model.six_state_firmware, issue 24): its twist c(phi, theta) and row h, its twist
update and its levelled start follow the float 6-state chain filter (nodesim.chain.compiled.six_state_float_kernel,
itself checked against firmware_model.six_state_filter) to the rounding of its formats and the CORDIC; a build
whose sent words differ from the filter's formats is refused; in the chain it keeps the float chain's accuracy and
its saturations reach the run summary (the engines' equality: tests/nodesim/chain/test_compiled.py)."""

import math

import numpy as np
import pytest

from firmware_model import six_state_kernel as k6
from firmware_model import six_state_firmware as n6
from firmware_model import fixed_kernel as fk
from firmware_model import node_firmware as nf
from firmware_model.errors import FirmwareError
from firmware_model.six_state_fixed import SixStateFixedFormats
from nodesim.api import simulate
from nodesim.chain import estimator
from nodesim.chain.compiled import six_state_float_kernel as ssk
from nodesim.chain.estimator import six_state_firmware_config, six_state_params
from nodesim.chain.metrics import per_realization_metrics, summarize
from nodesim.chain.network import simulate_chain
from nodesim.chain.six_state import level_attitude
from nodesim.chain.six_state_firmware_lanes import SixStateFirmwareLanes
from nodesim.scenario.schema import Scenario
from nodesim.sensors.chain_imu import ChainImu
from nodesim.sensors.sample_truth import sensor_force

SCENARIO = Scenario().with_overrides(**{"filter.states": 6, "filter.implementation": "fixed",
                                        "filter.levelling": "static"})
FIRMWARE, BUILD = six_state_firmware_config(SCENARIO)
P6, LANE0 = six_state_params(BUILD)
DEG2 = (180.0 / math.pi) ** 2
# 24 CORDIC iterations (firmware.cordic_iterations): each angle to ~2^-23 rad; a few of them per result
CORDIC_RAD = 8 * 2.0 ** -(SCENARIO.firmware.cordic_iterations - 1)


def _rad(raw):
    return np.asarray(raw, float) / 2**32 * 2 * math.pi


def _wrapped(x):
    return np.angle(np.exp(1j * np.asarray(x)))


def _lane(att, bias, p_rad):
    """A 6-state lane at (att, bias) with P (rad units) rounded into its block formats; and P as the lane holds it."""
    st = BUILD.initial_state(att, bias)
    f = BUILD.formats
    frac = np.full((6, 6), f.p_ab.frac_bits)
    frac[:3, :3], frac[3:, 3:] = f.p_aa.frac_bits, f.p_bb.frac_bits
    st[k6.I_P:k6.I_P + 36] = np.rint(np.ldexp(p_rad * DEG2, frac)).astype(np.int64).ravel()
    return st, frac


def _p_rad(st, frac):
    return np.ldexp(st[k6.I_P:k6.I_P + 36].reshape(6, 6).astype(float), -frac) / DEG2


def test_twist_offset_and_row_follow_the_float_twist():
    rng = np.random.default_rng(3)
    counts, work = np.zeros(len(n6.SITES), np.int64), np.zeros(k6.WORK_SIZE, np.int64)
    for _ in range(200):
        att = np.r_[rng.uniform(-1.4, 1.4, 2), rng.uniform(-3, 3)]
        c, h0, h1 = n6.twist_offset(BUILD.initial_state(att, (0, 0, 0)), P6, counts, work)
        h = np.empty(6)
        ssk.twist_row(np.r_[att, np.zeros(39)], h)
        assert abs(_wrapped(_rad(c) - ssk.twist_offset(att[0], att[1]))) < CORDIC_RAD
        np.testing.assert_allclose(np.array([h0, h1]) / 2.0 ** BUILD.formats.transition.frac_bits, h[:2], atol=1e-6)
    assert not counts.any()


def test_twist_update_follows_the_float_twist_update():
    """One update from random correlated covariances: the float filter's Joseph form and the fixed simple form are
    equal in exact arithmetic, so they differ by the formats' rounding (attitude in rad, bias by one Q16.16 LSB,
    P normwise per element)."""
    rng = np.random.default_rng(4)
    counts, work = np.zeros(len(n6.SITES), np.int64), np.zeros(k6.WORK_SIZE, np.int64)
    bias_lsb = 2.0**-16 * math.pi / 180.0
    moved = 0.0
    for _ in range(100):
        att, bias = np.r_[rng.uniform(-1.2, 1.2, 2), rng.uniform(-3, 3)], rng.normal(0, 1e-3, 3)
        sig = np.r_[rng.uniform(0.002, 0.05, 3), rng.uniform(1e-5, 1e-4, 3)]
        p = np.corrcoef(rng.normal(size=(6, 12))) * np.outer(sig, sig)
        st, frac = _lane(att, bias, p)
        fl = np.r_[_rad(st[:3]), st[3:6] * bias_lsb, _p_rad(st, frac).ravel()]
        ref = att[2] + ssk.twist_offset(att[0], att[1]) + rng.normal(0, 0.01)
        var = 1e-6
        before = fl[:3].copy()
        ssk.update_twist(fl, ref, var)
        n6.twist_update_raw(st, int(np.rint(ref / (2 * math.pi) * 2**32)), int(np.rint(var * DEG2 * 2**24)), P6,
                            counts, work)
        moved = max(moved, np.max(np.abs(_wrapped(fl[:3] - before))))
        assert np.max(np.abs(_wrapped(_rad(st[:3]) - fl[:3]))) < 2e-6
        assert np.max(np.abs(st[3:6] * bias_lsb - fl[3:6])) <= 2 * bias_lsb
        d = np.sqrt(np.diag(p))
        assert np.max(np.abs(_p_rad(st, frac) - fl[6:].reshape(6, 6)) / np.outer(d, d)) < 2e-4
    assert moved > 1e-3  # the updates moved the attitude by far more than the tolerance
    assert not counts.any()


@pytest.mark.parametrize("inclination_deg", [2.0, 45.0, 88.0])
def test_levelling_update_follows_the_float_levelling(inclination_deg):
    """One levelling update (six_state_kernel.level_raw) at a static tick from random correlated covariances, the
    accelerometer's count sums at a random toolface and a small attitude error: the float chain filter's
    level_update (Joseph form, the same count sums as its mean force) and the fixed one differ by the formats'
    rounding and the CORDIC (the tolerances of the twist update's test above), plus, for the attitude, what the
    second scalar update adds: after the first (K ~ 1, R ~ (sigma_f / g)^2 = 2.8e-4 deg^2 = 4.7 k LSB of p_aa) the
    covariance entries it reads are R-sized and carry up to 4 LSB of p_aa (a rounded product, a rounded
    difference, the gain's rounding, the mirrored entry), so its gain is off by up to 4 LSB / R and the attitude
    by that times the innovation |z|.  Near horizontal (88 deg, inside the 5 deg margin) both skip the roll."""
    rng = np.random.default_rng(int(inclination_deg))
    counts, work = np.zeros(len(k6.SITES), np.int64), np.zeros(k6.WORK_SIZE, np.int64)
    imu = ChainImu.from_scenario(SCENARIO)
    params = ssk.kernel_params(estimator.six_state_config(SCENARIO))
    assert params[ssk.P_LEVEL] == 1.0 and P6[k6.P_LEVEL] == 1
    bias_lsb = 2.0**-16 * math.pi / 180.0
    n, moved, worst = 100, 0.0, 0.0
    for _ in range(100):
        twist = rng.uniform(-math.pi, math.pi)
        force = sensor_force(np.array([math.radians(inclination_deg)]), np.array([0.5]), np.array([twist]))[0]
        sums = np.rint(force * imu.accel_lsb_per_m_s2 * n).astype(np.int64)
        tilt = level_attitude((sums / (n * imu.accel_lsb_per_m_s2))[None], np.array([0.0]))[0]
        att = np.r_[tilt[:2] + rng.normal(0, 0.01, 2), rng.uniform(-3, 3)]
        bias = rng.normal(0, 1e-3, 3)
        sig = np.r_[rng.uniform(0.002, 0.05, 3), rng.uniform(1e-5, 1e-4, 3)]
        p = np.corrcoef(rng.normal(size=(6, 12))) * np.outer(sig, sig)
        st, frac = _lane(att, bias, p)
        fl = np.r_[_rad(st[:3]), st[3:6] * bias_lsb, _p_rad(st, frac).ravel(), st[3:6] * bias_lsb]  # b_0 = b
        before = fl[:3].copy()
        assert ssk.level_update(fl, fl[3:6], sums / (n * imu.accel_lsb_per_m_s2), params)
        assert k6.level_raw(st, st[k6.I_BIAS:k6.I_BIAS + 3].copy(), sums, n, P6, counts, work) == 1  # rates = b_0
        z = np.max(np.abs(_wrapped(before[:2] - tilt[:2])))
        r_deg2 = (params[ssk.P_LEVEL_VAR] ** 0.5 * imu.accel_lsb_per_m_s2 * n / np.linalg.norm(sums)) ** 2 * DEG2
        second = z * 4 * 2.0 ** -BUILD.formats.p_aa.frac_bits / r_deg2
        moved = max(moved, np.max(np.abs(_wrapped(fl[:2] - before[:2]))))
        worst = max(worst, np.max(np.abs(_wrapped(_rad(st[:3]) - fl[:3]))) / (2e-6 + second))
        assert np.max(np.abs(_wrapped(_rad(st[:3]) - fl[:3]))) < 2e-6 + second
        assert np.max(np.abs(st[3:6] * bias_lsb - fl[3:6])) <= 2 * bias_lsb
        d = np.sqrt(np.diag(p))
        assert np.max(np.abs(_p_rad(st, frac) - fl[6:42].reshape(6, 6)) / np.outer(d, d)) < 2e-4
    assert moved > 1e-3  # the updates moved the attitude by far more than the tolerance
    assert not counts.any()
    print(f"worst attitude difference / bound: {worst:.3f}")


@pytest.mark.parametrize("inclination_deg", [2.0, 45.0, 70.0])
def test_levelled_start_follows_the_float_start(inclination_deg):
    """Static ticks of accelerometer count sums at an inclination and twist, then the start: roll and pitch are the
    float levelling of the window's mean force, the twist word the encoder's angle."""
    imu = ChainImu.from_scenario(SCENARIO)
    twist = np.radians([-170.0, -20.0, 0.0, 45.0, 160.0])
    R, n = twist.size, 100
    f = sensor_force(np.full(R, math.radians(inclination_deg)), np.full(R, math.radians(30.0)), twist)
    accel = np.rint(f * imu.accel_lsb_per_m_s2 * n).astype(np.int64)
    lanes = SixStateFirmwareLanes(SCENARIO, R)
    lanes.inputs[:, n6.IN_AX:n6.IN_AX + 3] = accel
    for _ in range(3):
        lanes.tick(nf.STATIC, np.zeros(R, np.int64), n)
    yaw0 = FIRMWARE.encoder_yaw_raw(twist)
    lanes.tick(nf.START, np.zeros(R, np.int64), n, yaw0_raw=yaw0)
    want = level_attitude(accel / (n * imu.accel_lsb_per_m_s2), twist)
    att = _rad(lanes.states[:, n6.O6:n6.O6 + 3])
    assert np.max(np.abs(_wrapped(att[:, :2] - want[:, :2]))) < CORDIC_RAD
    assert np.max(np.abs(_wrapped(att[:, 2] - want[:, 2]))) < 2 * CORDIC_RAD
    assert np.max(np.abs(_wrapped(lanes.yaw_rad - twist))) < 2 * CORDIC_RAD  # the sent twist: the encoder's
    assert np.array_equal(lanes.states[:, n6.O6 + k6.I_P:n6.O6 + k6.I_P + 36],
                          np.broadcast_to(LANE0[k6.I_P:k6.I_P + 36], (R, 36)))  # P0


def test_a_build_whose_sent_words_differ_from_the_filter_formats_is_refused():
    fparams = FIRMWARE.filter_params().copy()
    fparams[fk.W_YY + 1] -= 2
    with pytest.raises(FirmwareError, match="p_yy / p_aa.*filter.fixed_word_bits = 32"):
        n6.check_formats(fparams, P6)


LAB = {"chain.nodes": 4, "simulation.duration_s": 160.0, "simulation.realizations": 3,
       "metrics.window_start_s": 60.0, "metrics.window_end_s": 160.0, "filter.states": 6}


@pytest.mark.parametrize("inclination_deg", [2.0, 45.0])
def test_the_fixed_six_state_chain_keeps_the_float_chains_accuracy(inclination_deg):
    """Same seeds, same sensors: the fixed node firmware's yaw error at every node is the float 6-state chain's
    within 2 % (the differences are the formats' rounding), and nothing saturates."""
    out = {}
    for impl in ("float", "fixed"):
        s = Scenario().with_overrides(**LAB, **{"filter.implementation": impl, "motion.inclination_deg": inclination_deg})
        run = simulate_chain(s)
        out[impl] = summarize(per_realization_metrics(run, s.metrics))
        if impl == "fixed":
            assert all(not n.firmware_overflows for n in run.nodes)
    for n in range(1, 5):
        key = f"node{n}_rms_yaw_error_deg"
        assert out["fixed"][key] == pytest.approx(out["float"][key], rel=0.02), key
    assert out["fixed"]["rms_yaw_error_deg"] != out["float"]["rms_yaw_error_deg"]  # two filters, not one


def test_the_fixed_six_state_saturations_reach_the_run_summary(monkeypatch):
    """With Q2.30 angle gains (the filter's default formats, too narrow under the twist update:
    estimator.CHAIN_SIX_STATE_FORMATS) the gains saturate; the counts reach each node's firmware_overflows by site
    and their sum the summary's firmware_saturations."""
    monkeypatch.setattr(estimator, "CHAIN_SIX_STATE_FORMATS", SixStateFixedFormats())
    s = Scenario().with_overrides(**{**LAB, "filter.implementation": "fixed", "chain.nodes": 2,
                                     "simulation.duration_s": 100.0, "metrics.window_end_s": 100.0})
    run = simulate(s)
    sites = [n.firmware_overflows for n in run.chain.node_results]
    assert any(o.get("6-state K", 0) > 0 for o in sites)
    assert run.summary["firmware_saturations"] == sum(sum(o.values()) for o in sites) > 0
