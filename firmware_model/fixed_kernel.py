"""The fixed-point yaw filter (:class:`firmware_model.fixed_filter.FixedYawFilter`) as numba scalar kernels.

One realization ("lane") at a time: ``state`` is an int64[5] view (yaw, bias, P_yy, P_yb, P_bb raws, see
:func:`lane_states`), ``params`` the int64 vector of :func:`kernel_params` (formats and build-time constants),
``counts`` an int64[len(SITES)] overflow counter.  Every kernel performs the class's exact
primitive-by-primitive sequence (:mod:`firmware_model.fixedpoint` with round half even and saturation; the
binary angle wraps) on int64 scalars, so the bits and the per-site overflow counts are the class's:

- requantize by ``s = F_in - F``: ``s > 0``: ``(x + ((x >> s) & 1) + (1 << (s-1)) - 1) >> s`` (round half
  even); ``s < 0``: ``x << -s`` saturated when ``x`` lies outside ``[-((-MIN) >> -s), MAX >> -s]``; then
  ``MIN <= x <= MAX`` or saturate.  Every saturation adds 1 to its site;
- ``add``/``sub`` align both words to the finer format first; ``mul`` keeps the exact int64 product;
- ``div``: ``n = a << s`` (or ``d = b << -s``), floor quotient on a positive divisor, round half even from the
  remainder; a zero divisor gives MAX/MIN by the numerator's sign and counts once;
- ``from_float``: ``rint(ldexp(x, F))`` (IEEE round half even), saturated (counted) or, for the reference
  angle, wrapped modulo ``2**W`` (not counted); ``to_float``: ``ldexp(raw, -F)``.

Float operations keep the class's order (``rate * RAD_TO_DEG``, ``ref / TURN_RAD``, ``var * RAD_TO_DEG**2``,
``to_float(yaw) * TURN_RAD`` ...) and no fastmath, so the floats are the same doubles.  Only the default
policy (HALF_EVEN, SATURATE) is compiled; :func:`kernel_params` rejects any other.  Shifts outside what
:mod:`firmware_model.fixedpoint` allows raise :class:`~firmware_model.errors.FirmwareError` at the first use, where
the class raises ``FirmwareError``.

The primitives and the raw steps are plain njit functions called from the caller's compiled loop.  They were
inlined at numba's IR level (``inline="always"``) until 2026-12-01: that made the compiled engine take ~3 min
to compile on a fresh machine against ~40 s without it, and measured no faster (2000 predict+update steps of
one filter: 0.25 ms without, 0.41 ms with, on a noisy host; the chain benchmarks within their noise).
A caller's njit loop calls ``predict``/``update`` directly.  Every kernel here (and in
:mod:`firmware_model.node_firmware`) is compiled with ``_nrt=False``: none allocates, and without it a kernel
compiled first from an NRT caller (a test, a Python call) is cached with a reference-count increment and
decrement of every array argument around each inner call, which the engine's ``_nrt=False`` loop then loads
from the cache: the same firmware tick measured 84 ns or 230 ns per node-tick depending on which process had
compiled the kernels first (numba only passes a caller's ``_nrt=False`` down to callees it compiles itself).

The class applies an update mask after computing every lane: its overflow counts include lanes whose update
is discarded.  ``update`` here is the class's update of one lane with the mask True.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from firmware_model.fixedpoint import MAX_SHIFT, Overflow, Rounding
from firmware_model.errors import FirmwareError

RAD_TO_DEG = 180.0 / math.pi
TURN_RAD = 2.0 * math.pi  # one turn of the binary angle

SITES: tuple[str, ...] = (
    # predict
    "gyro rate", "rate - bias", "yaw increment", "2 dt P_yb", "P_yy predict", "dt^2 P_bb", "dt P_bb",
    "P_yb predict", "f^2 P_bb", "P_bb predict",
    # update
    "reference variance", "S = P_yy + R", "1 / S", "K_y", "K_b", "innovation deg", "K_y z", "K_b z",
    "bias update", "K_y P_yy", "P_yy update", "K_y P_yb", "P_yb update", "K_b P_yb", "P_bb update",
)
_SITE = {name: i for i, name in enumerate(SITES)}
S_GYRO, S_RATE_BIAS, S_YAW_INC = _SITE["gyro rate"], _SITE["rate - bias"], _SITE["yaw increment"]
S_2DT_PYB, S_PYY_PRED, S_DT2_PBB = _SITE["2 dt P_yb"], _SITE["P_yy predict"], _SITE["dt^2 P_bb"]
S_DT_PBB, S_PYB_PRED, S_F2_PBB, S_PBB_PRED = _SITE["dt P_bb"], _SITE["P_yb predict"], _SITE["f^2 P_bb"], _SITE["P_bb predict"]
S_REF_VAR, S_S, S_INV, S_KY, S_KB = (_SITE[s] for s in ("reference variance", "S = P_yy + R", "1 / S", "K_y", "K_b"))
S_INNOV, S_KY_Z, S_KB_Z, S_BIAS_UPD = (_SITE[s] for s in ("innovation deg", "K_y z", "K_b z", "bias update"))
S_KY_PYY, S_PYY_UPD, S_KY_PYB = _SITE["K_y P_yy"], _SITE["P_yy update"], _SITE["K_y P_yb"]
S_PYB_UPD, S_KB_PYB, S_PBB_UPD = _SITE["P_yb update"], _SITE["K_b P_yb"], _SITE["P_bb update"]

STATE_FIELDS = ("yaw", "bias", "p_yy", "p_yb", "p_bb")  # columns of lane_states
I_YAW, I_BIAS, I_PYY, I_PYB, I_PBB = range(5)

# params layout: (word_bits, frac_bits) of every FixedFormats field, then (raw, frac_bits, word_bits) of every
# build-time constant, in CONSTANTS order
FORMAT_FIELDS = ("yaw", "rate", "bias", "p_yy", "p_yb", "p_bb", "inv_s", "gain_yaw", "gain_bias", "innovation_deg")
CONSTANTS = ("k_turns", "c_2dt", "c_dt2", "q_yy", "c_dt", "c_f", "c_f2", "q_bb", "one", "c_360")
_FMT = {name: 2 * i for i, name in enumerate(FORMAT_FIELDS)}
_CONST = {name: 2 * len(FORMAT_FIELDS) + 3 * j for j, name in enumerate(CONSTANTS)}
N_PARAMS = 2 * len(FORMAT_FIELDS) + 3 * len(CONSTANTS)
W_YAW, W_RATE, W_BIAS, W_YY, W_YB, W_BB = (_FMT[n] for n in ("yaw", "rate", "bias", "p_yy", "p_yb", "p_bb"))
W_INV, W_KY, W_KB, W_INN = (_FMT[n] for n in ("inv_s", "gain_yaw", "gain_bias", "innovation_deg"))
C_KT, C_2DT, C_DT2, C_QYY, C_DT = (_CONST[n] for n in ("k_turns", "c_2dt", "c_dt2", "q_yy", "c_dt"))
C_F, C_F2, C_QBB, C_ONE, C_360 = (_CONST[n] for n in ("c_f", "c_f2", "q_bb", "one", "c_360"))
# the frac bits of a format sit at W_* + 1; a constant's frac bits at C_* + 1

RAD2_TO_DEG2 = RAD_TO_DEG**2  # the class computes RAD_TO_DEG**2 in Python: the same double
MAX_ALIGN = 31  # fixedpoint._align
MAX_DIV_SHIFT = 30  # fixedpoint.div


def kernel_params(kf: "FixedYawFilter") -> np.ndarray:
    """int64[N_PARAMS]: the formats (word, frac bits) and the constants (raw, frac, word bits) of ``kf``."""
    f = kf.formats
    if kf.ctx.rounding is not Rounding.HALF_EVEN or kf.ctx.overflow is not Overflow.SATURATE:
        raise FirmwareError(
            f"compiled fixed filter: policy rounding={kf.ctx.rounding.value}, overflow={kf.ctx.overflow.value}; "
            f"allowed only rounding={Rounding.HALF_EVEN.value}, overflow={Overflow.SATURATE.value}")
    for name in STATE_FIELDS:
        fmt = getattr(kf, name).fmt
        if fmt != getattr(f, name):
            raise FirmwareError(f"compiled fixed filter: state {name} is in {fmt}, formats.{name} = {getattr(f, name)}")
    p = np.zeros(N_PARAMS, dtype=np.int64)
    for name, i in _FMT.items():
        fmt = getattr(f, name)
        p[i], p[i + 1] = fmt.word_bits, fmt.frac_bits
    for name, i in _CONST.items():
        c = getattr(kf, name)
        raw = np.asarray(c.raw, dtype=np.int64)
        if raw.size != 1:
            raise FirmwareError(f"compiled fixed filter: constant {name} has {raw.size} values; allowed one")
        p[i], p[i + 1], p[i + 2] = raw.reshape(-1)[0], c.fmt.frac_bits, c.fmt.word_bits
    return p


def lane_states(kf: "FixedYawFilter") -> np.ndarray:
    """int64 (R, 5): the yaw, bias, P_yy, P_yb, P_bb raws of every realization (a copy)."""
    R = kf.realizations
    return np.stack([np.broadcast_to(np.asarray(getattr(kf, n).raw, dtype=np.int64), (R,)) for n in STATE_FIELDS], 1)


def counts_dict(counts) -> dict[str, int]:
    """The nonzero overflow counts by site name (the form of ``FixedYawFilter.overflow_counts``)."""
    return {SITES[i]: int(c) for i, c in enumerate(np.asarray(counts)) if c}


# ---- primitives on int64 scalars ---------------------------------------------------------------------------
@njit(cache=True, _nrt=False)
def shift_right_round(x, s):
    """x / 2^s rounded half to even (s >= 1), no saturation: ``(x + ((x >> s) & 1) + (1 << (s-1)) - 1) >> s``."""
    return (x + (((x >> s) & 1) + (np.int64(1) << (s - 1)) - 1)) >> s


@njit(cache=True, _nrt=False)
def div_round(n, d):
    """n / d rounded half to even for d > 0: the floor quotient, then the remainder decides (C: fx_div_round)."""
    q = n // d
    r2 = 2 * (n - q * d)
    if r2 > d or (r2 == d and (q & 1) == 1):
        q += 1
    return q


@njit(cache=True, _nrt=False)
def _sat(x, frac_in, w, f, counts, site):
    """fixedpoint._requantize with HALF_EVEN and SATURATE of the int64 intermediate ``x``."""
    hi = (np.int64(1) << (w - 1)) - 1
    lo = -hi - 1
    s = frac_in - f
    if s > 0:
        if s > MAX_SHIFT:
            raise FirmwareError("compiled fixed filter: a right shift exceeds 62 bits (formats outside fixedpoint's range)")
        x = shift_right_round(x, s)
    elif s < 0:
        ls = -s
        if ls > MAX_SHIFT:
            raise FirmwareError("compiled fixed filter: a left shift exceeds 62 bits (formats outside fixedpoint's range)")
        if x > (hi >> ls):
            counts[site] += 1
            return hi
        if x < -((-lo) >> ls):
            counts[site] += 1
            return lo
        return x << ls
    if x > hi:
        counts[site] += 1
        return hi
    if x < lo:
        counts[site] += 1
        return lo
    return x


@njit(cache=True, _nrt=False)
def _aligned(a, fa, b, fb, sign):
    """((int64_t)a << sa) +/- ((int64_t)b << sb) in the finer format; returns (sum, its frac bits)."""
    if abs(fa - fb) > MAX_ALIGN:
        raise FirmwareError("compiled fixed filter: add/sub of formats whose fraction bits differ by more than 31")
    fm = max(fa, fb)
    xa, xb = a << (fm - fa), b << (fm - fb)
    return (xa + xb if sign > 0 else xa - xb), fm


@njit(cache=True, _nrt=False)
def _add(a, fa, b, fb, p, i, counts, site):
    x, fm = _aligned(a, fa, b, fb, 1)
    return _sat(x, fm, p[i], p[i + 1], counts, site)


@njit(cache=True, _nrt=False)
def _sub(a, fa, b, fb, p, i, counts, site):
    x, fm = _aligned(a, fa, b, fb, -1)
    return _sat(x, fm, p[i], p[i + 1], counts, site)


@njit(cache=True, _nrt=False)
def _mul(a, fa, b, fb, p, i, counts, site):
    return _sat(a * b, fa + fb, p[i], p[i + 1], counts, site)


@njit(cache=True, _nrt=False)
def _div(a, fa, b, fb, p, i, counts, site):
    """fixedpoint.div with HALF_EVEN and SATURATE."""
    w, f = p[i], p[i + 1]
    s = f - fa + fb
    if abs(s) > MAX_DIV_SHIFT:
        raise FirmwareError("compiled fixed filter: division shift outside -30..30 (formats outside fixedpoint's range)")
    n, d = a, b
    if s >= 0:
        n = n << s
    else:
        d = d << (-s)
    if d < 0:
        n, d = -n, -d
    if d == 0:  # the guarded division: MAX or MIN by the numerator's sign, one overflow
        counts[site] += 1
        return (np.int64(1) << (w - 1)) - 1 if n >= 0 else -(np.int64(1) << (w - 1))
    return _sat(div_round(n, d), f, w, f, counts, site)


@njit(cache=True, _nrt=False)
def _wrap(x, w):
    """Two's-complement wrap into ``w`` bits (the binary angle)."""
    x &= (np.int64(1) << w) - 1
    return x - ((x >> (w - 1)) << w)


