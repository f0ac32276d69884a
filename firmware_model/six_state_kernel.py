"""The 6-state fixed-point filter (:mod:`firmware_model.six_state_fixed`) as numba scalar kernels, one lane at a time.

``state`` is int64[STATE_SIZE] (binary-angle roll, pitch, yaw; biases in the bias format; P row-major 6 x 6 in its
block formats; the count of singular ticks; the start bias b_0 of the levelling), ``params`` the int64 vector of
:meth:`firmware_model.six_state_fixed.SixStateFixedConfig.params`, ``counts`` int64[len(SITES)] overflow counters,
``work`` int64[WORK_SIZE] scratch (the kernels allocate nothing: ``_nrt=False`` like
:mod:`firmware_model.fixed_kernel`, whose primitives ``_add``/``_sub``/``_mul``/``_div``/``_sat``/``_wrap`` every
step here uses: round half even, saturation counted per site, the binary angles wrap).  The C twin is
firmware_model/c/six_state_filter.c, line for line; the equations are in :mod:`firmware_model.six_state_fixed`.

Covariance blocks: angle-angle (deg^2, ``p_aa``), angle-bias (deg^2/s, ``p_ab``), bias-bias ((deg/s)^2, ``p_bb``):
the format of entry (i, j) is that of its block (:func:`_blk`).  Only the upper triangle is computed; the lower
is its mirror, so P stays exactly symmetric.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from firmware_model import cordic
from firmware_model.errors import FirmwareError
from firmware_model.fixed_kernel import (
    RAD2_TO_DEG2, RAD_TO_DEG, TURN_RAD, _add, _div, _from_float_sat, _from_float_wrap, _mul, _sat, _sub, _to_float,
    _wrap,
)

SITES: tuple[str, ...] = (
    # predict
    "gyro rate", "rate - bias", "rho", "rho^2", "series", "exp(rho)", "J_r", "exp(-rho/2)", "dcm", "1 / cos pitch",
    "E", "Phi11", "Phi12", "G_C", "noise sqrt", "Q_d", "Phi P", "P predict",
    # update
    "reference variance", "S", "1 / S", "K", "innovation deg", "K z", "P update", "bias update",
    # levelling (level_raw)
    "level sigma", "level R",
)
(S_GYRO, S_RATE_BIAS, S_RHO, S_RHO2, S_SERIES, S_EXP, S_JR, S_EXPH, S_DCM, S_INVC, S_E, S_PHI11, S_PHI12, S_GC,
 S_GS, S_QD, S_PHIP, S_PPRED, S_REF_VAR, S_S, S_INV, S_K, S_INNOV, S_KZ, S_PUPD, S_BIAS_UPD, S_LSIG,
 S_LR) = range(len(SITES))

# the lane state: attitude, biases, P, singular ticks, the start bias b_0 (x, y, z; the levelling's static test)
I_ATT, I_BIAS, I_P, I_SING, I_B0 = 0, 3, 6, 42, 43
STATE_SIZE = 46
# the work array (3 x 3 matrices row-major, then the 6 x 6 product, CORDIC lanes, the update's row, gains and dx,
# the levelling's references and variances)
WK_EXP, WK_JR, WK_EXPH, WK_EINV, WK_E, WK_M, WK_PHI11, WK_PHI12, WK_GC, WK_GS = range(0, 90, 9)
WK_T, WK_CX, WK_CY, WK_CA, WK_CS, WK_ROW, WK_K, WK_DX, WK_LREF, WK_LVAR = 90, 126, 128, 130, 132, 134, 140, 146, 152, 155
WK_LRATE = 158  # level_lanes: the tick's rate raws
WORK_SIZE = 161

# params: (word, frac) of each format, (raw, frac, word) of each constant, then the series tables, then integers
FORMAT_FIELDS = ("angle", "rate", "bias", "rho", "rho2", "series", "unit", "transition", "noise_sqrt", "p_aa",
                 "p_ab", "p_bb", "inv_s", "gain_angle", "gain_bias", "innovation_deg", "level_sigma")
CONSTANTS = ("dt_rad", "dt", "f_x", "f_y", "f_z", "q_bx", "q_by", "q_bz", "sv_x", "sv_y", "sv_z", "c_360",
             "level_sigma")
SERIES_TERMS = 13
INTEGERS = ("cordic_iterations", "decouple", "sin_margin", "cos_margin", "one_unit", "one_transition", "dt_transition",
            "level", "level_rate")
_FMT = {name: 2 * i for i, name in enumerate(FORMAT_FIELDS)}
_CONST = {name: 2 * len(FORMAT_FIELDS) + 3 * j for j, name in enumerate(CONSTANTS)}
T_SERIES = 2 * len(FORMAT_FIELDS) + 3 * len(CONSTANTS)  # 3 tables of SERIES_TERMS raws (series format)
_INT = {name: T_SERIES + 3 * SERIES_TERMS + k for k, name in enumerate(INTEGERS)}
N_PARAMS = T_SERIES + 3 * SERIES_TERMS + len(INTEGERS)
(W_ANG, W_RATE, W_BIAS, W_RHO, W_RHO2, W_SER, W_UNIT, W_TR, W_GS, W_AA, W_AB, W_BB, W_INV, W_KA, W_KB,
 W_INN, W_LSIG) = (_FMT[n] for n in FORMAT_FIELDS)
C_DTR, C_DT, C_F, C_QB, C_SV, C_360 = _CONST["dt_rad"], _CONST["dt"], _CONST["f_x"], _CONST["q_bx"], _CONST["sv_x"], _CONST["c_360"]
C_LSIG = _CONST["level_sigma"]
P_ITER, P_DECOUPLE, P_SINM, P_COSM, P_ONE_U, P_ONE_T, P_DT_T, P_LEVEL, P_LEVEL_RATE = (_INT[n] for n in INTEGERS)
# the ``axes`` argument of update_raw: yaw only, roll/pitch/yaw, and the levelling's roll/pitch and pitch only
# (the scalar updates run over the contiguous axes [lo, hi) of :func:`_axes_range`)
YAW_ONLY, ALL_AXES, ROLL_PITCH, PITCH_ONLY = 1, 3, 4, 5
LEVEL_OP = 8  # run_ops: the levelling op's kind
LEVEL_DIFF_LIMIT = 1 << 30  # level_raw clamps |rate - b_0| (rate raws) here: exact for thresholds below it


@njit(cache=True, _nrt=False)
def _blk(i, j):
    """The params index of P entry (i, j)'s format: p_aa (both angles), p_bb (both biases), else p_ab."""
    if i < 3 and j < 3:
        return W_AA
    if i >= 3 and j >= 3:
        return W_BB
    return W_AB


