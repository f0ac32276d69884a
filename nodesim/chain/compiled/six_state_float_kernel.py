"""The float 6-state filter (:class:`firmware_model.six_state_filter.SixStateFilter`) as compiled scalar functions on
one realization, and the chain's per-node loop over it; both chain engines run these functions (the SimPy engine
through :class:`nodesim.chain.six_state.SixStateLanes`), so they agree bit for bit.

Lane state (``STATE_SIZE`` float64): attitude (phi, theta, psi) [rad], gyro bias (x, y, z) [rad/s], P (6 x 6,
row-major), the start bias b_0 (x, y, z) [rad/s] (the static window's, kept for the levelling's static test).  The maths is the module docstring of :mod:`firmware_model.six_state_filter` (thesis eqs 3.21-3.26,
3.31, 4.14-4.15; "rotation" and "euler" discretisation, "hold" and "decouple" inside the singularity margin),
written out per lane; tests/nodesim/chain/test_six_state_chain.py checks it against that filter step by step.

The chain passes the tube's twist down (the encoder's angle, the yaw the 2-state filter and the survey use,
:mod:`nodesim.sensors.chain_imu`: the body turns about its own z by psi_t from the untwisted tilted frame), while
the 6-state filter's psi is the Z-Y-X Euler yaw.  With C_b^n = Rz(psi) Ry(theta) Rx(phi) (nav z up) the twist is
the sum of the first and third Z-Y-Z angles of C_b^n:
    psi_t = atan2(C10 - C01, C00 + C11) = psi + c(phi, theta),   c = atan2(-sin(theta) sin(phi), cos(theta) + cos(phi))
(our derivation, docs/deviated_wells.md; c = O(phi theta), zero for a vertical tube).  A twist reference (the encoder's,
or the node above's) is the yaw-only measurement of thesis eq 3.31 / digest 2.6 on the twist: z = wrap(psi_t(x_INS)
- psi_t,ref) into (-pi, pi], linearised (eq 3.9, H = dh/dx) as h = [dc/dphi, dc/dtheta, 1, 0, 0, 0]; the node
reports psi_t and h P h^T.  (With H = e3 alone, i.e. c's roll/pitch sensitivity left out, the update's roll/pitch
corrections change c without the filter knowing, a loop that ran away within 15 s in a static string at 2 deg:
the node's roll and pitch errors doubled every few ticks.  Near vertical h = e3 + O(tilt).)
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from firmware_model.six_state_filter import SixStateFilterConfig
from nodesim.chain.compiled import tick_plan as tp
from nodesim.chain.compiled.filters import forwarded_reference

ATT, BIAS, P, BIAS0 = 0, 3, 6, 42
STATE_SIZE = 45
# params: dt, tau (3), diag Q (6, eq 3.26), A, G_D, sin(margin), cos(margin), hold, decouple, rotation, levelling,
# its static rate threshold [rad/s] and its per-axis force variance [(m/s^2)^2]
P_DT, P_TAU, P_Q, P_A, P_BG, P_SIN_M, P_COS_M, P_HOLD, P_DECOUPLE, P_ROTATION = 0, 1, 4, 10, 11, 12, 13, 14, 15, 16
P_LEVEL, P_LEVEL_RATE, P_LEVEL_VAR = 17, 18, 19
N_PARAMS = 20
SMALL_ANGLE = 1e-4  # as firmware_model.six_state_filter._SMALL_ANGLE


def kernel_params(config: SixStateFilterConfig) -> np.ndarray:
    """The (N_PARAMS,) float64 parameter row of ``config``."""
    p = np.zeros(N_PARAMS)
    p[P_DT] = config.dt_s
    p[P_TAU:P_TAU + 3] = config.bias_tau_s
    p[P_Q:P_Q + 6] = config.q_continuous
    p[P_A], p[P_BG] = config.tuning_a, config.bias_gain
    p[P_SIN_M], p[P_COS_M] = math.sin(config.singularity_margin_rad), math.cos(config.singularity_margin_rad)
    p[P_HOLD] = float(config.singularity == "hold")
    p[P_DECOUPLE] = float(config.singularity == "decouple")
    p[P_ROTATION] = float(config.discretisation == "rotation")
    p[P_LEVEL] = float(config.levelling)
    p[P_LEVEL_RATE], p[P_LEVEL_VAR] = config.levelling_rate_rad_s, config.levelling_force_sigma_m_s2**2
    return p


def init_states(config: SixStateFilterConfig, attitude_rad: np.ndarray, bias_rad_s: np.ndarray) -> np.ndarray:
    """(R, STATE_SIZE) lanes started at ``attitude_rad`` (R, 3) and ``bias_rad_s`` (R, 3) with P = P0."""
    R = attitude_rad.shape[0]
    s = np.zeros((R, STATE_SIZE))
    s[:, ATT:ATT + 3], s[:, BIAS:BIAS + 3] = attitude_rad, bias_rad_s
    s[:, P:P + 36] = config.p0.ravel()
    s[:, BIAS0:BIAS0 + 3] = bias_rad_s
    return s


@njit(cache=True, inline="always")
def wrap_pi_closed(x: float) -> float:
    """(-pi, pi] (firmware_model.six_state_filter.wrap_pi_closed)."""
    return math.pi - np.remainder(math.pi - x, 2.0 * math.pi)


@njit(cache=True, inline="always")
def twist_offset(phi: float, theta: float) -> float:
    """c(phi, theta) = psi_t - psi (module docstring)."""
    return math.atan2(-math.sin(theta) * math.sin(phi), math.cos(theta) + math.cos(phi))


@njit(cache=True)
def twist_rad(state) -> float:
    """The tube twist psi + c(phi, theta) of a lane: what the node reports and forwards as its yaw."""
    return state[ATT + 2] + twist_offset(state[ATT], state[ATT + 1])


@njit(cache=True, inline="always")
def _mm3(a, b, out) -> None:
    for i in range(3):
        for j in range(3):
            out[i, j] = a[i, 0] * b[0, j] + a[i, 1] * b[1, j] + a[i, 2] * b[2, j]


@njit(cache=True)
def _exp_jr(rho, sign: float, exp, jr) -> None:
    """Exp(sign rho) (Rodrigues) and J_r(sign rho) (firmware_model.six_state_filter.so3_exp / so3_right_jacobian)."""
    x, y, z = sign * rho[0], sign * rho[1], sign * rho[2]
    a = math.sqrt(x * x + y * y + z * z)
    a2 = a * a
    if a < SMALL_ANGLE:
        c1, c2, c3 = 1.0 - a2 / 6.0, 0.5 - a2 / 24.0, 1.0 / 6.0 - a2 / 120.0
    else:
        c1, c2, c3 = math.sin(a) / a, (1.0 - math.cos(a)) / a**2, (a - math.sin(a)) / a**3
    k = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    kk = np.empty((3, 3))
    _mm3(k, k, kk)
    for i in range(3):
        for j in range(3):
            one = 1.0 if i == j else 0.0
            exp[i, j] = one + c1 * k[i, j] + c2 * kk[i, j]
            jr[i, j] = one - c2 * k[i, j] + c3 * kk[i, j]


@njit(cache=True)
def _pitch_trig(theta: float, params):
    """(sin, cos, near) of the pitch the Euler-rate terms use (firmware_model.six_state_filter.pitch_trig)."""
    s, c = math.sin(theta), math.cos(theta)
    near = abs(c) < params[P_SIN_M]
    if near and params[P_HOLD] != 0.0:
        c = (-1.0 if c < 0.0 else 1.0) * params[P_SIN_M]
        s = (-1.0 if s < 0.0 else 1.0) * params[P_COS_M]
    return s, c, near


@njit(cache=True)
def _euler_rate(phi: float, s_theta: float, c_theta: float, e) -> None:
    """E(phi, theta) of eq 3.21 (digest 2.3)."""
    sp, cp = math.sin(phi), math.cos(phi)
    t = s_theta / c_theta
    e[0, 0], e[0, 1], e[0, 2] = 1.0, sp * t, cp * t
    e[1, 0], e[1, 1], e[1, 2] = 0.0, cp, -sp
    e[2, 0], e[2, 1], e[2, 2] = 0.0, sp / c_theta, cp / c_theta


@njit(cache=True)
def _body_to_nav(phi: float, theta: float, c) -> None:
    """C_b^n(phi, theta, psi = 0) = Ry(theta) Rx(phi) (firmware_model.six_state_filter.body_to_nav)."""
    sp, cp, st, ct = math.sin(phi), math.cos(phi), math.sin(theta), math.cos(theta)
    c[0, 0], c[0, 1], c[0, 2] = ct, sp * st, cp * st
    c[1, 0], c[1, 1], c[1, 2] = 0.0, cp, -sp
    c[2, 0], c[2, 1], c[2, 2] = -st, sp * ct, cp * ct


@njit(cache=True)
def _sandwich(m, state, out) -> None:
    """out = M P M^T (6 x 6) with P the lane's covariance, summed left to right."""
    mp = np.empty((6, 6))
    for i in range(6):
        for j in range(6):
            acc = 0.0
            for n in range(6):
                acc += m[i, n] * state[P + 6 * n + j]
            mp[i, j] = acc
    for i in range(6):
        for j in range(6):
            acc = 0.0
            for n in range(6):
                acc += mp[i, n] * m[j, n]
            out[i, j] = acc


