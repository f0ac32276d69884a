"""The node firmware around its yaw filter, in the MCU's integer arithmetic (docs/firmware.md), one lane at a time.

One lane is one node in one realization; its state is an int64 vector (``STATE_SIZE`` words: the filter's five
words of :mod:`firmware_model.fixed_kernel` first, then the firmware's own).  Every step is an njit function
over int64 scalars, called from the compiled engine's loop, from the SimPy engine through :func:`run_lanes`-style
loops, and mirrored line by line by the C reference (``firmware_model/c/node_firmware.c``):

- counts -> rate (the IMU driver; MPU6500 sensitivity S LSB per deg/s, stored as S10 = 10 S, an integer for
  every MPU6500 range: 1310, 655, 328, 164)::

      rate = round_he(sum * 10 * 2^F_rate / (n * S10))                     Q(F_rate) deg/s

  of the tick's sum of n int16 samples of the z gyro (one rounding, no float);
- static window (thesis 4.2.3, "simple averaging" of the stationary rates): ``bias_sum += sum; bias_n += n``
  and at its end ``bias = round_he(bias_sum * 10 * 2^F_bias / (bias_n * S10))``, the filter started from the
  encoder's binary angle with P0;
- predict: :func:`firmware_model.fixed_kernel._predict_raw` with the tick's rate;
- reference advance, thesis eq 3.29, psi_ref = psi_prev + omega dt_transfer, in binary-angle arithmetic with the
  transfer time in microseconds of the node's timer::

      k   = round_he(transfer_us * 2^35 / 360e6)                           turns per (deg/s), Q35
      ref = wrap32(psi_prev + round_he(omega * k >> (F_rate + 35 - F_yaw)))   (not saturated: exact mod 1 turn)

  (transfer_us saturates at 2^24 - 1 us = 16.8 s, counted; older estimates are stale long before);
  with ``chain.rate_compensation = "extrapolated"`` omega += round_he((rate_k - rate_(k-1)) (dt_us - transfer_us)
  / (2 dt_us)), the tick mean brought from T[k] - dt/2 to the transfer's middle;
- reference variance (thesis digest 2.6): R = P_prev + (transfer_us sigma_rate)^2 + sigma_off^2 in P_yy's format,
  with sigma_rate per microsecond a build-time constant;
- the encoder reply (binary angle psi_enc read at t_read, its rate) brought back to the tick:
  ref = psi_enc - rate_enc (t_read - T[k]) (the same advance with the rate negated), R = q^2 / 12;
- update: :func:`firmware_model.fixed_kernel._update_raw`.

Parameters are one int64 vector (:data:`PARAMS`, built by :mod:`firmware_model.config`), overflow counts one
int64 vector indexed by :data:`SITES` (the filter's sites first).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from firmware_model import fixed_kernel as fk

# ---- state: the filter's words, then the firmware's ----------------------------------------------------------
S_RUNNING = 5  # 0 = static window (accumulating the bias), 1 = filter running
S_BIAS_SUM, S_BIAS_N = 6, 7  # static window sums of counts and samples
S_LAST_RATE, S_HAVE_LAST = 8, 9  # the previous tick's rate (extrapolated rate compensation), 1 once it exists
S_RATE = 10  # this tick's rate (Q F_rate deg/s), read every tick (static window too)
STATE_SIZE = 11

# ---- parameters --------------------------------------------------------------------------------------------
PARAMS = (
    "gyro_sens_x10",  # 10 x LSB per deg/s
    "sigma_rate_raw", "sigma_rate_frac",  # per-tick gyro sigma per microsecond of transfer, deg/us
    "offset_var_raw",  # sigma_off^2 in P_yy's format
    "encoder_var_raw",  # encoder q^2 / 12 in P_yy's format
    "extrapolate",  # 1: extrapolated rate compensation
    "dt_us",  # the firmware tick in microseconds
    "p0_yy_raw", "p0_bb_raw",  # initial covariance in the filter's formats
    "sigma_d_frac",  # fraction bits of the transfer term (transfer sigma_rate, deg)
)
_P = {name: i for i, name in enumerate(PARAMS)}
P_SENS, P_SIG, P_SIG_F, P_OFF2, P_ENC_VAR = (_P[n] for n in ("gyro_sens_x10", "sigma_rate_raw", "sigma_rate_frac",
                                                            "offset_var_raw", "encoder_var_raw"))
P_EXTRA, P_DT_US, P_P0_YY, P_P0_BB, P_SIG_D_F = (_P[n] for n in ("extrapolate", "dt_us", "p0_yy_raw", "p0_bb_raw",
                                                                 "sigma_d_frac"))
N_PARAMS = len(PARAMS)

# ---- overflow sites: the filter's, then the firmware's --------------------------------------------------------
FIRMWARE_SITES = ("tick rate", "initial bias", "transfer time", "advance gain", "omega", "transfer sigma",
                  "R transfer", "R sum")
SITES = fk.SITES + FIRMWARE_SITES
_S = {name: i for i, name in enumerate(SITES)}
X_RATE, X_BIAS0, X_TRANSFER, X_GAIN, X_OMEGA = (_S[n] for n in FIRMWARE_SITES[:5])
X_SIGMA_D, X_R_TRANSFER, X_R_SUM = (_S[n] for n in FIRMWARE_SITES[5:])

ADVANCE_FRAC = 35  # fraction bits of k = transfer / 360 (turns per deg/s): k < 2^31 LSB up to 22.5 s > the timer
MAX_TRANSFER_US = (1 << 24) - 1
US_PER_TURN_DEG = 360_000_000  # 360 deg x 1e6 us


@njit(cache=True, _nrt=False)
def counts_to_rate(count_sum, n, frac, sens_x10):
    """round_he(count_sum * 10 * 2^frac / (n * S10)): the mean of n int16 samples in Q(frac) deg/s (n >= 1)."""
    return fk.div_round(count_sum * 10 * (np.int64(1) << frac), n * sens_x10)


@njit(cache=True, _nrt=False)
def read_gyro(state, gyro_z_sum, n, params, fparams, counts) -> None:
    """Every tick (the IMU driver): the tick's rate from its z-gyro count sum over n samples; the previous one is
    kept for the extrapolated rate compensation."""
    fr, wr = fparams[fk.W_RATE + 1], fparams[fk.W_RATE]
    state[S_LAST_RATE] = state[S_RATE]
    state[S_HAVE_LAST] = 1 if state[S_HAVE_LAST] >= 0 else 0
    state[S_RATE] = fk._sat(counts_to_rate(gyro_z_sum, n, fr, params[P_SENS]), fr, wr, fr, counts, X_RATE)


@njit(cache=True, _nrt=False)
def init_lane(state) -> None:
    """A node at power-up: static window, no bias samples yet, no rate read yet."""
    for i in range(STATE_SIZE):
        state[i] = 0
    state[S_HAVE_LAST] = -1  # becomes 0 at the first read, 1 from the second on


@njit(cache=True, _nrt=False)
def accumulate_bias(state, gyro_z_sum, n) -> None:
    """One static-window tick (after :func:`read_gyro`): the integer sums of the initial bias (thesis 4.2.3,
    simple averaging of the stationary rates)."""
    state[S_BIAS_SUM] += gyro_z_sum
    state[S_BIAS_N] += n


@njit(cache=True, _nrt=False)
def start_filter(state, yaw0_raw, params, fparams, counts) -> None:
    """End of the static window: bias = the mean rate over it (0 without samples), yaw = the encoder's binary
    angle, P = P0."""
    fb, wb = fparams[fk.W_BIAS + 1], fparams[fk.W_BIAS]
    bias = np.int64(0)
    if state[S_BIAS_N] > 0:
        bias = fk._sat(counts_to_rate(state[S_BIAS_SUM], state[S_BIAS_N], fb, params[P_SENS]), fb, wb, fb, counts,
                       X_BIAS0)
    state[fk.I_YAW] = fk._wrap(yaw0_raw, fparams[fk.W_YAW])
    state[fk.I_BIAS] = bias
    state[fk.I_PYY], state[fk.I_PYB], state[fk.I_PBB] = params[P_P0_YY], 0, params[P_P0_BB]
    state[S_RUNNING] = 1


@njit(cache=True, _nrt=False)
def predict(state, fparams, counts) -> None:
    """Time update with the rate :func:`read_gyro` read this tick."""
    fk._predict_raw(state, state[S_RATE], fparams, counts)


@njit(cache=True, _nrt=False)
def transfer_us_sat(transfer_us, counts):
    """The transfer time as the node's timer holds it: 0 .. 2^24 - 1 us (longer ones saturate, counted)."""
    if transfer_us > MAX_TRANSFER_US:
        counts[X_TRANSFER] += 1
        return np.int64(MAX_TRANSFER_US)
    if transfer_us < 0:
        counts[X_TRANSFER] += 1
        return np.int64(0)
    return transfer_us