@njit(cache=True, _nrt=False)
def _series(p, table, u, fu, counts):
    """Horner's sum_k b_k u^k of a table of SERIES_TERMS coefficients (series format), ``u`` with ``fu`` frac bits."""
    fs = p[W_SER + 1]
    c = p[table + SERIES_TERMS - 1]
    for k in range(SERIES_TERMS - 2, -1, -1):
        c = _add(p[table + k], fs, _mul(u, fu, c, fs, p, W_SER, counts, S_SERIES), fs, p, W_SER, counts, S_SERIES)
    return c


@njit(cache=True, _nrt=False)
def _skew(rho, i, j):
    """[rho x]_ij = [[0, -z, y], [z, 0, -x], [-y, x, 0]]_ij (raws of the rho format)."""
    if i == j:
        return np.int64(0)
    k = 3 - i - j
    s = 1 if (j - i) % 3 == 1 else -1  # (0,1), (1,2), (2,0): -rho_k; the transposed: +rho_k
    return -s * rho[k]


@njit(cache=True, _nrt=False)
def _matmul3(work, ia, fa, ta, ib, fb, io, p, w, counts, site):
    """work[io] = A B (3 x 3, row-major), A = work[ia] (transposed if ``ta``), out format p[w]: products rounded to
    it one by one and summed in k order (C: the same loop)."""
    fo = p[w + 1]
    for i in range(3):
        for j in range(3):
            acc = np.int64(0)
            for k in range(3):
                a = work[ia + 3 * k + i] if ta else work[ia + 3 * i + k]
                acc = _add(acc, fo, _mul(a, fa, work[ib + 3 * k + j], fb, p, w, counts, site), fo, p, w, counts, site)
            work[io + 3 * i + j] = acc


