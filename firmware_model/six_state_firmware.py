"""The node firmware around the 6-state fixed filter (issue 24, ``filter.states = 6``, ``implementation = "fixed"``),
in the MCU's integer arithmetic, one lane at a time: the 2-state firmware's tick (:mod:`firmware_model.node_firmware`)
with the 6-state filter (:mod:`firmware_model.six_state_kernel`) in place of the yaw filter, on the measurement model
of the chain's float 6-state filter (``nodesim.chain.compiled.six_state_float_kernel``, docs/deviated_wells.md).

Lane state (``STATE_SIZE`` int64 words):
    [0, nf.STATE_SIZE)       the 2-state firmware's words (:mod:`firmware_model.node_firmware`): its static-window
                             z sums, the z rate and the previous one (extrapolated rate compensation), the running
                             flag; and in the yaw filter's slots the words the node *sends* (the estimate frame):
                             ``fk.I_YAW`` the twist psi_t as a 32-bit binary angle, ``fk.I_PYY`` the twist's
                             variance h P h^T in P_yy's format (deg^2), ``fk.I_BIAS`` the z bias
    [O6, O6 + k6.STATE_SIZE) the 6-state filter's lane (binary-angle roll, pitch, yaw; Q16.16 biases; P)
    then the x, y gyro sums and the x, y, z accelerometer sums of the static window, the tick's x, y, z rates,
    the count of levelled ticks.
A 6-state node thus shows the chain what a 2-state node shows: the frames, the survey, the reference it applied and
the records read the same words, and the reference crossing the chain is the 2-state firmware's yaw word and P_yy
word.  The receiving node converts them into its 6-state formats: at 32 bits (the only word length the 6-state
build has, ``filter.fixed_word_bits = 32``) the yaw word and the angle format are both Q0.32 turns and P_yy and
``p_aa`` both Q8.24 deg^2, so the conversion is the identity (exact, no rounding); :func:`check_formats` refuses a
build where they differ.

Per tick (the 2-state firmware's phases):
  - read the gyro: the z rate by :func:`firmware_model.node_firmware.read_gyro`, x and y by the same integer
    conversion rate = round_he(sum 10 2^F_rate / (n S10)) (one rounding, saturated at "tick rate");
  - static window: the sums of the three gyro axes and of the three accelerometer axes (thesis 4.2.3);
  - start: biases = the window's mean rate per axis (0 without samples, as the 2-state firmware's z bias); roll and
    pitch by levelling the window's accelerometer sums f (the start tick's own where the window is empty), with
    the CORDIC's vectoring (:func:`firmware_model.cordic.vectoring_lanes`, gain-compensated magnitude):
        phi_0 = atan2(f_y, f_z),   theta_0 = atan2(-f_x, |(f_y, f_z)|)    (:func:`six_state_kernel.tilt_raw`)
    (thesis digest 2.7 step 4, eqs 1.1-1.3; the float start of nodesim.chain.six_state); psi_0 = psi_enc - c(phi_0,
    theta_0) in binary angles, so the twist starts at the encoder's angle; P = P0 of the 6-state build;
  - run: :func:`firmware_model.six_state_kernel.predict_raw` with the three rates, then the levelling
    (:func:`firmware_model.six_state_kernel.level_raw` with the three rate words and the tick's accelerometer sums:
    at a static tick, |w - b_0| below ``filter.levelling_rate_deg_s``, the accelerometer's roll and pitch update
    the filter; b_0 the start's biases; ``filter.levelling = "off"``: a no-op), then the reference as the 2-state
    firmware forms it (eq 3.29 in binary-angle arithmetic with the bias-corrected z rate, R of digest 2.6;
    :func:`firmware_model.node_firmware.advance`, ``omega``, ``reference_variance``, ``transfer_us_sat``), then
    :func:`twist_update_raw`;
  - every running tick: the sent words (twist, h P h^T, z bias) and the frame's rate field.

Twist (our derivation, docs/deviated_wells.md):  psi_t = psi + c(phi, theta),  c = atan2(N, D),
N = -sin(theta) sin(phi), D = cos(theta) + cos(phi).  In fixed point N' = N / 2, D' = D / 2 (Q2.30 ``unit``: D reaches
2, the format's bound; atan2 and the ratios below do not change with the common scale), the trig by CORDIC rotation,
c by CORDIC vectoring, and the linearised row (eq 3.9, H = dh/dx) h = [dc/dphi, dc/dtheta, 1, 0, 0, 0]:
    dc/dphi   = (D (-s_theta c_phi) - N (-s_phi)) / (N^2 + D^2)   = (N' s_phi - D' s_theta c_phi) / (2 (N'^2 + D'^2))
    dc/dtheta = (D (-c_theta s_phi) - N (-s_theta)) / (N^2 + D^2) = (N' s_theta - D' c_theta s_phi) / (2 (N'^2 + D'^2))
in the ``transition`` format (dimensionless, |h| < 32; beyond it saturates, counted).  The update (thesis eqs
3.11-3.14 as one scalar update, the form of :func:`firmware_model.six_state_kernel.update_raw`):
    z = wrap(psi_t - psi_t,ref) (binary-angle difference);  Ph = P h^T (block formats of column 2);
    S = h P h^T + R (p_aa);  K = Ph / S;  dx = K z (angles in turns, biases with z in deg);
    P -= K (Ph)^T (upper triangle, mirrored, P_ii >= 1 LSB);  closed-loop reset: Theta -= dx[:3], b += dx[3:].
(The float filter updates P in Joseph form; the fixed kernel's simple form is used here as in its own update.)
The C twin (firmware_model/c/six_state_filter.c) covers the filter's predict, update, tilt and levelling
(nf6_tilt, nf6_level), not this node layer.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from firmware_model import cordic
from firmware_model import fixed_kernel as fk
from firmware_model import node_firmware as nf
from firmware_model import six_state_kernel as k6
from firmware_model.errors import FirmwareError
from firmware_model.fixed_kernel import _add, _div, _mul, _sat, _sub, _wrap

O6 = nf.STATE_SIZE  # the 6-state filter's lane
S_GSUM = O6 + k6.STATE_SIZE  # x, y gyro sums of the static window
S_ASUM = S_GSUM + 2  # x, y, z accelerometer sums of the static window
S_RATES = S_ASUM + 3  # the tick's x, y, z rates (the rate format)
S_LEVELLED = S_RATES + 3  # the count of levelled ticks
STATE_SIZE = S_LEVELLED + 1

# inputs: the 2-state firmware's, then the tick's x, y gyro sums and x, y, z accelerometer sums
INPUTS = nf.INPUTS + ("gyro_x_sum", "gyro_y_sum", "accel_x_sum", "accel_y_sum", "accel_z_sum")
IN_GX, IN_GY, IN_AX = len(nf.INPUTS), len(nf.INPUTS) + 1, len(nf.INPUTS) + 2
OUTPUTS = nf.OUTPUTS

# overflow counts: the 2-state firmware's sites (reference, rates), the 6-state filter's, then the twist's
TWIST_SITES = ("twist trig", "twist h", "twist P h", "twist S")
SITES = nf.SITES + tuple("6-state " + s for s in k6.SITES) + tuple("6-state " + s for s in TWIST_SITES)
C6 = len(nf.SITES)  # the filter's counts start here
X_TRIG, X_H, X_PH, X_S = (C6 + len(k6.SITES) + i for i in range(len(TWIST_SITES)))


def check_formats(fparams: np.ndarray, params6: np.ndarray) -> None:
    """The sent words' formats (the 2-state build's yaw, P_yy, rate, bias: ``fparams``) must equal the 6-state
    build's angle, p_aa, rate and bias formats (``params6``): the conversion between them is then exact."""
    for name, i2, i6 in (("yaw / angle", fk.W_YAW, k6.W_ANG), ("p_yy / p_aa", fk.W_YY, k6.W_AA),
                         ("rate", fk.W_RATE, k6.W_RATE), ("bias", fk.W_BIAS, k6.W_BIAS)):
        if (fparams[i2], fparams[i2 + 1]) != (params6[i6], params6[i6 + 1]):
            raise FirmwareError(f"the 6-state node sends its {name} word in the 2-state frame's format "
                                f"Q{fparams[i2] - fparams[i2 + 1]}.{fparams[i2 + 1]}, but its filter uses "
                                f"Q{params6[i6] - params6[i6 + 1]}.{params6[i6 + 1]}; allowed: equal formats "
                                "(filter.fixed_word_bits = 32)")


