"""The 6-state float filter (firmware_model.six_state_filter): its kinematics against first principles, its algebra
against filterpy step by step, its covariance properties, its reduction to the 2-state filter near vertical, the
pitch singularity, and bad input.

Sources: thesis eqs 3.11-3.14, 3.21-3.31, II.8, II.16 and 4.14-4.15 (thesis digest 2.3-2.7); the Allan values of
thesis table V.1 (the 2-state tests' numbers) on all three axes; encoder quantisation sigma 0.1015 deg (digest 2.6).
"""

import math

import numpy as np
import pytest
from filterpy.kalman import KalmanFilter
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from firmware_model.errors import FirmwareError
from firmware_model.six_state_filter import (
    SixStateFilter,
    SixStateFilterConfig,
    attitude_jacobian,
    body_to_nav,
    continuous_model,
    discrete_model,
    euler_angles,
    euler_rate_matrix,
    inverse_euler_rate_matrix,
    pitch_trig,
    so3_exp,
    wrap_pi_closed,
)
from firmware_model.yaw_filter import FloatYawFilter, YawFilterConfig

DEG = math.pi / 180.0
DT = 1.0 / 1.9
ENC_VAR = (2.0 * math.pi / 1024) ** 2 / 12.0
DRILL_RATE = 60.0 * DEG  # motion.drill_rate_deg_s default


def yaw_config(**kw) -> YawFilterConfig:
    return YawFilterConfig(dt_s=DT, arw_rad_per_sqrt_s=7.38e-3 * DEG, bias_instability_rad_s=3.33e-3 * DEG,
                           bias_tau_s=500.0, **kw)


def six_config(**kw) -> SixStateFilterConfig:
    return SixStateFilterConfig.from_yaw_config(yaw_config(), **kw)


def rot(axis: int, angle: float) -> np.ndarray:
    """The digest 2.3 elementary rotations C1 (z, psi), C2 (y, theta), C3 (x, phi), frame-to-frame."""
    c, s = math.cos(angle), math.sin(angle)
    if axis == 0:
        return np.array([[1, 0, 0], [0, c, s], [0, -s, c]])
    if axis == 1:
        return np.array([[c, 0, -s], [0, 1, 0], [s, 0, c]])
    return np.array([[c, s, 0], [-s, c, 0], [0, 0, 1]])


def trig(theta):
    return np.sin(theta), np.cos(theta)


angles = st.tuples(st.floats(-math.pi, math.pi), st.floats(-1.4, 1.4), st.floats(-math.pi, math.pi))
rates = st.tuples(*[st.floats(-2.0, 2.0)] * 3)


# --- kinematics against first principles -------------------------------------------------------------------------

@given(angles, rates)
def test_euler_rate_matrix_inverts_ii16_and_matches_the_dcm_rate(att, w):
    """E of eq 3.21 inverts eq II.16 (omega = [phi', 0, 0] + C3 [0, theta', 0] + C3 C2 [0, 0, psi'], built here from
    the rotation matrices), and Theta' = E omega moves C_b^n as eq II.8 says (C' = C [omega x])."""
    phi, theta, psi = att
    w = np.array(w)
    e = euler_rate_matrix(np.array(phi), *trig(np.array(theta)))
    rates_ = e @ w
    c3, c2 = rot(0, phi), rot(1, theta)
    omega_back = np.array([rates_[0], 0, 0]) + c3 @ [0, rates_[1], 0] + c3 @ c2 @ [0, 0, rates_[2]]
    np.testing.assert_allclose(omega_back, w, atol=1e-9 * (1 + np.abs(rates_).max()))
    np.testing.assert_allclose(inverse_euler_rate_matrix(np.array(phi), np.array(theta)) @ e, np.eye(3), atol=1e-9 / math.cos(theta))
    c_bn = (rot(0, phi) @ rot(1, theta) @ rot(2, psi)).T
    np.testing.assert_allclose(body_to_nav(np.array(att)), c_bn, atol=1e-15)
    h = 1e-6
    d_c = (body_to_nav(np.array(att) + h * rates_) - body_to_nav(np.array(att) - h * rates_)) / (2 * h)
    wx = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
    np.testing.assert_allclose(d_c, c_bn @ wx, atol=1e-7 * (1 + np.abs(rates_).max()) ** 2)


@given(angles, rates)
def test_f11_is_the_jacobian_of_the_euler_kinematics(att, w):
    """The digest's F11 (2.4) is d(E(Theta) omega)/dTheta: central differences of E omega agree."""
    att, w = np.array(att), np.array(w)

    def kin(a):
        return euler_rate_matrix(a[0], *trig(a[1])) @ w

    h = 1e-6
    num = np.stack([(kin(att + h * np.eye(3)[j]) - kin(att - h * np.eye(3)[j])) / (2 * h) for j in range(3)], -1)
    f11 = attitude_jacobian(att[0], *trig(att[1]), w)
    scale = (1 + np.abs(w).max()) / math.cos(att[1]) ** 3
    np.testing.assert_allclose(f11, num, atol=1e-7 * scale)


@given(angles, rates, st.sampled_from(["rotation", "euler"]))
def test_f_is_the_linearised_error_dynamics_with_its_sign(att, w, disc):
    """F = [[F11, E], [0, -1/tau]] of eqs 3.24 is the Jacobian of the error dynamics for d_Theta = Theta_INS -
    Theta_true and b = b_true - b_hat: d_Theta' = E(Theta_INS) w_hat - E(Theta_INS - d_Theta)(w_hat - b)."""
    cfg = six_config(discretisation=disc)
    att, w = np.array(att), np.array(w)

    def err_rate(x):
        true = att - x[:3]
        return euler_rate_matrix(att[0], *trig(att[1])) @ w - euler_rate_matrix(true[0], *trig(true[1])) @ (w - x[3:])

    h = 1e-7
    num = np.stack([(err_rate(h * np.eye(6)[j]) - err_rate(-h * np.eye(6)[j])) / (2 * h) for j in range(6)], -1)
    f, g, _ = continuous_model(cfg, att[None], w[None])
    scale = (1 + np.abs(w).max()) / math.cos(att[1]) ** 3
    np.testing.assert_allclose(f[0, :3], num, atol=1e-6 * scale)
    np.testing.assert_allclose(g[0, :3, :3], cfg.tuning_a * euler_rate_matrix(att[0], *trig(att[1])))