@njit(cache=True, _nrt=False)
def _dot3(a0, a1, a2, work, ib, j, fa, fb, p, w, counts, site):
    """a . column j of work[ib] (3 x 3), each product rounded to p[w] then summed."""
    fo = p[w + 1]
    acc = _mul(a0, fa, work[ib + j], fb, p, w, counts, site)
    acc = _add(acc, fo, _mul(a1, fa, work[ib + 3 + j], fb, p, w, counts, site), fo, p, w, counts, site)
    return _add(acc, fo, _mul(a2, fa, work[ib + 6 + j], fb, p, w, counts, site), fo, p, w, counts, site)


@njit(cache=True, _nrt=False)
def _phi_row_dot(work, row, x, base, stride, other, p, w, counts, site):
    """sum_m Phi_row,m x[base + stride m] (m < 6: Phi11 then Phi12 of the top row ``row``), x_m in the format of P
    entry (m, other), each product rounded to p[w] then summed in m order (T = Phi P and T Phi^T)."""
    fo, ft = p[w + 1], p[W_TR + 1]
    acc = np.int64(0)
    for m in range(6):
        wm = WK_PHI11 + 3 * row + m if m < 3 else WK_PHI12 + 3 * row + m - 3
        acc = _add(acc, fo, _mul(work[wm], ft, x[base + stride * m], p[_blk(m, other) + 1], p, w, counts, site), fo,
                   p, w, counts, site)
    return acc