@njit(cache=True, _nrt=False)
def advance(yaw_raw, omega_raw, transfer_us, fparams, counts):
    """Eq 3.29 in binary-angle arithmetic (module docstring): yaw + omega transfer.  The increment is rounded, not
    saturated: a binary angle is exact modulo one turn, so any advance wraps correctly."""
    fr, wy, fy = fparams[fk.W_RATE + 1], fparams[fk.W_YAW], fparams[fk.W_YAW + 1]
    k = fk.div_round(transfer_us << ADVANCE_FRAC, US_PER_TURN_DEG)
    k = fk._sat(k, ADVANCE_FRAC, 32, ADVANCE_FRAC, counts, X_GAIN)
    inc = fk.shift_right_round(omega_raw * k, fr + ADVANCE_FRAC - fy)  # fr + 35 - fy = 19 for every word length
    return fk._wrap(yaw_raw + inc, wy)


@njit(cache=True, _nrt=False)
def omega(state, params, fparams, counts, transfer_us):
    """The node's bias-corrected rate (Q F_rate deg/s) used to advance a forwarded estimate; extrapolated to the
    transfer's middle when configured (module docstring)."""
    fr, wr, fb = fparams[fk.W_RATE + 1], fparams[fk.W_RATE], fparams[fk.W_BIAS + 1]
    w = fk._sub(state[S_RATE], fr, state[fk.I_BIAS], fb, fparams, fk.W_RATE, counts, X_OMEGA)
    if params[P_EXTRA] != 0 and state[S_HAVE_LAST] != 0:
        dt_us = params[P_DT_US]
        slope = fk.div_round((state[S_RATE] - state[S_LAST_RATE]) * (dt_us - transfer_us), 2 * dt_us)
        w = fk._sat(w + slope, fr, wr, fr, counts, X_OMEGA)
    return w