def _tick_jacobian(cfg, att, w, h=1e-7):
    """-d/dx of the true attitude after one tick, from Theta_INS - d_Theta at the true rate w_hat - b: the error
    transition d_Theta+ = Theta_INS+ - Theta_true+ (numeric, central differences)."""

    def true_after(x):
        return euler_angles(body_to_nav(att - x[:3]) @ so3_exp((w - x[3:]) * cfg.dt_s))

    return np.stack([-wrap_pi_closed(true_after(h * np.eye(6)[j]) - true_after(-h * np.eye(6)[j])) / (2 * h)
                     for j in range(6)], -1)


@settings(max_examples=100)
@given(st.tuples(st.floats(-math.pi, math.pi), st.floats(-1.2, 1.2), st.floats(-math.pi, math.pi)), rates)
def test_rotation_phi_is_the_jacobian_of_the_tick_map(att, w):
    """The "rotation" Phi_11, Phi_12 are the Jacobian of its tick map (the strapdown through C_b^n Exp(rho)) in the
    error coordinates, at the thesis tick (1.9 Hz) and rates up to 2 rad/s."""
    att, w = np.array(att), np.array(w)
    cfg = six_config()
    phi, _, post, _ = discrete_model(cfg, att[None], w[None])
    expected = att + wrap_pi_closed(euler_angles(body_to_nav(att) @ so3_exp(w * DT)) - att)
    # the same angles, continued from the prior's branch (a step of exactly pi, a tie, may land on either side)
    np.testing.assert_allclose(wrap_pi_closed(post[0] - expected), 0.0, atol=1e-12)
    assert np.all(np.abs(post[0] - att) <= math.pi + 1e-12)
    c_post = abs(math.cos(post[0, 1]))
    if c_post < 0.3:  # the numeric derivative of the angles is poor near gimbal lock
        return
    np.testing.assert_allclose(phi[0, :3], _tick_jacobian(cfg, att, w), atol=1e-6 / c_post**2)


@settings(max_examples=60)
@given(st.tuples(st.floats(-math.pi, math.pi), st.floats(-1.2, 1.2), st.floats(-math.pi, math.pi)), rates)
def test_rotation_phi_is_eq_3_24_to_first_order(att, w):
    """Phi("rotation") - (I + F dt) is O(dt^2) (eqs 3.24-3.25 discretised by Euler): halving dt quarters it."""
    att, w = np.array(att), np.array(w)
    diffs = []
    for dt in (0.02, 0.01):
        cfg = six_config(dt_s=dt)
        phi, q_d, _, _ = discrete_model(cfg, att[None], w[None])
        f, g, _ = continuous_model(cfg, att[None], w[None])
        diffs.append(np.abs(phi[0, :3] - (np.eye(3, 6) + f[0, :3] * dt)).max())
        q_euler = g[0] @ np.diag(cfg.q_continuous) @ g[0].T * dt
        np.testing.assert_allclose(q_d[0], q_euler, rtol=0, atol=np.abs(q_euler).max() * 10 * dt * (1 + np.abs(w).max()) / math.cos(att[1]))
    if diffs[0] > 1e-9:
        assert 3.5 < diffs[0] / diffs[1] < 4.5
    else:
        assert diffs[1] < 1e-9


def test_euler_discretisation_grows_under_rotation_and_rotation_does_not():
    """Why "rotation" is the default: spinning about z at the drilling 60 deg/s and 1.9 Hz, the (phi, theta) block of
    the Euler Phi = I + F dt has spectral radius sqrt(1 + (w dt)^2) = 1.14 (the roll/pitch errors grow 14 % a tick)
    and the Euler strapdown grows a 2 deg tilt with them; the exact tick keeps both (an orthogonal block; the tilt
    to 1e-12 over 200 ticks)."""
    w = np.array([[0.0, 0.0, DRILL_RATE]])
    for disc, radius in (("euler", math.hypot(1.0, DRILL_RATE * DT)), ("rotation", 1.0)):
        phi, _, _, _ = discrete_model(six_config(discretisation=disc), np.zeros((1, 3)), w)
        assert np.abs(np.linalg.eigvals(phi[0, :2, :2])).max() == pytest.approx(radius, rel=1e-12)
    tilt = 2.0 * DEG
    att0 = np.array([0.0, tilt, 0.0])
    for disc in ("euler", "rotation"):  # a tube tilted 2 deg spinning about its own (fixed) axis
        kf = SixStateFilter(six_config(discretisation=disc), 1, att0)
        for _ in range(200):
            kf.predict([0.0, 0.0, DRILL_RATE])
        c = np.cos(kf.attitude_rad[0, 0]) * np.cos(kf.attitude_rad[0, 1])  # cos(inclination) of the body z axis
        if disc == "rotation":
            assert c == pytest.approx(math.cos(tilt), abs=1e-12)
        else:
            assert math.degrees(math.acos(np.clip(c, -1, 1))) > 20.0


# --- filterpy, step by step ---------------------------------------------------------------------------------------

ATT = [0, 1, 2]
MAX_ANGLE_SIGMA = 0.3  # rad: the filterpy comparison runs while the angle errors are small (the linearised regime)


def _rel_cov_error(ours: np.ndarray, ref: np.ndarray) -> float:
    """max |dP_ij| / sqrt(P_ii P_jj) (the covariance's own scale; an off-diagonal element may be near zero)."""
    d = np.sqrt(np.outer(np.diag(ref), np.diag(ref)))
    return float((np.abs(ours - ref) / d).max())