@njit(cache=True, _nrt=False)
def predict_raw(state, rate_raw, params, counts, work):
    """One time update (:mod:`firmware_model.six_state_fixed`, "predict"), the gyro rates (x, y, z) already raw words
    in the rate format (deg/s)."""
    p = params
    fr, fb, fa = p[W_RATE + 1], p[W_BIAS + 1], p[W_ANG + 1]
    frho, frho2, fs, fu, ft, fgs = p[W_RHO + 1], p[W_RHO2 + 1], p[W_SER + 1], p[W_UNIT + 1], p[W_TR + 1], p[W_GS + 1]
    it = p[P_ITER]
    one_u = p[P_ONE_U]
    # rho = (omega - b) dt (rad) and s = |rho|^2
    rho = work[WK_ROW:WK_ROW + 3]
    for i in range(3):
        d = _sub(rate_raw[i], fr, state[I_BIAS + i], fb, p, W_RATE, counts, S_RATE_BIAS)
        rho[i] = _mul(d, fr, p[C_DTR], p[C_DTR + 1], p, W_RHO, counts, S_RHO)
    s = np.int64(0)
    for i in range(3):
        s = _add(s, frho2, _mul(rho[i], frho, rho[i], frho, p, W_RHO2, counts, S_RHO2), frho2, p, W_RHO2, counts, S_RHO2)
    # the SO(3) coefficients in u = s / 16 (and s / 64 for rho / 2): the raw of s read with 4 (6) more fraction bits
    c1 = _series(p, T_SERIES, s, frho2 + 4, counts)
    c2 = _series(p, T_SERIES + SERIES_TERMS, s, frho2 + 4, counts)
    c3 = _series(p, T_SERIES + 2 * SERIES_TERMS, s, frho2 + 4, counts)
    c1h = _series(p, T_SERIES, s, frho2 + 6, counts)
    c2h = _series(p, T_SERIES + SERIES_TERMS, s, frho2 + 6, counts)
    for i in range(3):
        for j in range(3):
            k = _skew(rho, i, j)
            k2 = _mul(rho[i], frho, rho[j], frho, p, W_RHO2, counts, S_RHO2)
            if i == j:
                k2 = _sub(k2, frho2, s, frho2, p, W_RHO2, counts, S_RHO2)
            e = _add(_mul(c1, fs, k, frho, p, W_UNIT, counts, S_EXP), fu,
                     _mul(c2, fs, k2, frho2, p, W_UNIT, counts, S_EXP), fu, p, W_UNIT, counts, S_EXP)
            jr = _sub(_mul(c3, fs, k2, frho2, p, W_UNIT, counts, S_JR), fu,
                      _mul(c2, fs, k, frho, p, W_UNIT, counts, S_JR), fu, p, W_UNIT, counts, S_JR)
            eh = _sub(_mul(c2h, fs, k2, frho2 + 2, p, W_UNIT, counts, S_EXPH), fu,
                      _mul(c1h, fs, k, frho + 1, p, W_UNIT, counts, S_EXPH), fu, p, W_UNIT, counts, S_EXPH)
            if i == j:
                e = _add(e, fu, one_u, fu, p, W_UNIT, counts, S_EXP)
                jr = _add(jr, fu, one_u, fu, p, W_UNIT, counts, S_JR)
                eh = _add(eh, fu, one_u, fu, p, W_UNIT, counts, S_EXPH)
            work[WK_EXP + 3 * i + j], work[WK_JR + 3 * i + j], work[WK_EXPH + 3 * i + j] = e, jr, eh
    # the strapdown: C+ = C_b^n(phi, theta, 0) Exp(rho); its Z-Y-X angles by CORDIC vectoring
    sp, cp = cordic.sin_cos(state[I_ATT], it)
    st, ct = cordic.sin_cos(state[I_ATT + 1], it)
    spst = _mul(sp, fu, st, fu, p, W_UNIT, counts, S_DCM)
    cpst = _mul(cp, fu, st, fu, p, W_UNIT, counts, S_DCM)
    spct = _mul(sp, fu, ct, fu, p, W_UNIT, counts, S_DCM)
    cpct = _mul(cp, fu, ct, fu, p, W_UNIT, counts, S_DCM)
    c00 = _dot3(ct, spst, cpst, work, WK_EXP, 0, fu, fu, p, W_UNIT, counts, S_DCM)
    c10 = _dot3(np.int64(0), cp, -sp, work, WK_EXP, 0, fu, fu, p, W_UNIT, counts, S_DCM)
    c20 = _dot3(-st, spct, cpct, work, WK_EXP, 0, fu, fu, p, W_UNIT, counts, S_DCM)
    c21 = _dot3(-st, spct, cpct, work, WK_EXP, 1, fu, fu, p, W_UNIT, counts, S_DCM)
    c22 = _dot3(-st, spct, cpct, work, WK_EXP, 2, fu, fu, p, W_UNIT, counts, S_DCM)
    work[WK_CX], work[WK_CX + 1], work[WK_CY], work[WK_CY + 1] = c00, c22, c10, c21
    cordic.vectoring_lanes(work[WK_CX:WK_CX + 2], work[WK_CY:WK_CY + 2], it, work[WK_CA:WK_CA + 2],
                           work[WK_CS:WK_CS + 2])
    d_psi, phi_new = work[WK_CA], work[WK_CA + 1]
    work[WK_CX], work[WK_CY] = work[WK_CX + 1], -c20  # theta = atan2(-C+_20, |(C+_21, C+_22)|)
    cordic.vectoring_lanes(work[WK_CX:WK_CX + 1], work[WK_CY:WK_CY + 1], it, work[WK_CA:WK_CA + 1],
                           work[WK_CS:WK_CS + 1])
    theta_new = work[WK_CA]
    # E^-1 at the prior (eq II.16) before the attitude moves on
    work[WK_EINV:WK_EINV + 9] = 0
    work[WK_EINV], work[WK_EINV + 2] = one_u, -st
    work[WK_EINV + 4], work[WK_EINV + 5], work[WK_EINV + 7], work[WK_EINV + 8] = cp, spct, -sp, cpct
    state[I_ATT] = phi_new
    state[I_ATT + 1] = theta_new
    state[I_ATT + 2] = _wrap(state[I_ATT + 2] + d_psi, p[W_ANG])
    # E at the posterior, the pitch held at the margin where singular
    sp, cp = cordic.sin_cos(phi_new, it)
    st, ct = cordic.sin_cos(theta_new, it)
    near = abs(ct) < p[P_SINM]
    if near:
        state[I_SING] += 1
        ct = -p[P_SINM] if ct < 0 else p[P_SINM]
        st = -p[P_COSM] if st < 0 else p[P_COSM]
    if near and p[P_DECOUPLE] != 0:  # Phi11 = I, Phi12 = dt I, G_C = A I (A is in sv)
        work[WK_PHI11:WK_PHI11 + 9] = 0
        work[WK_PHI12:WK_PHI12 + 9] = 0
        work[WK_GC:WK_GC + 9] = 0
        for i in range(3):
            work[WK_PHI11 + 4 * i], work[WK_PHI12 + 4 * i], work[WK_GC + 4 * i] = p[P_ONE_T], p[P_DT_T], p[P_ONE_T]
    else:
        inv_c = _div(one_u, fu, ct, fu, p, W_TR, counts, S_INVC)
        t = _mul(st, fu, inv_c, ft, p, W_TR, counts, S_E)
        e = work[WK_E:WK_E + 9]
        e[0], e[1], e[2] = p[P_ONE_T], _mul(sp, fu, t, ft, p, W_TR, counts, S_E), _mul(cp, fu, t, ft, p, W_TR, counts, S_E)
        e[3], e[4], e[5] = 0, _sat(cp, fu, p[W_TR], ft, counts, S_E), _sat(-sp, fu, p[W_TR], ft, counts, S_E)
        e[6], e[7], e[8] = 0, _mul(sp, fu, inv_c, ft, p, W_TR, counts, S_E), _mul(cp, fu, inv_c, ft, p, W_TR, counts, S_E)
        _matmul3(work, WK_EXP, fu, True, WK_EINV, fu, WK_M, p, W_UNIT, counts, S_PHI11)  # Exp(-rho) E^-1
        _matmul3(work, WK_E, ft, False, WK_M, fu, WK_PHI11, p, W_TR, counts, S_PHI11)
        _matmul3(work, WK_E, ft, False, WK_JR, fu, WK_PHI12, p, W_TR, counts, S_PHI12)
        for i in range(9):
            work[WK_PHI12 + i] = _mul(work[WK_PHI12 + i], ft, p[C_DT], p[C_DT + 1], p, W_TR, counts, S_PHI12)
        _matmul3(work, WK_E, ft, False, WK_EXPH, fu, WK_GC, p, W_TR, counts, S_GC)
    # the rate noise's square root G_C diag(A sigma_v sqrt(dt)), then Q_d = (that)(that)^T
    for i in range(3):
        for k in range(3):
            c = C_SV + 3 * k
            work[WK_GS + 3 * i + k] = _mul(work[WK_GC + 3 * i + k], ft, p[c], p[c + 1], p, W_GS, counts, S_GS)
    # T = Phi P (6 x 6): the top rows [Phi11 Phi12] P, the bottom rows diag(f) P
    P = state[I_P:I_P + 36]
    for i in range(6):
        for k in range(6):
            w = _blk(i, k)
            fo = p[w + 1]
            if i < 3:
                acc = _phi_row_dot(work, i, P, k, 6, k, p, w, counts, S_PHIP)
            else:
                c = C_F + 3 * (i - 3)
                acc = _mul(p[c], p[c + 1], P[6 * i + k], p[_blk(i, k) + 1], p, w, counts, S_PHIP)
            work[WK_T + 6 * i + k] = acc
    # P = T Phi^T + Q_d, upper triangle, mirrored
    for i in range(6):
        for j in range(i, 6):
            w = _blk(i, j)
            fo = p[w + 1]
            if j < 3:
                acc = _phi_row_dot(work, j, work, WK_T + 6 * i, 1, i, p, w, counts, S_PPRED)
                for k in range(3):  # + Q_d,ij = sum_k gs_ik gs_jk
                    q = _mul(work[WK_GS + 3 * i + k], fgs, work[WK_GS + 3 * j + k], fgs, p, W_AA, counts, S_QD)
                    acc = _add(acc, fo, q, fo, p, w, counts, S_PPRED)
            else:
                c = C_F + 3 * (j - 3)
                acc = _mul(work[WK_T + 6 * i + j], p[_blk(i, j) + 1], p[c], p[c + 1], p, w, counts, S_PPRED)
                if i == j:
                    c = C_QB + 3 * (j - 3)
                    acc = _add(acc, fo, p[c], p[c + 1], p, w, counts, S_PPRED)
            if i == j and acc < 1:
                acc = np.int64(1)  # P_ii >= 1 LSB (as the 2-state filter)
            P[6 * i + j] = acc
            P[6 * j + i] = acc