@njit(cache=True)
def predict(state, rates, params) -> bool:
    """Time update of one lane over one tick with the tick-averaged gyro rates (3,) [rad/s]; True if the tick's
    Euler-rate terms fell inside the singularity margin (module docstring of firmware_model.six_state_filter)."""
    dt, a_gain = params[P_DT], params[P_A]
    w = np.empty(3)
    for i in range(3):
        w[i] = rates[i] - state[BIAS + i]
    phi0, theta0, psi0 = state[ATT], state[ATT + 1], state[ATT + 2]
    tr = np.zeros((6, 6))  # Phi
    gc, e = np.empty((3, 3)), np.empty((3, 3))
    for i in range(3):
        tr[3 + i, 3 + i] = 1.0 - dt / params[P_TAU + i]
    if params[P_ROTATION] != 0.0:
        rho = np.empty(3)
        for i in range(3):
            rho[i] = w[i] * dt
        ex, jr, c0, c1 = np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3))
        _exp_jr(rho, 1.0, ex, jr)
        _body_to_nav(phi0, theta0, c0)
        _mm3(c0, ex, c1)  # C+ in the prior's yaw-free frame: its Euler angles give the yaw increment
        theta = -math.asin(min(max(c1[2, 0], -1.0), 1.0))
        d_phi = math.atan2(c1[2, 1], c1[2, 2])
        d_psi = math.atan2(c1[1, 0], c1[0, 0])
        phi = phi0 + wrap_pi_closed(d_phi - phi0)
        psi = psi0 + d_psi
        s, c, near = _pitch_trig(theta, params)
        _euler_rate(phi, s, c, e)
        # Phi_11 = E(Theta+) Exp(-rho) E(Theta)^-1, E^-1 = eq II.16 (no singularity)
        sp, cp, st, ct = math.sin(phi0), math.cos(phi0), math.sin(theta0), math.cos(theta0)
        einv = np.array([[1.0, 0.0, -st], [0.0, cp, sp * ct], [0.0, -sp, cp * ct]])
        ext = np.empty((3, 3))
        for i in range(3):
            for j in range(3):
                ext[i, j] = ex[j, i]
        m1, m2 = np.empty((3, 3)), np.empty((3, 3))
        _mm3(e, ext, m1)
        _mm3(m1, einv, m2)
        _mm3(e, jr, m1)  # Phi_12 = dt E(Theta+) J_r(rho)
        for i in range(3):
            for j in range(3):
                tr[i, j] = m2[i, j]
                tr[i, 3 + j] = dt * m1[i, j]
        _exp_jr(rho, -0.5, ex, jr)  # G_C' = A E(Theta+) Exp(-rho/2)
        _mm3(e, ex, m1)
        for i in range(3):
            for j in range(3):
                gc[i, j] = a_gain * m1[i, j]
    else:  # "euler": F and G at the prior; Phi = I + F dt
        s, c, near = _pitch_trig(theta0, params)
        _euler_rate(phi0, s, c, e)
        sp, cp = math.sin(phi0), math.cos(phi0)
        a = w[1] * cp - w[2] * sp
        b = w[1] * sp + w[2] * cp
        t, c2 = s / c, c * c
        f11 = np.array([[a * t, b / c2, 0.0], [-b, 0.0, 0.0], [a / c, b * s / c2, 0.0]])
        decoupled = near and params[P_DECOUPLE] != 0.0
        d = np.empty(3)
        for i in range(3):
            if decoupled:
                d[i] = dt * w[i]
            else:
                d[i] = dt * (e[i, 0] * w[0] + e[i, 1] * w[1] + e[i, 2] * w[2])
        phi, theta, psi = phi0 + d[0], theta0 + d[1], psi0 + d[2]
        for i in range(3):
            for j in range(3):
                tr[i, j] = (1.0 if i == j else 0.0) + f11[i, j] * dt
                tr[i, 3 + j] = e[i, j] * dt
                gc[i, j] = a_gain * e[i, j]
    if near and params[P_DECOUPLE] != 0.0:  # Phi_11 = I, Phi_12 = dt I, G_C = A I
        for i in range(3):
            for j in range(3):
                one = 1.0 if i == j else 0.0
                tr[i, j], tr[i, 3 + j], gc[i, j] = one, dt * one, a_gain * one
    state[ATT], state[ATT + 1], state[ATT + 2] = phi, theta, psi
    # P = Phi P Phi^T + Q_d, Q_d = blkdiag(G_C diag(sigma_v^2) G_C^T dt, G_D^2 diag(2 sigma_b^2 / tau) dt)
    new = np.empty((6, 6))
    _sandwich(tr, state, new)
    for i in range(3):
        for j in range(3):
            q = 0.0
            for m in range(3):
                q += gc[i, m] * params[P_Q + m] * gc[j, m]
            new[i, j] += q * dt
        new[3 + i, 3 + i] += params[P_BG] ** 2 * params[P_Q + 3 + i] * dt
    for i in range(6):
        for j in range(6):
            state[P + 6 * i + j] = 0.5 * (new[i, j] + new[j, i])
    return near