@njit(cache=True, _nrt=False)
def _from_float_sat(v, w, f, counts, site):
    """fixedpoint.from_float (HALF_EVEN, SATURATE) of one finite double."""
    y = np.rint(math.ldexp(v, f))
    hi = (np.int64(1) << (w - 1)) - 1
    lo = -hi - 1
    if y > hi:
        counts[site] += 1
        return hi
    if y < lo:
        counts[site] += 1
        return lo
    return np.int64(y)


@njit(cache=True, _nrt=False)
def _from_float_wrap(v, w, f):
    """fixedpoint.from_float (HALF_EVEN, WRAP, no counter) of one finite double: the exact residue modulo 2**w.
    A value whose scaling overflows to infinity gives 0, as the class does (fmod(inf) = NaN, cast to INT64_MIN
    on x86, whose low ``w`` bits are 0)."""
    y = np.rint(math.ldexp(v, f))
    if not math.isfinite(y):
        return np.int64(0)
    hi = (np.int64(1) << (w - 1)) - 1
    if -hi - 1 <= y <= hi:
        return np.int64(y)
    return _wrap(np.int64(np.fmod(y, math.ldexp(1.0, w))), w)


@njit(cache=True, _nrt=False)
def _to_float(raw, f):
    return math.ldexp(float(raw), -f)