@njit(cache=True, _nrt=False)
def _axes_range(axes):
    """The attitude rows [lo, hi) an update of ``axes`` uses (any other value: all three, as ALL_AXES)."""
    if axes == YAW_ONLY:
        return 2, 3
    if axes == ROLL_PITCH:
        return 0, 2
    if axes == PITCH_ONLY:
        return 1, 2
    return 0, 3


@njit(cache=True, _nrt=False)
def update_raw(state, axes, ref_raw, var_raw, params, counts, work):
    """One measurement update: ``axes`` = YAW_ONLY (H = e3^T, ref_raw[2] and var_raw[2] used), ALL_AXES (H = [I3 0]),
    ROLL_PITCH (the roll and pitch rows of [I3 0]) or PITCH_ONLY (the pitch row; :func:`_axes_range`); references as
    binary angles, variances in the p_aa format (deg^2).  Sequential scalar updates (roll, pitch, yaw, those of
    ``axes``) on the innovations of the prior, z_a - dx_a, then the closed-loop reset."""
    p = params
    fa, fb, finv, fka, fkb, finn = p[W_ANG + 1], p[W_BIAS + 1], p[W_INV + 1], p[W_KA + 1], p[W_KB + 1], p[W_INN + 1]
    faa = p[W_AA + 1]
    P = state[I_P:I_P + 36]
    work[WK_DX:WK_DX + 6] = 0
    lo, hi = _axes_range(axes)
    for a in range(lo, hi):
        z = _wrap(state[I_ATT + a] - ref_raw[a], p[W_ANG])  # the wrapped innovation Theta_INS - Theta_ref
        r = _wrap(z - work[WK_DX + a], p[W_ANG])
        sv = _add(P[7 * a], faa, var_raw[a], faa, p, W_AA, counts, S_S)
        inv = _div(p[P_ONE_U], p[W_UNIT + 1], sv, faa, p, W_INV, counts, S_INV)
        for k in range(6):
            work[WK_ROW + k] = P[6 * a + k]
        for j in range(6):
            wk = W_KA if j < 3 else W_KB
            work[WK_K + j] = _mul(work[WK_ROW + j], p[_blk(a, j) + 1], inv, finv, p, wk, counts, S_K)
        r_deg = _mul(r, fa, p[C_360], p[C_360 + 1], p, W_INN, counts, S_INNOV)
        for j in range(6):
            if j < 3:
                dx = _mul(work[WK_K + j], fka, r, fa, p, W_ANG, counts, S_KZ)
                work[WK_DX + j] = _add(work[WK_DX + j], fa, dx, fa, p, W_ANG, counts, S_KZ)
            else:
                dx = _mul(work[WK_K + j], fkb, r_deg, finn, p, W_BIAS, counts, S_KZ)
                work[WK_DX + j] = _add(work[WK_DX + j], fb, dx, fb, p, W_BIAS, counts, S_KZ)
        for j in range(6):
            fk = fka if j < 3 else fkb
            for k in range(j, 6):
                w = _blk(j, k)
                fo = p[w + 1]
                v = _sub(P[6 * j + k], fo, _mul(work[WK_K + j], fk, work[WK_ROW + k], p[_blk(a, k) + 1], p, w, counts,
                                                 S_PUPD), fo, p, w, counts, S_PUPD)
                if j == k and v < 1:
                    v = np.int64(1)
                P[6 * j + k] = v
                P[6 * k + j] = v
    for i in range(3):
        state[I_ATT + i] = _wrap(state[I_ATT + i] - work[WK_DX + i], p[W_ANG])
        state[I_BIAS + i] = _add(state[I_BIAS + i], fb, work[WK_DX + 3 + i], fb, p, W_BIAS, counts, S_BIAS_UPD)