@njit(cache=True)
def update_row(state, h, z: float, var_rad2: float) -> None:
    """Scalar measurement update of one lane with the row ``h`` (6,) and innovation ``z`` (eqs 3.11-3.14):
    K = P h^T / (h P h^T + R), dx = K z, closed-loop reset, P = (I - K h) P (I - K h)^T + K R K^T, symmetrised."""
    ph = np.empty(6)
    for i in range(6):
        acc = 0.0
        for m in range(6):
            acc += state[P + 6 * i + m] * h[m]
        ph[i] = acc
    hph = 0.0
    for i in range(6):
        hph += h[i] * ph[i]
    inv_s = 1.0 / (hph + var_rad2)
    k = np.empty(6)
    for i in range(6):
        k[i] = ph[i] * inv_s
    for i in range(3):
        state[ATT + i] = state[ATT + i] - k[i] * z
        state[BIAS + i] = state[BIAS + i] + k[3 + i] * z
    ikh = np.empty((6, 6))
    for i in range(6):
        for j in range(6):
            ikh[i, j] = (1.0 if i == j else 0.0) - k[i] * h[j]
    new = np.empty((6, 6))
    _sandwich(ikh, state, new)
    for i in range(6):
        for j in range(6):
            new[i, j] = new[i, j] + k[i] * var_rad2 * k[j]
    for i in range(6):
        for j in range(6):
            state[P + 6 * i + j] = 0.5 * (new[i, j] + new[j, i])