@njit(cache=True, _nrt=False)
def init_lane(state) -> None:
    """A node at power-up (:func:`firmware_model.node_firmware.init_lane`, the other words zero)."""
    for i in range(STATE_SIZE):
        state[i] = 0
    nf.init_lane(state)


@njit(cache=True, _nrt=False)
def _rate(count_sum, n, params, fparams, counts):
    fr = fparams[fk.W_RATE + 1]
    return _sat(nf.counts_to_rate(count_sum, n, fr, params[nf.P_SENS]), fr, fparams[fk.W_RATE], fr, counts, nf.X_RATE)


@njit(cache=True, _nrt=False)
def twist_offset(st6, p6, counts, work):
    """(c, dc/dphi, dc/dtheta) of a 6-state lane: c a binary angle, the partials in the transition format
    (module docstring)."""
    p = p6
    it, fu, ft = p[k6.P_ITER], p[k6.W_UNIT + 1], p[k6.W_TR + 1]
    sp, cp = cordic.sin_cos(st6[k6.I_ATT], it)
    s_t, c_t = cordic.sin_cos(st6[k6.I_ATT + 1], it)
    n2 = -_mul(s_t, fu, sp, fu + 1, p, k6.W_UNIT, counts, X_TRIG)  # N / 2
    d2 = _add(c_t, fu + 1, cp, fu + 1, p, k6.W_UNIT, counts, X_TRIG)  # D / 2
    work[k6.WK_CX], work[k6.WK_CY] = d2, n2
    cordic.vectoring_lanes(work[k6.WK_CX:k6.WK_CX + 1], work[k6.WK_CY:k6.WK_CY + 1], it, work[k6.WK_CA:k6.WK_CA + 1],
                           work[k6.WK_CS:k6.WK_CS + 1])
    c = work[k6.WK_CA]
    q = _add(_mul(n2, fu, n2, fu, p, k6.W_UNIT, counts, X_TRIG), fu, _mul(d2, fu, d2, fu, p, k6.W_UNIT, counts, X_TRIG),
             fu, p, k6.W_UNIT, counts, X_TRIG)  # (N^2 + D^2) / 4; 2 q read with one fraction bit less
    num0 = _sub(_mul(n2, fu, sp, fu, p, k6.W_UNIT, counts, X_TRIG), fu,
                _mul(d2, fu, _mul(s_t, fu, cp, fu, p, k6.W_UNIT, counts, X_TRIG), fu, p, k6.W_UNIT, counts, X_TRIG),
                fu, p, k6.W_UNIT, counts, X_TRIG)
    num1 = _sub(_mul(n2, fu, s_t, fu, p, k6.W_UNIT, counts, X_TRIG), fu,
                _mul(d2, fu, _mul(c_t, fu, sp, fu, p, k6.W_UNIT, counts, X_TRIG), fu, p, k6.W_UNIT, counts, X_TRIG),
                fu, p, k6.W_UNIT, counts, X_TRIG)
    h0 = _div(num0, fu, q, fu - 1, p, k6.W_TR, counts, X_H)
    h1 = _div(num1, fu, q, fu - 1, p, k6.W_TR, counts, X_H)
    return c, h0, h1