@njit(cache=True, _nrt=False)
def tilt_raw(fx, fy, fz, iterations, work):
    """(phi, theta, |(f_y, f_z)|, |f|) of a specific-force vector (count sums, int64): roll and pitch by levelling
    (thesis digest 2.7 step 4, eqs 1.1-1.3 with the sensor's x, y, z), two CORDIC vectorings
    (:func:`firmware_model.cordic.vectoring_lanes`, gain-compensated magnitudes, in the sums' units):
        phi = atan2(f_y, f_z),   theta = atan2(-f_x, |(f_y, f_z)|)   (binary angles; theta in [-90, 90] deg)
    Used at the node's start (:func:`firmware_model.six_state_firmware._start`) and by :func:`level_raw`."""
    work[WK_CX], work[WK_CY] = fz, fy
    cordic.vectoring_lanes(work[WK_CX:WK_CX + 1], work[WK_CY:WK_CY + 1], iterations, work[WK_CA:WK_CA + 1],
                           work[WK_CS:WK_CS + 1])
    phi, m_yz = work[WK_CA], work[WK_CX]
    work[WK_CY] = -fx  # work[WK_CX] holds |(f_y, f_z)|
    cordic.vectoring_lanes(work[WK_CX:WK_CX + 1], work[WK_CY:WK_CY + 1], iterations, work[WK_CA:WK_CA + 1],
                           work[WK_CS:WK_CS + 1])
    return phi, work[WK_CA], m_yz, work[WK_CX]