@njit(cache=True)
def level_update(state, rates, force, params) -> bool:
    """The accelerometer's roll and pitch as measurements at a static tick (firmware_model.six_state_filter, module
    docstring "Levelling"; thesis eqs 3.27-3.31 on the roll and pitch rows, the resolution of eqs 1.1-1.3):
    static if |rates - b_0| < the threshold (b_0 the start bias: the static test must not hang on the estimate it
    is meant to correct, whose x, y components a long string's twist innovations can pull far off); phi_m = atan2(f_y, f_z), theta_m = atan2(-f_x, |(f_y, f_z)|),
    R_phi = sigma_f^2 / (f_y^2 + f_z^2), R_theta = sigma_f^2 / |f|^2, two scalar updates (roll skipped near
    horizontal).  ``rates`` (3,) the tick's gyro rates [rad/s], ``force`` (3,) its mean specific force [m/s^2];
    True if the tick was static and updated."""
    if params[P_LEVEL] == 0.0:
        return False
    w2 = 0.0
    for i in range(3):
        w2 += (rates[i] - state[BIAS0 + i]) ** 2
    if w2 >= params[P_LEVEL_RATE] ** 2:
        return False
    fx, fy, fz = force[0], force[1], force[2]
    nyz2 = fy * fy + fz * fz
    f2 = fx * fx + nyz2
    if not f2 > 0.0:
        return False
    var = params[P_LEVEL_VAR]
    h = np.zeros(6)
    if nyz2 >= f2 * params[P_SIN_M] ** 2:  # roll defined: |(f_y, f_z)| >= |f| sin(margin)
        h[0] = 1.0
        update_row(state, h, wrap_pi_closed(state[ATT] - math.atan2(fy, fz)), var / nyz2)
        h[0] = 0.0
    h[1] = 1.0
    update_row(state, h, wrap_pi_closed(state[ATT + 1] - math.atan2(-fx, math.sqrt(nyz2))), var / f2)
    return True