@njit(cache=True, _nrt=False)
def reference_variance(var_prev_raw, transfer_us, params, fparams, counts):
    """R = P_prev + (transfer sigma_rate)^2 + sigma_off^2 in P_yy's format (thesis digest 2.6)."""
    fyy, fd = fparams[fk.W_YY + 1], params[P_SIG_D_F]
    d = fk._sat(transfer_us * params[P_SIG], params[P_SIG_F], 32, fd, counts, X_SIGMA_D)
    d2 = fk._sat(d * d, 2 * fd, fparams[fk.W_YY], fyy, counts, X_R_TRANSFER)
    r = fk._add(var_prev_raw, fyy, d2, fyy, fparams, fk.W_YY, counts, X_R_SUM)
    return fk._add(r, fyy, params[P_OFF2], fyy, fparams, fk.W_YY, counts, X_R_SUM)


@njit(cache=True, _nrt=False)
def forwarded_update(state, up_yaw_raw, up_var_raw, transfer_us, params, fparams, counts):
    """Update from the estimate frame of the node above, read ``transfer_us`` before this tick; returns
    (reference, R) raws as applied."""
    tr = transfer_us_sat(transfer_us, counts)
    w = omega(state, params, fparams, counts, tr)
    ref = advance(up_yaw_raw, w, tr, fparams, counts)
    r = reference_variance(up_var_raw, tr, params, fparams, counts)
    fk._update_raw(state, ref, r, fparams, counts)
    return ref, r


@njit(cache=True, _nrt=False)
def encoder_update(state, enc_yaw_raw, enc_rate_raw, back_us, params, fparams, counts):
    """Update from the encoder reply read ``back_us`` after this tick: ref = psi_enc - rate_enc back, R = q^2/12;
    returns (reference, R) raws as applied."""
    tr = transfer_us_sat(back_us, counts)
    ref = advance(enc_yaw_raw, -enc_rate_raw, tr, fparams, counts)
    r = params[P_ENC_VAR]
    fk._update_raw(state, ref, r, fparams, counts)
    return ref, r