@njit(cache=True, _nrt=False)
def level_raw(state, rate_raw, accel_sum, n_samples, params, counts, work):
    """The levelling update at a static tick (the fixed form of nodesim.chain.compiled.six_state_float_kernel.
    level_update; :mod:`firmware_model.six_state_fixed`, "Levelling"): ``rate_raw`` (3,) the tick's rates (rate
    format), ``accel_sum`` (3,) its accelerometer count sums over ``n_samples`` samples.  Returns 1 if the tick was
    static and updated, else 0 (levelling off, a moving tick, a zero force vector).
        static:   sum_i clamp(w_i - b_0,i)^2 < w_thr^2    exact integers on the rate raws (clamp at 2^30)
        phi_m, theta_m, |f_yz|, |f| = tilt_raw(f)         (eqs 1.1-1.3 resolution, CORDIC)
        sigma_F = c_sigma n                              the sums' noise, c_sigma = sigma_f S_a 180/pi (deg counts)
        R_theta = (sigma_F / |f|)^2,  R_phi = (sigma_F / |f_yz|)^2          (p_aa, deg^2; sites level sigma, R)
        update_raw(PITCH_ONLY or ROLL_PITCH, (phi_m, theta_m), (R_phi, R_theta))   (thesis eqs 3.27-3.31)
    the roll skipped where cos(theta_m) < sin(margin) (near horizontal; cordic.sin_cos, the predict's test)."""
    p = params
    if p[P_LEVEL] == 0:
        return 0
    thr = p[P_LEVEL_RATE]
    w2 = np.int64(0)
    for i in range(3):
        d = rate_raw[i] - state[I_B0 + i]
        if d > LEVEL_DIFF_LIMIT:
            d = np.int64(LEVEL_DIFF_LIMIT)
        elif d < -LEVEL_DIFF_LIMIT:
            d = np.int64(-LEVEL_DIFF_LIMIT)
        w2 += d * d
    if w2 >= thr * thr:
        return 0
    it = p[P_ITER]
    phi, theta, m_yz, m = tilt_raw(accel_sum[0], accel_sum[1], accel_sum[2], it, work)
    if m == 0:
        return 0
    fc, fl, faa = p[C_LSIG + 1], p[W_LSIG + 1], p[W_AA + 1]
    sig = p[C_LSIG] * n_samples  # exact: |c_sigma raw| < 2^31, n_samples < 2^31
    ref, var = work[WK_LREF:WK_LREF + 3], work[WK_LVAR:WK_LVAR + 3]
    ref[0], ref[1], ref[2] = phi, theta, 0
    var[0], var[2] = 0, 0
    r = _div(sig, fc, m, 0, p, W_LSIG, counts, S_LSIG)
    var[1] = _mul(r, fl, r, fl, p, W_AA, counts, S_LR)
    axes = PITCH_ONLY
    _, ct = cordic.sin_cos(theta, it)
    if ct >= p[P_SINM]:  # roll defined: |(f_y, f_z)| >= |f| sin(margin)
        r = _div(sig, fc, m_yz, 0, p, W_LSIG, counts, S_LSIG)
        var[0] = _mul(r, fl, r, fl, p, W_AA, counts, S_LR)
        axes = ROLL_PITCH
    update_raw(state, axes, ref, var, p, counts, work)
    return 1


# ---- the float boundary (what the IMU driver and the radio deliver) -----------------------------------------------
@njit(cache=True, _nrt=False)
def predict(state, rates_rad_s, params, counts, work):
    """:func:`predict_raw` with the gyro rates (x, y, z) in rad/s crossing into the rate format (site "gyro rate");
    ``work[WK_DX:WK_DX + 3]`` holds the raw rates meanwhile."""
    for i in range(3):
        v = rates_rad_s[i] * RAD_TO_DEG
        if not math.isfinite(v):
            raise FirmwareError("gyro rates: non-finite value; allowed finite rad/s")
        work[WK_DX + i] = _from_float_sat(v, params[W_RATE], params[W_RATE + 1], counts, S_GYRO)
    predict_raw(state, work[WK_DX:WK_DX + 3], params, counts, work)