@njit(cache=True, nogil=True)
def level_lanes(states, rates, force, params, mask) -> None:
    """:func:`level_update` in every lane r with ``mask[r]`` (rates, force (R, 3))."""
    for r in range(states.shape[0]):
        if mask[r]:
            level_update(states[r], rates[r], force[r], params)


@njit(cache=True)
def update(state, ref_yaw_rad: float, var_rad2: float) -> None:
    """Euler-yaw update (eq 3.31, H = e3^T, as firmware_model.six_state_filter.SixStateFilter.update):
    z = wrap(psi - ref) into (-pi, pi]."""
    h = np.zeros(6)
    h[2] = 1.0
    update_row(state, h, wrap_pi_closed(state[ATT + 2] - ref_yaw_rad), var_rad2)


@njit(cache=True)
def twist_row(state, h) -> None:
    """h = d psi_t / d x = [dc/dphi, dc/dtheta, 1, 0, 0, 0] at the lane's attitude (eq 3.9, H = dh/dx, for the
    twist h(x) = psi + c(phi, theta), c = atan2(N, D), N = -s_theta s_phi, D = c_theta + c_phi)."""
    sp, cp = math.sin(state[ATT]), math.cos(state[ATT])
    st, ct = math.sin(state[ATT + 1]), math.cos(state[ATT + 1])
    n, d = -st * sp, ct + cp
    q = 1.0 / (n * n + d * d)
    h[0] = (d * (-st * cp) - n * (-sp)) * q
    h[1] = (d * (-ct * sp) - n * (-st)) * q
    h[2] = 1.0
    h[3], h[4], h[5] = 0.0, 0.0, 0.0