# ---- the filter ----------------------------------------------------------------------------------------------
@njit(cache=True, _nrt=False)
def _predict_raw(state, rate_raw, params, counts):
    """FixedYawFilter.predict_raw of one lane, the gyro rate already a raw word in ``formats.rate``."""
    p = params
    fr, fb, fy, fyy, fyb, fbb = p[W_RATE + 1], p[W_BIAS + 1], p[W_YAW + 1], p[W_YY + 1], p[W_YB + 1], p[W_BB + 1]
    yaw, bias, p_yy, p_yb, p_bb = state[I_YAW], state[I_BIAS], state[I_PYY], state[I_PYB], state[I_PBB]
    d = _sub(rate_raw, fr, bias, fb, p, W_RATE, counts, S_RATE_BIAS)
    inc = _mul(d, fr, p[C_KT], p[C_KT + 1], p, W_YAW, counts, S_YAW_INC)
    new_yaw = _wrap(yaw + inc, p[W_YAW])  # fp.add(..., WRAP): both in the yaw format, no shift
    y = _add(p_yy, fyy, _mul(p_yb, fyb, p[C_2DT], p[C_2DT + 1], p, W_YY, counts, S_2DT_PYB), fyy, p, W_YY, counts, S_PYY_PRED)
    y = _add(y, fyy, _mul(p_bb, fbb, p[C_DT2], p[C_DT2 + 1], p, W_YY, counts, S_DT2_PBB), fyy, p, W_YY, counts, S_PYY_PRED)
    y = _add(y, fyy, p[C_QYY], p[C_QYY + 1], p, W_YY, counts, S_PYY_PRED)
    yb = _add(p_yb, fyb, _mul(p_bb, fbb, p[C_DT], p[C_DT + 1], p, W_YB, counts, S_DT_PBB), fyb, p, W_YB, counts, S_PYB_PRED)
    yb = _mul(yb, fyb, p[C_F], p[C_F + 1], p, W_YB, counts, S_PYB_PRED)
    bb = _add(_mul(p_bb, fbb, p[C_F2], p[C_F2 + 1], p, W_BB, counts, S_F2_PBB), fbb, p[C_QBB], p[C_QBB + 1], p, W_BB,
              counts, S_PBB_PRED)
    state[I_YAW], state[I_PYY], state[I_PYB], state[I_PBB] = new_yaw, max(y, 1), yb, max(bb, 1)