@njit(cache=True, _nrt=False)
def _twist_ph(st6, h0, h1, p6, counts, work):
    """Ph = P h^T into work[WK_ROW:WK_ROW + 6] (entry i in the format of P's (i, 2)); returns h P h^T (p_aa)."""
    p = p6
    ft, faa = p[k6.W_TR + 1], p[k6.W_AA + 1]
    P = st6[k6.I_P:k6.I_P + 36]
    for i in range(6):
        w = k6._blk(i, 2)
        fo = p[w + 1]
        acc = _add(_mul(P[6 * i], fo, h0, ft, p, w, counts, X_PH), fo, _mul(P[6 * i + 1], fo, h1, ft, p, w, counts, X_PH),
                   fo, p, w, counts, X_PH)
        work[k6.WK_ROW + i] = _add(acc, fo, P[6 * i + 2], fo, p, w, counts, X_PH)
    acc = _add(_mul(h0, ft, work[k6.WK_ROW], faa, p, k6.W_AA, counts, X_PH), faa,
               _mul(h1, ft, work[k6.WK_ROW + 1], faa, p, k6.W_AA, counts, X_PH), faa, p, k6.W_AA, counts, X_PH)
    return _add(acc, faa, work[k6.WK_ROW + 2], faa, p, k6.W_AA, counts, X_PH)