@st.composite
def filter_cases(draw, pitch_max=(0.2, 1.2, 1.5707, "singular"), rate_max=(0.05, 1.3, 2.5), log_var_min=-10.0):
    cfg = six_config(
        discretisation=draw(st.sampled_from(["rotation", "euler"])),
        singularity=draw(st.sampled_from(["hold", "decouple"])),
        b_tuning=draw(st.sampled_from(["process_noise", "noise_gain"])),
        tuning_a=draw(st.floats(0.5, 3.0)), tuning_b=draw(st.floats(1.0, 10.0)),
        bias_tau_s=draw(st.floats(50.0, 5000.0)),
        singularity_margin_rad=draw(st.floats(1.0, 15.0)) * DEG,
    )
    return dict(cfg=cfg, realizations=draw(st.integers(1, 3)), ticks=draw(st.sampled_from([5, 20, 40, 40])),
                seed=draw(st.integers(0, 2**32 - 1)), pitch_max=draw(st.sampled_from(pitch_max)),
                rate_max=draw(st.sampled_from(rate_max)), xy_rate_max=draw(st.sampled_from([0.02, 0.2, 2.5])),
                p_update=draw(st.floats(0.0, 1.0)),
                p_roll_pitch=draw(st.floats(0.0, 0.5)),
                log_var=draw(st.tuples(st.floats(log_var_min, -2), st.floats(log_var_min, -2))))


def _sequence(case):
    """Random attitudes, rates, references (a turn away at random) and update masks of one case."""
    rng = np.random.default_rng(case["seed"])
    R, K = case["realizations"], case["ticks"]
    if case["pitch_max"] == "singular":  # start at or inside the singularity margin
        m = case["cfg"].singularity_margin_rad
        pitch = rng.choice([-1.0, 1.0], R) * (np.pi / 2 - rng.uniform(0.0, 1.5 * m, R))
    else:
        pitch = rng.uniform(-case["pitch_max"], case["pitch_max"], R)
    att0 = np.c_[rng.uniform(-np.pi, np.pi, R), pitch, rng.uniform(-10, 10, R)]
    xy = min(case["xy_rate_max"], case["rate_max"])
    lo, hi = sorted(case["log_var"])
    steps = []
    for _ in range(K):
        steps.append(dict(
            rates=rng.uniform(-1.0, 1.0, (R, 3)) * [xy, xy, case["rate_max"]],
            update=rng.random() < case["p_update"], roll_pitch=rng.random() < case["p_roll_pitch"],
            mask=rng.random(R) < 0.8, ref_noise=rng.normal(0, 0.2, (R, 3)) + rng.choice([0, 2 * np.pi], (R, 3)),
            var=10 ** rng.uniform(lo, hi, (R, 3))))
    return att0, rng.normal(0, 1e-3, (R, 3)), steps


def _in_envelope(kf, pitch_limit) -> bool:
    if np.sqrt(kf.covariance[:, ATT, ATT]).max() > MAX_ANGLE_SIGMA:
        event("stopped: angle sigma > 0.3 rad")
        return False
    if np.abs(kf.attitude_rad[:, 1]).max() > pitch_limit:
        event("stopped: pitch beyond the envelope")
        return False
    return True


def _check_against_filterpy(case, tol: float, pitch_limit: float) -> None:
    """Run ``case`` through our filter and, tick by tick from our prior, through filterpy's KalmanFilter with our
    Phi, Q_d, H, R (the closed-loop reset outside); compare P, the correction and the state to ``tol``."""
    cfg, R = case["cfg"], case["realizations"]
    att0, b0, steps = _sequence(case)
    kf = SixStateFilter(cfg, R, att0, b0)
    checked = 0
    for s in steps:
        if not _in_envelope(kf, pitch_limit):
            break
        p_prior, bias_prior = kf.covariance.copy(), kf.bias_rad_s.copy()
        kf.predict(s["rates"])
        for r in range(R):
            ref = KalmanFilter(dim_x=6, dim_z=1)
            ref.P, ref.F, ref.Q = p_prior[r].copy(), kf.last_phi[r], kf.last_q_d[r]
            ref.predict()
            assert _rel_cov_error(kf.covariance[r], ref.P) <= tol
        np.testing.assert_array_equal(kf.bias_rad_s, bias_prior)
        checked += 1
        if not s["update"] or not _in_envelope(kf, pitch_limit):
            continue
        p_pred, att_pred = kf.covariance.copy(), kf.attitude_rad.copy()
        axes = [0, 1, 2] if s["roll_pitch"] else [2]
        truth_ref = att_pred + s["ref_noise"]
        if s["roll_pitch"]:
            kf.update(truth_ref[:, 2], s["var"][:, 2], mask=s["mask"], reference_roll_pitch_rad=truth_ref[:, :2],
                      roll_pitch_variance_rad2=s["var"][:, :2])
        else:
            kf.update(truth_ref[:, 2], s["var"][:, 2], mask=s["mask"])
        for r in range(R):
            if not s["mask"][r]:
                np.testing.assert_array_equal(kf.covariance[r], p_pred[r])
                np.testing.assert_array_equal(kf.attitude_rad[r], att_pred[r])
                continue
            ref = KalmanFilter(dim_x=6, dim_z=len(axes))
            ref.P, ref.H, ref.R = p_pred[r].copy(), kf.last_h, np.diag(s["var"][r, axes])
            z = wrap_pi_closed(att_pred[r, axes] - truth_ref[r, axes])
            assert np.all(np.abs(z) <= math.pi)
            ref.update(z.reshape(-1, 1))
            assert _rel_cov_error(kf.covariance[r], ref.P) <= tol
            bound = np.sqrt(np.diag(p_pred[r]) * float(z @ np.linalg.inv(ref.S) @ z))  # |dx_i| <= bound_i
            np.testing.assert_array_less(np.abs(kf.last_correction[r] - ref.x[:, 0]), tol * bound + 1e-300)
            eps = 4 * np.finfo(float).eps
            np.testing.assert_array_less(np.abs(kf.attitude_rad[r] - (att_pred[r] - ref.x[:3, 0])),
                                         tol * bound[:3] + eps * np.abs(att_pred[r]) + 1e-300)
            np.testing.assert_array_less(np.abs(kf.bias_rad_s[r] - (bias_prior[r] + ref.x[3:, 0])),
                                         tol * bound[3:] + eps * np.abs(bias_prior[r]) + 1e-300)
    event(f"ticks checked: {checked // 10 * 10}+")
    if kf.singular_ticks.any():
        event("near-singular ticks checked")


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(filter_cases(pitch_max=(0.2, 1.0), rate_max=(0.05, 1.3), log_var_min=-8.0))
def test_matches_filterpy_kalman_filter_step_by_step(case):
    """Each tick, filterpy's KalmanFilter starts from our prior P and is given our F (Phi), Q (Q_d), H and R: its
    predicted and updated P equal ours to 1e-12 relative (to sqrt(P_ii P_jj)), its correction x our dx to 1e-12 of
    the bound sqrt(P_ii z^T S^-1 z) of |dx_i|, and our attitude and biases are the strapdown plus filterpy's
    correction.  Random sequences: both discretisations, any tuning, rates up to 1.3 rad/s (75 deg/s, above the
    drilling 60 and the lab's 71 deg/s), R from 1e-8 rad^2 (a forwarded yaw of 0.006 deg) to 1e-2, yaw-only and
    roll/pitch/yaw updates, per-realization masks, references a turn away (the (-pi, pi] wrap), while |pitch| <=
    60 deg and every angle sigma < 0.3 rad (the linearised regime).  Measured over 1500 such sequences: worst
    3.8e-14.  (Starting filterpy from our P each tick keeps the check on the algebra: the recursion itself
    amplifies rounding under fast rotation, filterpy against filterpy with P0 one ulp apart drifts to ~1e-8 over
    1000 ticks at 1.3 rad/s; the free-running check below is at slow rates.)"""
    _check_against_filterpy(case, 1e-12, math.radians(60.0))


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(filter_cases())
def test_matches_filterpy_through_the_singularity(case):
    """The same check over the whole envelope: pitch up to 90 deg with both singularity treatments (held or
    decoupled Euler-rate terms), rates up to 2.5 rad/s, R down to 1e-10 rad^2, at 1e-9 relative.  Near gimbal lock
    roll and yaw errors become one rotation and P's condition number passes 1e8: the same algebra in another
    order then differs by up to ~3e-12 (measured, 800 sequences), which is why this envelope has its own bound."""
    _check_against_filterpy(case, 1e-9, math.pi)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.integers(0, 2**32 - 1), st.sampled_from(["rotation", "euler"]))