@njit(cache=True, _nrt=False)
def predict(state, rate_rad_s, params, counts):
    """FixedYawFilter.predict of one lane: the rate in rad/s crosses into Q deg/s (site "gyro rate")."""
    v = rate_rad_s * RAD_TO_DEG
    if not math.isfinite(v):
        raise FirmwareError("gyro rate: non-finite value (or one whose deg/s value overflows); allowed finite rad/s")
    _predict_raw(state, _from_float_sat(v, params[W_RATE], params[W_RATE + 1], counts, S_GYRO), params, counts)


@njit(cache=True, _nrt=False)
def _update_raw(state, ref_raw, r_raw, params, counts):
    """FixedYawFilter.update_raw of one lane (mask True): reference as a binary angle, variance in P_yy's format."""
    p = params
    fy, fb, fyy, fyb, fbb = p[W_YAW + 1], p[W_BIAS + 1], p[W_YY + 1], p[W_YB + 1], p[W_BB + 1]
    fi, fky, fkb, fin = p[W_INV + 1], p[W_KY + 1], p[W_KB + 1], p[W_INN + 1]
    yaw, bias, p_yy, p_yb, p_bb = state[I_YAW], state[I_BIAS], state[I_PYY], state[I_PYB], state[I_PBB]
    z = _wrap(yaw - ref_raw, p[W_YAW])  # (int32_t)(yaw - ref): the wrapped innovation
    s = _add(p_yy, fyy, r_raw, fyy, p, W_YY, counts, S_S)
    inv = _div(p[C_ONE], p[C_ONE + 1], s, fyy, p, W_INV, counts, S_INV)
    k_y = _mul(p_yy, fyy, inv, fi, p, W_KY, counts, S_KY)
    k_b = _mul(p_yb, fyb, inv, fi, p, W_KB, counts, S_KB)
    z_deg = _mul(z, fy, p[C_360], p[C_360 + 1], p, W_INN, counts, S_INNOV)
    new_yaw = _wrap(yaw - _mul(k_y, fky, z, fy, p, W_YAW, counts, S_KY_Z), p[W_YAW])
    new_bias = _add(bias, fb, _mul(k_b, fkb, z_deg, fin, p, W_BIAS, counts, S_KB_Z), fb, p, W_BIAS, counts, S_BIAS_UPD)
    yy = _sub(p_yy, fyy, _mul(k_y, fky, p_yy, fyy, p, W_YY, counts, S_KY_PYY), fyy, p, W_YY, counts, S_PYY_UPD)
    yb = _sub(p_yb, fyb, _mul(k_y, fky, p_yb, fyb, p, W_YB, counts, S_KY_PYB), fyb, p, W_YB, counts, S_PYB_UPD)
    bb = _sub(p_bb, fbb, _mul(k_b, fkb, p_yb, fyb, p, W_BB, counts, S_KB_PYB), fbb, p, W_BB, counts, S_PBB_UPD)
    state[I_YAW], state[I_BIAS], state[I_PYY], state[I_PYB], state[I_PBB] = new_yaw, new_bias, max(yy, 1), yb, max(bb, 1)