@njit(cache=True, _nrt=False)
def twist_update_raw(st6, ref_raw, var_raw, p6, counts, work) -> None:
    """The twist update of one lane (module docstring): reference a binary angle, R in p_aa; ``counts`` the whole
    :data:`SITES` vector (the twist functions count at their absolute sites)."""
    p = p6
    fa, fb, finv, fka, fkb, finn, faa = (p[k6.W_ANG + 1], p[k6.W_BIAS + 1], p[k6.W_INV + 1], p[k6.W_KA + 1],
                                         p[k6.W_KB + 1], p[k6.W_INN + 1], p[k6.W_AA + 1])
    c, h0, h1 = twist_offset(st6, p6, counts, work)
    z = _wrap(_wrap(st6[k6.I_ATT + 2] + c, p[k6.W_ANG]) - ref_raw, p[k6.W_ANG])
    hph = _twist_ph(st6, h0, h1, p6, counts, work)
    sv = _add(hph, faa, var_raw, faa, p, k6.W_AA, counts, X_S)
    inv = _div(p[k6.P_ONE_U], p[k6.W_UNIT + 1], sv, faa, p, k6.W_INV, counts, C6 + k6.S_INV)
    for j in range(6):
        wk = k6.W_KA if j < 3 else k6.W_KB
        work[k6.WK_K + j] = _mul(work[k6.WK_ROW + j], p[k6._blk(j, 2) + 1], inv, finv, p, wk, counts, C6 + k6.S_K)
    z_deg = _mul(z, fa, p[k6.C_360], p[k6.C_360 + 1], p, k6.W_INN, counts, C6 + k6.S_INNOV)
    for j in range(6):
        if j < 3:
            work[k6.WK_DX + j] = _mul(work[k6.WK_K + j], fka, z, fa, p, k6.W_ANG, counts, C6 + k6.S_KZ)
        else:
            work[k6.WK_DX + j] = _mul(work[k6.WK_K + j], fkb, z_deg, finn, p, k6.W_BIAS, counts, C6 + k6.S_KZ)
    P = st6[k6.I_P:k6.I_P + 36]
    for j in range(6):
        fk_j = fka if j < 3 else fkb
        for m in range(j, 6):
            w = k6._blk(j, m)
            fo = p[w + 1]
            v = _sub(P[6 * j + m], fo, _mul(work[k6.WK_K + j], fk_j, work[k6.WK_ROW + m], p[k6._blk(m, 2) + 1], p, w,
                                            counts, C6 + k6.S_PUPD), fo, p, w, counts, C6 + k6.S_PUPD)
            if j == m and v < 1:
                v = np.int64(1)
            P[6 * j + m] = v
            P[6 * m + j] = v
    for i in range(3):
        st6[k6.I_ATT + i] = _wrap(st6[k6.I_ATT + i] - work[k6.WK_DX + i], p[k6.W_ANG])
        st6[k6.I_BIAS + i] = _add(st6[k6.I_BIAS + i], fb, work[k6.WK_DX + 3 + i], fb, p, k6.W_BIAS, counts,
                                  C6 + k6.S_BIAS_UPD)


@njit(cache=True, _nrt=False)
def _start(state, inp, p6, p0, params, fparams, counts, work) -> None:
    """End of the static window (module docstring): biases, the levelled roll and pitch, psi_0, P0 (``p0``: the
    6-state build's initial lane, whose P words are copied)."""
    st6 = state[O6:O6 + k6.STATE_SIZE]
    nf.start_filter(state, inp[nf.IN_YAW0], params, fparams, counts)  # the z bias, the running flag
    fb, wb = fparams[fk.W_BIAS + 1], fparams[fk.W_BIAS]
    n = state[nf.S_BIAS_N]
    for i in range(2):
        b = np.int64(0)
        if n > 0:
            b = _sat(nf.counts_to_rate(state[S_GSUM + i], n, fb, params[nf.P_SENS]), fb, wb, fb, counts, nf.X_BIAS0)
        st6[k6.I_BIAS + i] = b
    st6[k6.I_BIAS + 2] = state[fk.I_BIAS]
    ax, ay, az = state[S_ASUM], state[S_ASUM + 1], state[S_ASUM + 2]
    if n == 0:  # no static window: the start tick's own accelerometer sums
        ax, ay, az = inp[IN_AX], inp[IN_AX + 1], inp[IN_AX + 2]
    st6[k6.I_ATT], st6[k6.I_ATT + 1], _, _ = k6.tilt_raw(ax, ay, az, p6[k6.P_ITER], work)
    st6[k6.I_ATT + 2] = 0
    c, _, _ = twist_offset(st6, p6, counts, work)
    st6[k6.I_ATT + 2] = _wrap(inp[nf.IN_YAW0] - c, p6[k6.W_ANG])
    for i in range(36):
        st6[k6.I_P + i] = p0[k6.I_P + i]
    st6[k6.I_SING] = 0
    for i in range(3):  # the start bias b_0 (the levelling's static test)
        st6[k6.I_B0 + i] = st6[k6.I_BIAS + i]