def test_free_running_filterpy_agrees_at_slow_rates(seed, disc):
    """filterpy's KalmanFilter carrying its own P over 200 ticks (our F, Q, H, R each tick; the closed-loop reset
    outside, as in the 2-state test) stays within 1e-12 relative of ours at lab rates (<= 0.1 rad/s)."""
    rng = np.random.default_rng(seed)
    cfg = six_config(discretisation=disc)
    R = 2
    kf = SixStateFilter(cfg, R, np.c_[rng.uniform(-0.3, 0.3, (R, 2)), rng.uniform(-3, 3, R)])
    refs = [KalmanFilter(dim_x=6, dim_z=1) for _ in range(R)]
    for ref in refs:
        ref.P = cfg.p0.copy()
    for k in range(200):
        kf.predict(rng.uniform(-0.1, 0.1, (R, 3)))
        for r, ref in enumerate(refs):
            ref.F, ref.Q = kf.last_phi[r], kf.last_q_d[r]
            ref.predict()
        if k % 3:
            yaw = kf.yaw_rad.copy()
            kf.update(yaw + rng.normal(0, 1e-3, R), ENC_VAR)
            for r, ref in enumerate(refs):
                ref.H, ref.R = kf.last_h, np.array([[ENC_VAR]])
                ref.x = np.zeros((6, 1))
                ref.update(np.array([[wrap_pi_closed(yaw[r] - (yaw[r] + 0.0))]]))
        for r, ref in enumerate(refs):
            assert _rel_cov_error(kf.covariance[r], ref.P) <= 1e-12


# --- covariance properties ----------------------------------------------------------------------------------------

@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(filter_cases(rate_max=(0.05, 1.3)))
def test_covariance_stays_symmetric_positive_definite_and_finite(case):
    """Over random sequences (including the singular margin, both treatments): P is exactly symmetric (it is
    symmetrised each step) and finite and the estimates are finite, always; P is positive definite (Cholesky
    succeeds, smallest eigenvalue > 0) while the angle sigmas are below 1 rad.  Beyond that a linearised filter
    means nothing and P can be numerically singular: the "euler" form under fast rotation grows P exponentially
    (the instability above), and near gimbal lock roll and yaw errors are individually unbounded (only their sum
    or difference is defined), though the "rotation" form keeps them finite."""
    att0, b0, steps = _sequence(case)
    kf = SixStateFilter(case["cfg"], case["realizations"], att0, b0)
    linear = True
    for s in steps:
        kf.predict(s["rates"])
        if s["update"]:
            kf.update(kf.yaw_rad + s["ref_noise"][:, 2], s["var"][:, 2], mask=s["mask"])
        p = kf.covariance
        np.testing.assert_array_equal(p, np.swapaxes(p, -1, -2))
        assert np.all(np.isfinite(kf.attitude_rad)) and np.all(np.isfinite(kf.bias_rad_s))
        if case["cfg"].discretisation == "rotation" or linear:
            assert np.all(np.isfinite(p))
        linear = linear and np.sqrt(kf.covariance[:, ATT, ATT]).max() <= 1.0
        if linear:
            np.linalg.cholesky(p)  # raises LinAlgError unless positive definite
            assert np.all(np.linalg.eigvalsh(p)[:, 0] > 0.0)
    event("stayed in the linearised regime" if linear else "left the linearised regime")


def test_yaw_update_never_raises_the_variance_and_zero_variance_reference_pins_yaw():
    """An update cannot increase any variance (P+ = P- - P H^T S^-1 H P, a PSD subtraction); an exact reference
    (R = 0) makes P_psi_psi zero up to rounding and the yaw equal to it."""
    kf = SixStateFilter(six_config(), 2, [[0.1, 0.2, 1.0], [0.0, -0.3, -2.0]])
    for _ in range(30):
        kf.predict([[0.01, -0.02, 1.0], [0.0, 0.01, -0.5]])
    before = np.diagonal(kf.covariance, axis1=1, axis2=2).copy()
    kf.update([0.5, -1.0], ENC_VAR)
    assert np.all(np.diagonal(kf.covariance, axis1=1, axis2=2) <= before * (1 + 1e-14))
    kf.update([0.6, -1.1], 0.0)
    assert np.all(kf.yaw_variance_rad2 < 1e-15 * before[:, 2])
    np.testing.assert_allclose(wrap_pi_closed(kf.yaw_rad - [0.6, -1.1]), 0.0, atol=1e-12)