@njit(cache=True, _nrt=False)
def update(state, ref_rad, var_rad2, params, counts):
    """FixedYawFilter.update of one lane with the mask True."""
    if not (math.isfinite(ref_rad) and math.isfinite(var_rad2)):
        raise FirmwareError("reference yaw/variance: non-finite value; allowed finite numbers")
    if var_rad2 < 0:
        raise FirmwareError("reference variance: negative value; allowed >= 0 (rad^2)")
    v = var_rad2 * RAD2_TO_DEG2
    if not math.isfinite(v):
        raise FirmwareError("reference variance: its deg^2 value overflows; allowed finite numbers")
    ref_raw = _from_float_wrap(ref_rad / TURN_RAD, params[W_YAW], params[W_YAW + 1])
    r_raw = _from_float_sat(v, params[W_YY], params[W_YY + 1], counts, S_REF_VAR)
    _update_raw(state, ref_raw, r_raw, params, counts)


@njit(cache=True, _nrt=False)
def predict_raw_lanes(states, rate_raws, params, counts):
    """:func:`_predict_raw` of every lane (rows of ``states``); ``counts`` summed over the lanes."""
    for r in range(states.shape[0]):
        _predict_raw(states[r], rate_raws[r], params, counts)


@njit(cache=True, _nrt=False)
def update_raw_lanes(states, ref_raws, r_raws, params, counts):
    """:func:`_update_raw` of every lane (rows of ``states``); ``counts`` summed over the lanes."""
    for r in range(states.shape[0]):
        _update_raw(states[r], ref_raws[r], r_raws[r], params, counts)