@njit(cache=True, _nrt=False)
def _sent_words(state, p6, counts, work) -> None:
    """The words the node reports and sends: the twist, h P h^T, the z bias (module docstring)."""
    st6 = state[O6:O6 + k6.STATE_SIZE]
    c, h0, h1 = twist_offset(st6, p6, counts, work)
    state[fk.I_YAW] = _wrap(st6[k6.I_ATT + 2] + c, p6[k6.W_ANG])
    state[fk.I_PYY] = _twist_ph(st6, h0, h1, p6, counts, work)
    state[fk.I_BIAS] = st6[k6.I_BIAS + 2]


@njit(cache=True, _nrt=False)
def node_tick(state, p6, p0, params, fparams, counts, inp, out, work) -> None:
    """One firmware tick of one lane (module docstring); ``inp`` (len(INPUTS),) as
    :func:`firmware_model.node_firmware.node_tick`'s plus the x, y gyro and the accelerometer sums, ``out`` its
    outputs (whether an update was applied, its reference and R raws, the frame's rate field)."""
    out[nf.OUT_APPLIED] = 0
    out[nf.OUT_REF] = 0
    out[nf.OUT_R] = 0
    phase = inp[nf.IN_PHASE]
    if phase == nf.ABSENT:
        return
    c6 = counts[C6:]
    nf.read_gyro(state, inp[nf.IN_GZ], inp[nf.IN_N], params, fparams, counts)
    n = inp[nf.IN_N]
    state[S_RATES] = _rate(inp[IN_GX], n, params, fparams, counts)
    state[S_RATES + 1] = _rate(inp[IN_GY], n, params, fparams, counts)
    state[S_RATES + 2] = state[nf.S_RATE]
    st6 = state[O6:O6 + k6.STATE_SIZE]
    if phase == nf.STATIC:
        nf.accumulate_bias(state, inp[nf.IN_GZ], n)
        state[S_GSUM] += inp[IN_GX]
        state[S_GSUM + 1] += inp[IN_GY]
        for i in range(3):
            state[S_ASUM + i] += inp[IN_AX + i]
    elif phase == nf.START:
        _start(state, inp, p6, p0, params, fparams, counts, work)
    elif phase == nf.RUN:
        k6.predict_raw(st6, state[S_RATES:S_RATES + 3], p6, c6, work)
        # the levelling at a static tick (filter.levelling; off in the build: returns at once)
        state[S_LEVELLED] += k6.level_raw(st6, state[S_RATES:S_RATES + 3], inp[IN_AX:IN_AX + 3], n, p6, c6, work)
        state[fk.I_BIAS] = st6[k6.I_BIAS + 2]  # nf.omega's bias: the z bias
        kind = inp[nf.IN_REF]
        if kind == nf.ENCODER_REF or kind == nf.FORWARDED_REF:
            tr = nf.transfer_us_sat(inp[nf.IN_TRANSFER], counts)
            if kind == nf.ENCODER_REF:  # the reply brought back to the tick; R = q^2 / 12
                ref = nf.advance(inp[nf.IN_REF_YAW], -inp[nf.IN_REF_AUX], tr, fparams, counts)
                r = params[nf.P_ENC_VAR]
            else:  # the frame's yaw and P_yy words advanced over the transfer (eq 3.29, digest 2.6)
                w = nf.omega(state, params, fparams, counts, tr)
                ref = nf.advance(inp[nf.IN_REF_YAW], w, tr, fparams, counts)
                r = nf.reference_variance(inp[nf.IN_REF_AUX], tr, params, fparams, counts)
            twist_update_raw(st6, ref, r, p6, counts, work)
            out[nf.OUT_APPLIED], out[nf.OUT_REF], out[nf.OUT_R] = 1, ref, r
    if state[nf.S_RUNNING] != 0:
        _sent_words(state, p6, counts, work)
        out[nf.OUT_RATE] = nf.estimate_rate(state, params, fparams, counts)


@njit(cache=True, _nrt=False)
def node_tick_lanes(states, p6, p0, params, fparams, counts, inputs, outputs, work) -> None:
    """:func:`node_tick` for every lane r (the SimPy engine's call, one per node tick for all realizations)."""
    for r in range(states.shape[0]):
        node_tick(states[r], p6, p0, params, fparams, counts, inputs[r], outputs[r], work)
