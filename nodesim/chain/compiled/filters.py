"""Phase 2 of the compiled engine: one node's filter over its running ticks, given what phase 1 resolved.

Estimates only flow down the chain, so the nodes are run one after the other from the top, each over all of its
ticks, with the references phase 1 chose (:mod:`nodesim.chain.compiled.events`).  Per running tick k and
realization r, as :class:`nodesim.chain.node_process.ChainNode` does it:
    a holding tick (a tube insertion above the node): record the saved state, nothing else;
    predict with the tick-averaged gyro rate;
    the top node of the time, scheduled tick, reply received:  update with the encoder reference (the caller's);
    other nodes, a packet taken from node n - s (s = 1, or 2 after a fallback) read at its tick j:
        transfer = T[k] - T_(n-s)[j],  omega = gyro - bias_hat  (+ slope (dt - transfer) / 2 when extrapolated)
        psi_ref = psi_hat_(n-s)[j] + omega transfer                                  (thesis eq 3.29)
        R = P_(n-s)[j] + (transfer sigma_rate)^2 + sigma_off^2                        (thesis digest 2.6)
    record yaw, P_yy and bias.
:func:`run_node` is the float filter (:mod:`.float_kernel`, state ``fstate`` (R, 5)); the fixed-point firmware runs
its whole tick, :func:`firmware_model.node_firmware.node_tick`, in :func:`run_node_firmware`.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from firmware_model import fixed_kernel as fxk
from firmware_model import node_firmware as nf
from firmware_model import six_state_firmware as n6
from nodesim.chain.compiled import float_kernel as flk  # compiled into run_node; numba's cache of run_node is keyed
# on this file only: a change in float_kernel (2026-12-03: mod_two_pi in update) needs an edit here to recompile
from nodesim.chain.compiled import tick_plan as tp


@njit(cache=True, _nrt=False, inline="always")
def forwarded_reference(r, k, s, j, t, up_t, up_yaw, up_var, gyro, bias_rad_s, dt_s, extrapolate, rate_sigma,
                        offset_var):
    """(psi_ref, R) at tick ``k`` of realization ``r`` from the estimate node n - 1 - ``s`` read at its tick ``j``
    (module docstring; thesis eq 3.29, digest 2.6), the rate advanced with the z gyro ``gyro`` (R, K) minus
    ``bias_rad_s``: the 2-state and the 6-state loops share it."""
    transfer = t[k] - up_t[s][j]
    omega = gyro[r, k] - bias_rad_s
    if extrapolate and k > 0:
        slope = (gyro[r, k] - gyro[r, k - 1]) / dt_s
        omega = omega + slope * 0.5 * (dt_s - transfer)
    ref = up_yaw[s][r, j] + omega * transfer
    d = transfer * rate_sigma
    return ref, up_var[s][r, j] + d * d + offset_var


@njit(cache=True, _nrt=False, nogil=True)
def run_node(fstate, fparams, counts, gyro, t, k_first, k_end, codes, enc_ref, enc_var,
             applied, src_node, src_tick, up_t, up_yaw, up_var, dt_s, extrapolate, rate_sigma, offset_var,
             yaw, var, bias, ref_yaw, ref_var, r_first, r_end) -> None:
    """Ticks ``k_first`` .. ``k_end - 1`` of one node in realizations ``r_first`` .. ``r_end - 1`` (module
    docstring; disjoint ranges may run on parallel threads, each with its own ``counts``); ``codes`` (K,) what
    the node does at each tick (:mod:`.tick_plan`: static ticks are the caller's, a holding tick records the saved
    state); ``up_*`` = (node above, node two above) tick times and records; ``src_node`` (R, K) holds 1 or 2 (how
    far up the reference came from), 0 for none."""
    for r in range(r_first, r_end):  # realizations are independent: one after the other, each over its ticks
        fst = fstate[r]
        for k in range(k_first, k_end):
            c = codes[k]
            if c == tp.STATIC:
                continue
            if c != tp.HOLD:
                flk.predict(fst, gyro[r, k], fparams, counts)
            if c == tp.ASK:
                if applied[r, k]:
                    flk.update(fst, enc_ref[r, k], enc_var, fparams, counts)
                    ref_yaw[r, k], ref_var[r, k] = enc_ref[r, k], enc_var
            elif c == tp.RUN and src_node[r, k] > 0:
                ref, v = forwarded_reference(r, k, src_node[r, k] - 1, src_tick[r, k], t, up_t, up_yaw, up_var, gyro,
                                             flk.bias_rad_s(fst, fparams), dt_s, extrapolate, rate_sigma, offset_var)
                flk.update(fst, ref, v, fparams, counts)
                ref_yaw[r, k], ref_var[r, k] = ref, v
            yaw[r, k], var[r, k], bias[r, k] = (flk.yaw_rad(fst, fparams), flk.yaw_variance_rad2(fst, fparams),
                                                flk.bias_rad_s(fst, fparams))


@njit(cache=True)
def sequential_sum(gyro, stop: int):
    """Sum over the first ``stop`` ticks, added tick by tick (the static window's bias sum, same rounding)."""
    R = gyro.shape[0]
    out = gyro[:, 0] * 0.0
    for k in range(stop):
        for r in range(R):
            out[r] += gyro[r, k]
    return out


@njit(cache=True, _nrt=False, nogil=True)
def run_node_firmware(states, params, fparams, counts, gyro_sums, accel_sums, n_samples, t, codes, k_end, init, applied,
                      enc_yaw_raw, enc_rate_raw, enc_back_us, src_node, src_tick, up_t, rx_yaw_raw, rx_var_raw,
                      inp, out, yaw_raw, var_raw, rate_raw, bias_raw, yaw, var, bias, ref_yaw, ref_var, r_first,
                      r_end, six, params6, lane0, work) -> None:
    """The fixed-point firmware (:func:`firmware_model.node_firmware.node_tick`, or with ``six`` the 6-state node's
    :func:`firmware_model.six_state_firmware.node_tick`: ``params6``, ``lane0``, ``work`` its build, initial lane and
    scratch) of one node over ticks 0 .. ``k_end - 1`` of the arrays in realizations ``r_first`` .. ``r_end - 1``
    (the node's ticks from its first, ``init``: its lanes start there; else a window of them that goes on from the
    lanes where the window before left them: the same words as one call over both), each tick as
    ``codes`` says (:mod:`.tick_plan`): static window, the filter's start, holding, or predict and the reference
    phase 1 chose (the encoder reply read ``enc_back_us``
    after the tick for the top node; for the others ``rx_*_raw[r, k]``, the yaw and P_yy words decoded from the
    estimate frame node n - s sent at its tick j, :func:`.frame_pass.receive_frames`).  ``gyro_sums``,
    ``accel_sums`` (R, K, 3): the tick's count sums (the 2-state firmware reads the z gyro's).  Records the yaw,
    P_yy, rate and bias raws (the words of the frame it sends, :func:`.frame_pass.send_frames`) and the floats the
    SimPy engine records.  ``inp``/``out``: (R, len(INPUTS)) / (R, len(OUTPUTS)) work rows, one per realization."""
    sy, syy, sb = fxk.float_scales(fparams)  # the records' floats without an ldexp call per tick (~15 % of it)
    for r in range(r_first, r_end):
        st, x, o = states[r], inp[r], out[r]
        if init and six:
            n6.init_lane(st)
        elif init:
            nf.init_lane(st)
        for k in range(k_end):
            c = codes[k]
            x[nf.IN_GZ], x[nf.IN_N], x[nf.IN_REF] = gyro_sums[r, k, 2], n_samples[k], nf.NO_REF
            if c == tp.STATIC:
                x[nf.IN_PHASE] = nf.STATIC
            elif c == tp.START:
                x[nf.IN_PHASE], x[nf.IN_YAW0] = nf.START, enc_yaw_raw[r, k]
            elif c == tp.HOLD:
                x[nf.IN_PHASE] = nf.HOLD
            else:
                x[nf.IN_PHASE] = nf.RUN
                if c == tp.ASK:
                    if applied[r, k]:
                        x[nf.IN_REF], x[nf.IN_REF_YAW] = nf.ENCODER_REF, enc_yaw_raw[r, k]
                        x[nf.IN_REF_AUX], x[nf.IN_TRANSFER] = enc_rate_raw[r, k], enc_back_us[r, k]
                elif c == tp.RUN and src_node[r, k] > 0:
                    s, j = src_node[r, k] - 1, src_tick[r, k]
                    x[nf.IN_REF], x[nf.IN_REF_YAW], x[nf.IN_REF_AUX] = nf.FORWARDED_REF, rx_yaw_raw[r, k], rx_var_raw[r, k]
                    x[nf.IN_TRANSFER] = np.int64(np.rint((t[k] - up_t[s][j]) * 1e6))  # estimator.timer_us
            if six:
                x[n6.IN_GX], x[n6.IN_GY] = gyro_sums[r, k, 0], gyro_sums[r, k, 1]
                for i in range(3):
                    x[n6.IN_AX + i] = accel_sums[r, k, i]
                n6.node_tick(st, params6, lane0, params, fparams, counts, x, o, work)
            else:
                nf.node_tick(st, params, fparams, counts, x, o)
            if c == tp.STATIC:  # the static window reports the encoder's yaw (its survey's azimuth reference)
                yaw_raw[r, k] = enc_yaw_raw[r, k]
                continue
            yaw_raw[r, k], var_raw[r, k] = st[fxk.I_YAW], st[fxk.I_PYY]
            rate_raw[r, k], bias_raw[r, k] = o[nf.OUT_RATE], st[fxk.I_BIAS]
            yaw[r, k] = fxk.yaw_rad_of(st[fxk.I_YAW], sy)
            var[r, k] = fxk.yaw_variance_rad2_of(st[fxk.I_PYY], syy)
            bias[r, k] = fxk.bias_rad_s_of(st[fxk.I_BIAS], sb)
            if o[nf.OUT_APPLIED] != 0:
                ref_yaw[r, k] = fxk.yaw_rad_of(o[nf.OUT_REF], sy)
                ref_var[r, k] = fxk.yaw_variance_rad2_of(o[nf.OUT_R], syy)