@njit(cache=True, _nrt=False)
def float_scales(params):
    """(2^-F_yaw, 2^-F_yy, 2^-F_bias) of the formats in ``params``: a word times its format's scale is the double
    ``_to_float`` gives (ldexp(raw, -F); scaling by a power of two is exact away from the subnormals, and the words'
    doubles are >= 2^-62), so a tick loop computes the three ldexp calls (~3 ns each) once and converts with
    :func:`yaw_rad_of`, :func:`yaw_variance_rad2_of`, :func:`bias_rad_s_of`."""
    return math.ldexp(1.0, -params[W_YAW + 1]), math.ldexp(1.0, -params[W_YY + 1]), math.ldexp(1.0, -params[W_BIAS + 1])


@njit(cache=True, _nrt=False)
def yaw_rad_of(raw, yaw_scale):
    """A yaw-format word (binary angle) in radians, ``yaw_scale`` = 2^-F_yaw (:func:`float_scales`)."""
    return float(raw) * yaw_scale * TURN_RAD


@njit(cache=True, _nrt=False)
def yaw_variance_rad2_of(raw, yy_scale):
    """A P_yy-format word in rad^2, ``yy_scale`` = 2^-F_yy (:func:`float_scales`)."""
    return float(raw) * yy_scale / RAD2_TO_DEG2


@njit(cache=True, _nrt=False)
def bias_rad_s_of(raw, bias_scale):
    """A bias-format word in rad/s, ``bias_scale`` = 2^-F_bias (:func:`float_scales`)."""
    return float(raw) * bias_scale / RAD_TO_DEG


@njit(cache=True, _nrt=False)
def yaw_rad(state, params):
    """FixedYawFilter.yaw_rad of one lane (binary angle in radians, [-pi, pi))."""
    return yaw_rad_of(state[I_YAW], math.ldexp(1.0, -params[W_YAW + 1]))


@njit(cache=True, _nrt=False)
def bias_rad_s(state, params):
    return bias_rad_s_of(state[I_BIAS], math.ldexp(1.0, -params[W_BIAS + 1]))


@njit(cache=True, _nrt=False)
def yaw_variance_rad2(state, params):
    return yaw_variance_rad2_of(state[I_PYY], math.ldexp(1.0, -params[W_YY + 1]))