@njit(cache=True)
def update_twist(state, ref_twist_rad: float, var_rad2: float) -> None:
    """Update with a twist reference (the encoder's or the node above's): z = wrap(psi_t(x_INS) - psi_t,ref) into
    (-pi, pi], linearised with :func:`twist_row` (the EKF form of eqs 3.9-3.14; module docstring)."""
    h = np.empty(6)
    twist_row(state, h)
    update_row(state, h, wrap_pi_closed(twist_rad(state) - ref_twist_rad), var_rad2)


@njit(cache=True)
def twist_variance_rad2(state) -> float:
    """h P h^T: the variance of the reported twist (what the node sends with it)."""
    h = np.empty(6)
    twist_row(state, h)
    acc = 0.0
    for i in range(6):
        for j in range(6):
            acc += h[i] * state[P + 6 * i + j] * h[j]
    return acc


@njit(cache=True, nogil=True)
def twist_variance_lanes(states, out) -> None:
    for r in range(states.shape[0]):
        out[r] = twist_variance_rad2(states[r])


@njit(cache=True, nogil=True)
def predict_lanes(states, rates, params, singular, mask) -> None:
    """:func:`predict` in every lane r with ``mask[r]`` (rates (R, 3)); counts singular ticks in ``singular``."""
    for r in range(states.shape[0]):
        if mask[r] and predict(states[r], rates[r], params):
            singular[r] += 1


@njit(cache=True, nogil=True)
def update_lanes(states, ref_twist, var, mask) -> None:
    """:func:`update_twist` in the lanes with ``mask[r]`` (ref (R,), var (R,))."""
    for r in range(states.shape[0]):
        if mask[r]:
            update_twist(states[r], ref_twist[r], var[r])


@njit(cache=True, nogil=True)
def twist_lanes(states, out) -> None:
    for r in range(states.shape[0]):
        out[r] = twist_rad(states[r])


@njit(cache=True, nogil=True)
def run_node(states, params, singular, rates, force, gyro_z, t, k_first, k_end, codes, enc_ref, enc_var, applied,
             src_node, src_tick, up_t, up_yaw, up_var, dt_s, extrapolate, rate_sigma, offset_var, yaw, var, bias,
             ref_yaw, ref_var, r_first, r_end) -> None:
    """The compiled engine's phase 2 for one node (as :func:`nodesim.chain.compiled.filters.run_node`, with the
    6-state lane): ``rates`` (R, K, 3) the filter's gyro input, ``force`` (R, K, 3) the tick's specific force (the
    levelling at static ticks, :func:`level_update`, after the time update), ``gyro_z`` (R, K) the z rate the forwarded
    reference is advanced with (eq 3.29, :func:`.filters.forwarded_reference`); records the twist, its variance
    and the z-bias."""
    for r in range(r_first, r_end):
        st = states[r]
        for k in range(k_first, k_end):
            c = codes[k]
            if c == tp.STATIC:
                continue
            if c != tp.HOLD:
                if predict(st, rates[r, k], params):
                    singular[r] += 1
                level_update(st, rates[r, k], force[r, k], params)
            if c == tp.ASK:
                if applied[r, k]:
                    update_twist(st, enc_ref[r, k], enc_var)
                    ref_yaw[r, k], ref_var[r, k] = enc_ref[r, k], enc_var
            elif c == tp.RUN and src_node[r, k] > 0:
                ref, v = forwarded_reference(r, k, src_node[r, k] - 1, src_tick[r, k], t, up_t, up_yaw, up_var,
                                             gyro_z, st[BIAS + 2], dt_s, extrapolate, rate_sigma, offset_var)
                update_twist(st, ref, v)
                ref_yaw[r, k], ref_var[r, k] = ref, v
            yaw[r, k], var[r, k], bias[r, k] = twist_rad(st), twist_variance_rad2(st), st[BIAS + 2]