# --- near vertical: the 2-state filter ------------------------------------------------------------------------------

@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from(["rotation", "euler"]), st.sampled_from([1, 3, 40]))
def test_exactly_vertical_yaw_bias_block_is_the_two_state_filter(seed, disc, every):
    """At phi = theta = 0 with rates about z only (any sequence, the drilling rate included), the 6-state model's
    (psi, b_z) block decouples exactly: E = I, the psi row of F11 is zero (digest 2.4), the rotation of the roll/pitch
    errors stays in their block, G Q G^T is diagonal, and H = e3 reads the block alone.  So the yaw, the z bias and
    the (psi, b_z) covariance equal the 2-state filter's (same tuning) to rounding: P to 1e-12 relative, the yaw to
    1e-12 rad and the bias to 1e-15 rad/s (the tolerances of the 2-state filter's filterpy test; the "rotation"
    strapdown reaches the yaw through atan2, one rounding of the angle per tick)."""
    rng = np.random.default_rng(seed)
    R, K = 3, 300
    b0 = rng.normal(0, 1e-3, R)
    six = SixStateFilter(six_config(discretisation=disc), R, np.c_[np.zeros((R, 2)), rng.uniform(-3, 3, R)],
                         np.c_[np.zeros((R, 2)), b0])
    two = FloatYawFilter(yaw_config(), R, initial_yaw_rad=six.yaw_rad.copy(), bias_offset_rad_s=b0)
    for k in range(K):
        wz = rng.uniform(-1.3, 1.3) + rng.normal(0, 2e-4, R)
        six.predict(np.c_[np.zeros((R, 2)), wz])
        two.predict(wz)
        if k % every == 0:
            ref = six.yaw_rad + rng.normal(0, 2e-3, R)
            six.update(ref, ENC_VAR)
            two.update(ref, ENC_VAR)
        np.testing.assert_allclose(six.covariance[:, [2, 5]][:, :, [2, 5]], two.covariance, rtol=1e-12, atol=0)
        np.testing.assert_allclose(six.yaw_rad, two.yaw_rad, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(six.bias_rad_s[:, 2], two.bias_rad_s, rtol=0, atol=1e-15)
    np.testing.assert_array_equal(six.attitude_rad[:, :2], 0.0)
    np.testing.assert_array_equal(six.bias_rad_s[:, :2], 0.0)


def _tilted_two_state(theta):
    """The 2-state filter the 6-state yaw reduces to at a static tilt (derivation in the test below)."""
    cfg, sec = yaw_config(), 1.0 / math.cos(theta)
    return YawFilterConfig(dt_s=DT, arw_rad_per_sqrt_s=cfg.arw_rad_per_sqrt_s * sec,
                           bias_instability_rad_s=cfg.bias_instability_rad_s * sec, bias_tau_s=cfg.bias_tau_s,
                           initial_yaw_sigma_rad=cfg.initial_yaw_sigma_rad,
                           initial_bias_sigma_rad_s=cfg.initial_bias_sigma_rad_s * sec)


@settings(max_examples=30, deadline=None)
@given(st.floats(-0.5, 0.5), st.floats(-0.5, 0.5), st.sampled_from(["rotation", "euler"]), st.sampled_from([1, 7, 37]))
def test_static_tilt_yaw_block_is_a_scaled_two_state_filter_within_tan2_theta(phi, theta, disc, every):
    """Near vertical with zero roll/pitch (and yaw) rates the tolerance is derived, not chosen.

    Static, omega_hat = 0: Phi_11 = I, Phi_12 = dt E, Q_d,11 = A^2 sigma^2 E E^T dt.  In body-rate coordinates
    a = E^-1 d_Theta every axis is the same independent 2-state pair (a_i, b_i), and the yaw error is
    d_psi = e3^T E a = u.a with u = (0, s_phi, c_phi) / c_theta, |u| = 1 / c_theta.  The pair along u is observed,
    the rest never: d_psi and b_eff = (s_phi b_y + c_phi b_z) / c_theta form a 2-state filter with Q scaled by
    sec^2(theta), the initial bias variance scaled by sec^2(theta) and the initial yaw variance and R unchanged
    (E^-T u / |u| = (0, 0, c_theta): the yaw prior is the thesis's).  Hence exactly, for every tick:
        P6_psi_psi = P2'_yy,   P6_psi_bz = c_phi c_theta P2'_yb,
        P6_bz_bz = c_phi^2 c_theta^2 P2'_bb + s_phi^2 P_perp,  P_perp = f^2 P_perp + q_b (the unobserved bias),
    with P2' that scaled 2-state filter; and since the Riccati recursion is monotone in Q, P0 and R and
    P(sQ, sP0, sR) = s P(Q, P0, R), the 6-state yaw variance sits between the 2-state filter's and sec^2(theta)
    times it: the relative tolerance is tan^2(theta) (1.2e-3 at 2 deg), whatever the roll."""
    cfg6 = six_config(discretisation=disc)
    six = SixStateFilter(cfg6, 1, [phi, theta, 0.3])
    two = FloatYawFilter(yaw_config(), 1)
    scaled = FloatYawFilter(_tilted_two_state(theta), 1)
    f, q_b = 1.0 - DT / 500.0, yaw_config().q_d[1, 1]
    p_perp = yaw_config().initial_bias_sigma_rad_s**2
    cp, ct, sp = math.cos(phi), math.cos(theta), math.sin(phi)
    for k in range(400):
        six.predict([0.0, 0.0, 0.0])
        two.predict(0.0)
        scaled.predict(0.0)
        p_perp = f * f * p_perp + q_b
        if k % every == 0:
            six.update(0.3, ENC_VAR)  # the truth: the attitude is exact, so nothing is corrected
            two.update(0.0, ENC_VAR)
            scaled.update(0.0, ENC_VAR)
        p6, p2 = six.covariance[0], scaled.covariance[0]
        np.testing.assert_allclose(p6[2, 2], p2[0, 0], rtol=1e-10)
        np.testing.assert_allclose(p6[2, 5], cp * ct * p2[0, 1], rtol=1e-10)
        np.testing.assert_allclose(p6[5, 5], (cp * ct) ** 2 * p2[1, 1] + sp**2 * p_perp, rtol=1e-10)
        ratio = p6[2, 2] / two.covariance[0, 0, 0]
        assert 1.0 - 1e-12 <= ratio <= (1.0 + math.tan(theta) ** 2) * (1.0 + 1e-12)


# --- the pitch singularity ------------------------------------------------------------------------------------------

@pytest.mark.parametrize("disc", ["rotation", "euler"])
@pytest.mark.parametrize("mode", ["hold", "decouple"])
def test_pitching_through_90_deg_counts_the_margin_and_stays_finite(disc, mode):
    """A tube pitching at 2 deg/s from 80 deg through 90 deg (horizontal) to 122 deg: every tick whose Euler-rate terms
    are evaluated within the 5 deg margin is counted (the count is recomputed here from the attitudes), nothing is
    NaN or infinite, and with "hold" no Euler-rate term of Phi exceeds 1/sin(margin) times the rate scale."""
    margin = 5.0 * DEG
    cfg = six_config(discretisation=disc, singularity=mode, singularity_margin_rad=margin)
    kf = SixStateFilter(cfg, 1, [0.0, 80.0 * DEG, 0.0])
    expected = 0
    for k in range(40):
        prior = kf.attitude_rad.copy()
        kf.predict([0.0, 2.0 * DEG, 0.0])  # 2 deg/s about the body y axis
        evaluated = kf.attitude_rad[0, 1] if disc == "rotation" else prior[0, 1]
        expected += abs(math.cos(evaluated)) < math.sin(margin)
        if k % 2 == 0:
            kf.update(kf.yaw_rad + 1e-3, ENC_VAR)
        assert kf.singular_ticks[0] == expected
        assert np.all(np.isfinite(kf.covariance)) and np.all(np.isfinite(kf.attitude_rad))
        if mode == "hold" and kf.near_singular[0]:
            e_terms = np.abs(kf.last_phi[0, :3, 3:]) / DT
            assert e_terms.max() <= 1.0 / math.sin(margin) * (1 + 1e-12) * 1.01
    assert 0 < kf.singular_ticks[0] < 40
    if disc == "rotation":  # the direction cosine strapdown is exact through gimbal lock: the body z axis
        c_bn = body_to_nav(kf.attitude_rad)[0]  # has turned 40 ticks x 2 deg/s x dt about the body y axis
        tilt = math.degrees(math.acos(np.clip(c_bn[2, 2], -1, 1)))
        assert tilt == pytest.approx(80.0 + 40 * 2.0 * DT * 1.0, abs=0.5)


@pytest.mark.parametrize("disc", ["rotation", "euler"])
def test_decouple_inside_the_margin_is_the_two_state_filter_for_yaw(disc):
    """Inside the margin the "decouple" treatment propagates the (psi, b_z) block as the 2-state filter does
    (Phi_11 = I, Phi_12 = dt I, G_C = A I; the Euler strapdown with E = I): the (psi, b_z) covariance is the
    2-state filter's and the yaw advances by dt w_z."""
    cfg = six_config(singularity="decouple", discretisation=disc)
    kf = SixStateFilter(cfg, 1, [0.2, 88.0 * DEG, 0.4])
    two = FloatYawFilter(yaw_config(), 1)
    for k in range(50):
        kf.predict([0.0, 0.0, 0.0])
        two.predict(0.0)
        if k % 4 == 0:
            kf.update(0.4, ENC_VAR)
            two.update(0.0, ENC_VAR)
        np.testing.assert_allclose(kf.covariance[0][np.ix_([2, 5], [2, 5])], two.covariance[0], rtol=1e-12)
    assert kf.singular_ticks[0] == 50
    if disc == "euler":
        yaw = kf.yaw_rad[0]
        kf.predict([0.0, 0.0, 0.01])
        assert kf.yaw_rad[0] == pytest.approx(yaw + 0.01 * DT, rel=1e-14)


def test_hold_bounds_the_euler_terms_by_the_margin():
    """pitch_trig with "hold": |1/cos| <= 1/sin(margin) and |tan| <= cot(margin) on both sides of +/-90 deg, the
    true values outside; the mask marks exactly |cos theta| < sin(margin)."""
    m = 5.0 * DEG
    theta = np.radians([0.0, 60.0, 84.9, 85.1, 89.999, 90.0, 90.001, 95.1, -85.1, -90.0, -94.9, 180.0])
    s, c, near = pitch_trig(theta, m, hold=True)
    np.testing.assert_array_equal(near, np.abs(np.cos(theta)) < math.sin(m))
    assert np.all(np.abs(1.0 / c) <= 1.0 / math.sin(m) * (1 + 1e-15))
    np.testing.assert_array_equal(s[~near], np.sin(theta[~near]))
    np.testing.assert_array_equal(np.sign(c[near]), np.where(np.cos(theta[near]) < 0, -1.0, 1.0))


# --- consistency against a simulated truth ---------------------------------------------------------------------------

def _simulate_truth_run(tilt_deg, rate, ticks, R=300, every=1, seed=5, roll_pitch=False, discretisation="rotation"):
    """Monte Carlo: R tubes at ``tilt_deg`` spinning about their own axis at ``rate``, true attitude and bias
    drawn from the filter's P0 around its initial estimate, a gyro with the model's bias (Gauss-Markov, B = 1) and
    white noise, the encoder-sigma yaw reference (and, with ``roll_pitch``, roll/pitch references of 0.1 deg).
    Returns the 6-state and yaw-only normalised errors per tick (R, ticks).

    tau = 1e5 s: the filter holds b_hat between updates (as the 2-state filter does) while its error model lets the
    bias error decay as -b/tau; with the thesis's 500 s and this test's 0.05 deg/s initial bias sigma that
    mismatch alone shows (the z-bias error reaches ~2.6 sigma in 160 s, at vertical too), so the test keeps it out
    to check the attitude model."""
    rng = np.random.default_rng(seed)
    cfg = six_config(tuning_b=1.0, bias_tau_s=1e5, discretisation=discretisation)  # B = 1: the truth's bias noise
    est0 = np.c_[np.zeros(R), np.full(R, tilt_deg * DEG), rng.uniform(-np.pi, np.pi, R)]
    l0 = np.sqrt(np.diag(cfg.p0))
    err0 = rng.standard_normal((R, 6)) * l0
    c_true = body_to_nav(est0 - err0[:, :3])
    b_true = err0[:, 3:].copy()  # the estimate starts at b_hat = 0
    kf = SixStateFilter(cfg, R, est0)
    sig_n = np.array(cfg.arw_rad_per_sqrt_s) / math.sqrt(DT)
    f = 1.0 - DT / np.array(cfg.bias_tau_s)
    q_b = np.sqrt(cfg.q_continuous[3:] * DT)
    w_true = np.array([0.0, 0.0, rate])
    psi_true = euler_angles(c_true)[:, 2]
    nees, nees_yaw = np.zeros((R, ticks)), np.zeros((R, ticks))
    for k in range(ticks):
        meas = w_true + b_true + sig_n * rng.standard_normal((R, 3))
        kf.predict(meas)
        c_true = c_true @ so3_exp(np.broadcast_to(w_true * DT, (R, 3)))
        b_true = f * b_true + q_b * rng.standard_normal((R, 3))
        true_att = euler_angles(c_true)
        psi_true = psi_true + wrap_pi_closed(true_att[:, 2] - psi_true)
        true_att[:, 2] = psi_true
        if k % every == 0:
            ref = true_att + rng.standard_normal((R, 3)) * [0.1 * DEG, 0.1 * DEG, math.sqrt(ENC_VAR)]
            if roll_pitch:
                kf.update(ref[:, 2], ENC_VAR, reference_roll_pitch_rad=ref[:, :2], roll_pitch_variance_rad2=(0.1 * DEG) ** 2)
            else:
                kf.update(ref[:, 2], ENC_VAR)
        e = np.c_[wrap_pi_closed(kf.attitude_rad - true_att), b_true - kf.bias_rad_s]
        nees[:, k] = np.einsum("ri,ri->r", e, np.linalg.solve(kf.covariance, e[..., None])[..., 0])
        nees_yaw[:, k] = e[:, 2] ** 2 / kf.yaw_variance_rad2
    return nees, nees_yaw


@pytest.mark.parametrize("tilt_deg, every, roll_pitch", [(15.0, 1, False), (45.0, 5, False), (30.0, 3, True)])
def test_filter_is_consistent_with_a_simulated_spinning_tilted_tube(tilt_deg, every, roll_pitch):
    """The "rotation" model is the truth's linearisation (checked as a whole): 300 simulated tubes spinning at the drilling 60 deg/s
    about their own axis at 15-45 deg inclination, yaw-only encoder updates (or with roll/pitch): the normalised
    estimation error squared averages its dimension, 6 for the whole state (chi-square, 300 x 6 dof: the
    realization mean of a tick has sigma 0.2) and 1 for the yaw, over the last 100 ticks (bounds +/- 20 %,
    many sigmas of the 30000-sample mean, loose enough for the linearisation's second-order terms)."""
    nees, nees_yaw = _simulate_truth_run(tilt_deg, DRILL_RATE, 300, every=every, roll_pitch=roll_pitch)
    late = slice(200, 300)
    assert 0.8 * 6 < nees[:, late].mean() < 1.2 * 6
    assert 0.8 < nees_yaw[:, late].mean() < 1.2


def test_euler_discretisation_is_inconsistent_under_drilling_rotation():
    """The same truth at 15 deg and 60 deg/s with the digest's Euler form: the normalised error is 10^4 and more
    times its dimension within 100 ticks (the roll/pitch error growth of sqrt(1 + (w dt)^2) per tick)."""
    nees, _ = _simulate_truth_run(15.0, DRILL_RATE, 100, R=100, discretisation="euler")
    assert nees[:, -10:].mean() > 1e4 * 6


# --- measurement model, wrap, bad input -----------------------------------------------------------------------------

def test_innovation_wrap_is_minus_pi_exclusive_pi_inclusive():
    """Digest 2.6: innovations into (-180, 180] deg; a reference a turn (or several) away is the same reference."""
    np.testing.assert_array_equal(wrap_pi_closed([math.pi, -math.pi, 3 * math.pi, 0.0]), [math.pi, math.pi, math.pi, 0.0])
    x = np.linspace(-20, 20, 1001)
    w = wrap_pi_closed(x)
    assert np.all((w > -math.pi) & (w <= math.pi))
    turns = (w - x) / (2 * math.pi)
    np.testing.assert_allclose(turns, np.round(turns), atol=1e-12)
    a, b = SixStateFilter(six_config(), 1, [0, 0, 179 * DEG]), SixStateFilter(six_config(), 1, [0, 0, 179 * DEG])
    a.update(-179 * DEG, ENC_VAR)  # 2 deg ahead across the +/-180 seam
    b.update(181 * DEG + 4 * math.pi, ENC_VAR)
    np.testing.assert_allclose(a.last_correction, b.last_correction, rtol=1e-12)
    assert a.last_correction[0, 2] < 0  # yaw moves forward (dx = K z, z = -2 deg)


def test_yaw_only_update_touches_roll_pitch_only_through_their_covariance():
    """H = e3 (yaw only, digest 2.6): with no roll/pitch-yaw covariance (vertical, z rates) a yaw update leaves
    roll, pitch and their variances alone; roll/pitch references (H = [I3 0]) pull them and shrink their variances."""
    kf = SixStateFilter(six_config(), 1, [0.0, 0.0, 0.0])
    for _ in range(5):
        kf.predict([0.0, 0.0, 0.5])
    p_rp = kf.covariance[0, :2, :2].copy()
    kf.update(kf.yaw_rad + 0.01, ENC_VAR)
    np.testing.assert_array_equal(kf.attitude_rad[0, :2], 0.0)
    np.testing.assert_array_equal(kf.covariance[0, :2, :2], p_rp)
    kf.update(kf.yaw_rad, ENC_VAR, reference_roll_pitch_rad=[0.02, -0.01], roll_pitch_variance_rad2=(0.1 * DEG) ** 2)
    assert np.all(np.diag(kf.covariance[0])[:2] < 0.02 * np.diag(p_rp))
    np.testing.assert_allclose(kf.attitude_rad[0, :2], [0.02, -0.01], rtol=0.01)


def test_from_yaw_config_carries_the_two_state_tuning_and_q_matches():
    """The 6-state tuning built from a 2-state one: the same dt, Allan values, tau, A, B and b_tuning; at vertical
    its Q_d's (psi, b_z) entries are the 2-state filter's q_d (eqs 4.14-4.15, both readings of B)."""
    for reading in ("process_noise", "noise_gain"):
        two = yaw_config(b_tuning=reading, tuning_a=1.7, tuning_b=4.0)
        six = SixStateFilterConfig.from_yaw_config(two)
        assert (six.dt_s, six.tuning_a, six.tuning_b, six.b_tuning) == (two.dt_s, 1.7, 4.0, reading)
        _, q_d, _, _ = discrete_model(six, np.zeros((1, 3)), np.zeros((1, 3)))
        np.testing.assert_allclose(q_d[0][np.ix_([2, 5], [2, 5])], two.q_d, rtol=1e-14)
        np.testing.assert_allclose(six.p0[np.ix_([2, 5], [2, 5])], two.p0)


@pytest.mark.parametrize("kw, fragment", [
    (dict(b_tuning="B^2"), "b_tuning"),
    (dict(singularity="switch"), "singularity"),
    (dict(discretisation="rk4"), "discretisation"),
    (dict(singularity_margin_rad=0.0), "singularity_margin_rad"),
    (dict(singularity_margin_rad=math.pi / 2), "singularity_margin_rad"),
    (dict(tuning_b=-5.0), "tuning_b"),
    (dict(tuning_a=0.0), "tuning_a"),
    (dict(bias_tau_s=(500.0, -1.0, 500.0)), r"bias_tau_s \(y\)"),
    (dict(bias_tau_s=0.1), "dt_s"),
    (dict(arw_rad_per_sqrt_s=(1e-4, float("nan"), 1e-4)), r"arw_rad_per_sqrt_s \(y\)"),
    (dict(bias_instability_rad_s=-1e-5), "bias_instability_rad_s"),
    (dict(bias_instability_rad_s=1e200), "overflows"),
    (dict(arw_rad_per_sqrt_s=(1e-4, 1e-4)), "3 numbers"),
])
def test_bad_configuration_names_the_field(kw, fragment):
    with pytest.raises(FirmwareError, match=fragment):
        six_config(**kw)


def test_bad_input_is_rejected_with_its_name():
    kf = SixStateFilter(six_config(), 2)
    with pytest.raises(FirmwareError, match="gyro rates: non-finite"):
        kf.predict([[0.0, float("nan"), 0.0], [0.0, 0.0, 0.0]])
    with pytest.raises(FirmwareError, match="gyro rates: shape"):
        kf.predict(np.zeros((3, 3)))
    with pytest.raises(FirmwareError, match="reference variance: negative"):
        kf.update(0.0, -1.0)
    with pytest.raises(FirmwareError, match="give both or neither"):
        kf.update(0.0, ENC_VAR, reference_roll_pitch_rad=[0.0, 0.0])
    with pytest.raises(FirmwareError, match="roll/pitch variance: shape"):
        kf.update(0.0, ENC_VAR, reference_roll_pitch_rad=[0.0, 0.0], roll_pitch_variance_rad2=[1e-6, 1e-6, 1e-6])
    with pytest.raises(FirmwareError, match="pitch outside"):
        SixStateFilter(six_config(), 1, [0.0, 2.0, 0.0])
    with pytest.raises(FirmwareError, match="realizations"):
        SixStateFilter(six_config(), 0)


@settings(max_examples=50, deadline=None)
@given(st.tuples(st.floats(-math.pi, math.pi), st.floats(-1.2, 1.2), st.floats(-math.pi, math.pi)),
       st.tuples(*[st.floats(-1.3, 1.3)] * 3))
def test_rotation_q_d_is_the_rate_noise_integrated_over_the_turning_tick(att, w):
    """Rate noise n(s) at time s of the tick reaches the posterior error as E+ Exp(-w_hat (dt - s)) n(s) ds, so
    Q_d,11 = A^2 E+ [int_0^dt Exp(-w u) diag(sigma_v^2) Exp(-w u)^T du] E+^T.  With unequal per-axis sigmas (where
    the tick's rotation matters) the mid-tick form agrees with that integral (Simpson, 201 points) within the
    midpoint rule's error bound."""
    att, w = np.array(att), np.array(w)
    cfg = six_config(arw_rad_per_sqrt_s=(1e-4, 3e-4, 2e-4), tuning_a=1.3)
    _, q_d, post, _ = discrete_model(cfg, att[None], w[None])
    s_post, c_post, _ = pitch_trig(post[:, 1], cfg.singularity_margin_rad, hold=True)  # held inside the margin
    e_post = euler_rate_matrix(post[0, 0], s_post[0], c_post[0])
    u = np.linspace(0.0, DT, 201)
    rots = so3_exp(-np.outer(u, w))
    integrand = rots @ np.diag(cfg.q_continuous[:3]) @ np.swapaxes(rots, -1, -2)
    weights = np.ones(201)
    weights[1:-1:2], weights[2:-1:2] = 4.0, 2.0
    integral = np.tensordot(weights * (DT / 600.0), integrand, axes=1)
    exact = cfg.tuning_a**2 * e_post @ integral @ e_post.T
    # midpoint rule: |error| <= dt^3 / 24 max|f''|, |f''| <= 4 |w|^2 max(sigma^2) (two commutators with [w x]),
    # and |(E X E^T)_ij| <= ||E||_inf^2 max|X_ij|
    bound = cfg.tuning_a**2 * np.abs(e_post).sum(1).max() ** 2 * DT**3 / 24 * 4 * (w @ w) * cfg.q_continuous[:3].max()
    np.testing.assert_allclose(q_d[0, :3, :3], exact, rtol=0, atol=bound + 1e-12 * np.abs(exact).max())