@njit(cache=True, _nrt=False)
def estimate_rate(state, params, fparams, counts):
    """The rate field of the estimate frame: the bias-corrected tick rate (no extrapolation)."""
    fr, fb = fparams[fk.W_RATE + 1], fparams[fk.W_BIAS + 1]
    return fk._sub(state[S_RATE], fr, state[fk.I_BIAS], fb, fparams, fk.W_RATE, counts, X_OMEGA)


# ---- one firmware tick ---------------------------------------------------------------------------------------
# what the node does this tick (IN_PHASE)
ABSENT, STATIC, START, HOLD, RUN = 0, 1, 2, 3, 4
# which reference reached it (IN_REF)
NO_REF, ENCODER_REF, FORWARDED_REF, DIRECT_REF = 0, 1, 2, 3  # DIRECT: a recorded reference and R (replay)
INPUTS = ("phase", "gyro_z_sum", "n", "yaw0_raw", "ref", "ref_yaw_raw", "ref_aux_raw", "transfer_us")
IN_PHASE, IN_GZ, IN_N, IN_YAW0, IN_REF, IN_REF_YAW, IN_REF_AUX, IN_TRANSFER = range(len(INPUTS))
OUTPUTS = ("applied", "ref_raw", "r_raw", "rate_raw")
OUT_APPLIED, OUT_REF, OUT_R, OUT_RATE = range(len(OUTPUTS))


@njit(cache=True, _nrt=False)
def node_tick(state, params, fparams, counts, inp, out) -> None:
    """One firmware tick of one lane (the C reference's ``node_firmware_tick``): read the gyro; in the static
    window accumulate the bias; at its end start the filter from the encoder (``yaw0_raw``); holding (a tube
    insertion) keeps the state; running: predict, then update from the encoder reply (``ref_yaw_raw`` binary
    angle, ``ref_aux_raw`` its rate, ``transfer_us`` from the tick to its reading) or from the estimate frame of the
    node above (``ref_yaw_raw``, ``ref_aux_raw`` = its P_yy raw, ``transfer_us`` since its reading) or, in a replay,
    from a recorded reference (``ref_yaw_raw`` binary angle and ``ref_aux_raw`` R as applied).
    ``out``: whether an update was applied, its reference and R raws, the frame's rate field."""
    out[OUT_APPLIED] = 0
    out[OUT_REF] = 0
    out[OUT_R] = 0
    phase = inp[IN_PHASE]
    if phase == ABSENT:
        return
    read_gyro(state, inp[IN_GZ], inp[IN_N], params, fparams, counts)
    if phase == STATIC:
        accumulate_bias(state, inp[IN_GZ], inp[IN_N])
    elif phase == START:
        start_filter(state, inp[IN_YAW0], params, fparams, counts)
    elif phase == RUN:
        predict(state, fparams, counts)
        kind = inp[IN_REF]
        if kind == ENCODER_REF:
            ref, r = encoder_update(state, inp[IN_REF_YAW], inp[IN_REF_AUX], inp[IN_TRANSFER], params, fparams,
                                    counts)
            out[OUT_APPLIED], out[OUT_REF], out[OUT_R] = 1, ref, r
        elif kind == FORWARDED_REF:
            ref, r = forwarded_update(state, inp[IN_REF_YAW], inp[IN_REF_AUX], inp[IN_TRANSFER], params, fparams,
                                      counts)
            out[OUT_APPLIED], out[OUT_REF], out[OUT_R] = 1, ref, r
        elif kind == DIRECT_REF:
            fk._update_raw(state, inp[IN_REF_YAW], inp[IN_REF_AUX], fparams, counts)
            out[OUT_APPLIED], out[OUT_REF], out[OUT_R] = 1, inp[IN_REF_YAW], inp[IN_REF_AUX]
    if state[S_RUNNING] != 0:
        out[OUT_RATE] = estimate_rate(state, params, fparams, counts)


@njit(cache=True, _nrt=False)
def node_tick_lanes(states, params, fparams, counts, inputs, outputs) -> None:
    """:func:`node_tick` for every lane r (``states`` (R, STATE_SIZE), ``inputs`` (R, len(INPUTS)), ``outputs``
    (R, len(OUTPUTS))): the SimPy engine's call, one per node tick for all realizations."""
    for r in range(states.shape[0]):
        node_tick(states[r], params, fparams, counts, inputs[r], outputs[r])