@njit(cache=True, _nrt=False)
def update(state, axes, ref_rad, var_rad2, params, counts, work, raw):
    """:func:`update_raw` with the references (roll, pitch, yaw) in rad and their variances in rad^2 (only the yaw's
    read with YAW_ONLY); ``raw`` int64[6] receives the converted words (binary angles, then p_aa variances)."""
    lo, hi = _axes_range(axes)
    raw[:] = 0
    for a in range(lo, hi):
        if not (math.isfinite(ref_rad[a]) and math.isfinite(var_rad2[a])) or var_rad2[a] < 0:
            raise FirmwareError("reference: non-finite value or negative variance; allowed finite rad, variance >= 0")
        raw[a] = _from_float_wrap(ref_rad[a] / TURN_RAD, params[W_ANG], params[W_ANG + 1])
        raw[3 + a] = _from_float_sat(var_rad2[a] * RAD2_TO_DEG2, params[W_AA], params[W_AA + 1], counts, S_REF_VAR)
    update_raw(state, axes, raw[0:3], raw[3:6], params, counts, work)


@njit(cache=True, _nrt=False)
def attitude_rad(state, params, out):
    """(roll, pitch, yaw) of the lane in rad, each in [-pi, pi), into ``out`` (3,)."""
    for i in range(3):
        out[i] = _to_float(state[I_ATT + i], params[W_ANG + 1]) * TURN_RAD


@njit(cache=True, _nrt=False)
def yaw_rad(state, params):
    """The yaw a node transmits, rad in [-pi, pi)."""
    return _to_float(state[I_ATT + 2], params[W_ANG + 1]) * TURN_RAD


@njit(cache=True, _nrt=False)
def yaw_variance_rad2(state, params):
    return _to_float(state[I_P + 14], params[W_AA + 1]) / RAD2_TO_DEG2


@njit(cache=True, _nrt=False)
def run_ops(state, params, counts, work, ops, states_out):
    """A sequence of raw steps (the C twin's ``nf6_run``, for the bit-exact tests and the benchmark): ``ops`` rows
    (kind, a0, a1, a2, v0, v1, v2, n): kind 0 = predict_raw(rates a), 1 = update_raw(YAW_ONLY, refs a, variances v),
    3, 4, 5 = update_raw(ALL_AXES, ROLL_PITCH, PITCH_ONLY, ...), LEVEL_OP (8) = level_raw(rates a, accelerometer
    sums v, n samples); the state after each op into ``states_out`` rows (if it has any)."""
    for n in range(ops.shape[0]):
        if ops[n, 0] == 0:
            predict_raw(state, ops[n, 1:4], params, counts, work)
        elif ops[n, 0] == LEVEL_OP:
            level_raw(state, ops[n, 1:4], ops[n, 4:7], ops[n, 7], params, counts, work)
        else:
            update_raw(state, ops[n, 0], ops[n, 1:4], ops[n, 4:7], params, counts, work)
        if states_out.shape[0] > n:
            for i in range(STATE_SIZE):
                states_out[n, i] = state[i]


@njit(cache=True, _nrt=False)
def predict_lanes(states, rates_rad_s, params, counts, work):
    """:func:`predict` of every lane (rows of ``states`` and ``rates_rad_s`` (R, 3)); ``counts`` summed over lanes."""
    for r in range(states.shape[0]):
        predict(states[r], rates_rad_s[r], params, counts, work)


@njit(cache=True, _nrt=False)
def update_lanes(states, axes, ref_rad, var_rad2, mask, params, counts, work, raw):
    """:func:`update` of the lanes where ``mask`` (R,) is nonzero (the others neither change nor count)."""
    for r in range(states.shape[0]):
        if mask[r]:
            update(states[r], axes, ref_rad[r], var_rad2[r], params, counts, work, raw)


@njit(cache=True, _nrt=False)
def level_lanes(states, rates_rad_s, accel_sums, n_samples, params, counts, work):
    """:func:`level_raw` of every lane (rates (R, 3) in rad/s crossing into the rate format at site "gyro rate" as
    in :func:`predict`, accelerometer count sums (R, 3) over ``n_samples`` samples); returns the number of lanes
    levelled."""
    done = 0
    for r in range(states.shape[0]):
        for i in range(3):
            v = rates_rad_s[r, i] * RAD_TO_DEG
            if not math.isfinite(v):
                raise FirmwareError("gyro rates: non-finite value; allowed finite rad/s")
            work[WK_LRATE + i] = _from_float_sat(v, params[W_RATE], params[W_RATE + 1], counts, S_GYRO)
        done += level_raw(states[r], work[WK_LRATE:WK_LRATE + 3], accel_sums[r], n_samples, params, counts, work)
    return done
