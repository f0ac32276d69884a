"""Fused no-overflow fast path of the fixed-point yaw filter (:mod:`firmware_model.fixed_filter`).

The filter's per-tick sequence of fixed-point primitives, computed on raw int64 arrays with the same integer
operations as :mod:`firmware_model.fixedpoint` (``(int64_t)a * b``, aligned sums ``(a << sa) +/- (b << sb)``,
the round-half-even shift ``x + ((x >> s) & 1) + (1 << (s - 1)) - 1 >> s``, the rounded division, the
binary-angle wrap) but without the per-primitive ``Fx`` wrapping, argument checks and saturation: every
intermediate the exact path would saturate is collected with its format's limits and all are checked at the
end in one comparison (a :class:`_Trace`).  If any lies outside its range (or a divisor is not positive, or a
shift is outside the cases fused here) the result is discarded: the functions return ``None`` (or raise
:class:`Unsupported`) and the caller runs the exact primitive-by-primitive path, which saturates and counts.
Without overflow every saturation is the identity, so both paths give the same bits and neither records an
overflow.  Only the default policy (round half even, saturate) is fused.
"""

from __future__ import annotations

import numpy as np

from firmware_model.fixedpoint import MAX_SHIFT

INT64_MAX = (1 << 63) - 1
MAX_DIV_SHIFT = 30


class Unsupported(Exception):
    """A case the fast path does not cover (or a single realization's overflow); the exact path computes (or
    rejects) it."""


class _Trace:
    """Intermediates that the exact path would saturate, with their raw limits."""

    __slots__ = ("vals", "lo", "hi", "scalar")

    def __init__(self, scalar: bool):
        self.vals, self.lo, self.hi, self.scalar = [], [], [], scalar

    def sat(self, x: np.ndarray, lo: int, hi: int) -> np.ndarray:
        if self.scalar:  # a Python int is checked at once: an overflow ends the fast path early
            if not lo <= x <= hi:
                raise Unsupported
            return x
        self.vals.append(x)
        self.lo.append(lo)
        self.hi.append(hi)
        return x

    def in_range(self) -> bool:
        if self.scalar:
            return True  # checked in sat
        v = np.stack(self.vals)
        return not ((v < np.array(self.lo)[:, None]).any() or (v > np.array(self.hi)[:, None]).any())


def _round_right(x: np.ndarray, s: int) -> np.ndarray:
    """x / 2**s rounded half to even, in place (the exact path's HALF_EVEN shift)."""
    if s > MAX_SHIFT:
        raise Unsupported
    t = x >> s
    t &= 1
    t += (1 << (s - 1)) - 1
    x += t
    x >>= s
    return x


def _sat(tr: _Trace, x: np.ndarray, frac_in: int, fmt) -> np.ndarray:
    """Requantize owned int64 ``x`` to ``fmt`` (saturation deferred to the trace)."""
    s = frac_in - fmt.frac_bits
    lo, hi = fmt.min_raw, fmt.max_raw
    if s > 0:
        x = _round_right(x, s)
    elif s < 0:
        if -s > MAX_SHIFT:
            raise Unsupported
        tr.sat(x, -((-lo) >> -s), hi >> -s)  # x << -s stays in range iff x does within these
        return x << -s
    return tr.sat(x, lo, hi)


def _wrap(x: np.ndarray, frac_in: int, fmt) -> np.ndarray:
    """Requantize owned ``x`` to ``fmt`` with two's-complement wrap (a binary angle)."""
    s = frac_in - fmt.frac_bits
    if s < 0:
        raise Unsupported
    if s > 0:
        x = _round_right(x, s)
    w = fmt.word_bits
    x &= (1 << w) - 1
    x -= (x >> (w - 1)) << w
    return x


def _aligned(a, fa: int, b, fb: int, sign: int) -> tuple[np.ndarray, int]:
    """((int64_t)a << sa) +/- ((int64_t)b << sb) in the finer of the two formats."""
    if abs(fa - fb) > 31:
        raise Unsupported
    f = max(fa, fb)
    xa, xb = a << (f - fa), b << (f - fb)
    return (xa + xb if sign > 0 else xa - xb), f


def _add(tr, a, fa, b, fb, out):
    x, f = _aligned(a, fa, b, fb, 1)
    return _sat(tr, x, f, out)


def _sub(tr, a, fa, b, fb, out):
    x, f = _aligned(a, fa, b, fb, -1)
    return _sat(tr, x, f, out)


def _mul(tr, a, fa, b, fb, out):
    return _sat(tr, a * b, fa + fb, out)


def _div(tr, a, fa, b, fb, out):
    """Rounded a / b for positive b (others go to the exact path, which handles zero and signs)."""
    s = out.frac_bits - fa + fb
    if abs(s) > MAX_DIV_SHIFT:
        raise Unsupported
    n, d = (a << s, b) if s >= 0 else (a, b << -s)
    tr.sat(d, 1, INT64_MAX)
    d = _floor(tr, d)
    q = n // d
    r2 = 2 * (n - q * d)
    q = q + ((r2 > d) | ((r2 == d) & ((q & 1) == 1)))
    return tr.sat(q, out.min_raw, out.max_raw)


def _floor(tr, x):
    """max(x, 1) (the variance floor of the filter)."""
    return max(x, 1) if tr.scalar else np.maximum(x, 1)


def _raws(fxs, scalar: bool) -> list:
    """The raw words of ``fxs``: Python ints for a single realization (no numpy call per primitive; every
    fused intermediate of in-range words fits in int64, so int and int64 arithmetic agree), else arrays."""
    if scalar:
        return [int(x.raw.reshape(-1)[0]) for x in fxs]
    return [x.raw for x in fxs]


CONSTANTS = ("k_turns", "c_2dt", "c_dt2", "q_yy", "c_dt", "c_f", "c_f2", "q_bb", "one", "c_360")


def _constants(kf, scalar: bool) -> list:
    """The raws of the filter's build-time constants (cached on the filter: they never change)."""
    cache = kf.__dict__.setdefault("_fused_constants", {})
    if scalar not in cache:
        cache[scalar] = _raws([getattr(kf, name) for name in CONSTANTS], scalar)
    return cache[scalar]


def _arrays(values, scalar: bool) -> tuple:
    return tuple(np.array([v], dtype=np.int64) for v in values) if scalar else tuple(values)


def _frac(fx) -> int:
    return fx.fmt.frac_bits


def predict(kf, rate, scalar: bool = False) -> tuple | None:
    """(yaw, p_yy, p_yb, p_bb) raws after ``kf.predict_raw(rate)`` or None (run the exact path); ``scalar``:
    a single realization, computed on Python ints."""
    f, tr = kf.formats, _Trace(scalar)
    yaw, bias, p_yy, p_yb, p_bb, rate_raw = _raws((kf.yaw, kf.bias, kf.p_yy, kf.p_yb, kf.p_bb, rate), scalar)
    k_turns, c_2dt, c_dt2, q_yy, c_dt, c_f, c_f2, q_bb, _, _ = _constants(kf, scalar)
    fy, fyy0, fyb0, fbb0 = _frac(kf.yaw), _frac(kf.p_yy), _frac(kf.p_yb), _frac(kf.p_bb)
    fyy, fyb, fbb = f.p_yy.frac_bits, f.p_yb.frac_bits, f.p_bb.frac_bits
    d = _sub(tr, rate_raw, _frac(rate), bias, _frac(kf.bias), f.rate)
    inc = _mul(tr, d, f.rate.frac_bits, k_turns, _frac(kf.k_turns), kf.yaw.fmt)
    x, fx = _aligned(yaw, fy, inc, fy, 1)
    new_yaw = _wrap(x, fx, kf.yaw.fmt)
    y = _add(tr, p_yy, fyy0, _mul(tr, p_yb, fyb0, c_2dt, _frac(kf.c_2dt), f.p_yy), fyy, f.p_yy)
    y = _add(tr, y, fyy, _mul(tr, p_bb, fbb0, c_dt2, _frac(kf.c_dt2), f.p_yy), fyy, f.p_yy)
    y = _add(tr, y, fyy, q_yy, _frac(kf.q_yy), f.p_yy)
    yb = _add(tr, p_yb, fyb0, _mul(tr, p_bb, fbb0, c_dt, _frac(kf.c_dt), f.p_yb), fyb, f.p_yb)
    yb = _mul(tr, yb, fyb, c_f, _frac(kf.c_f), f.p_yb)
    bb = _add(tr, _mul(tr, p_bb, fbb0, c_f2, _frac(kf.c_f2), f.p_bb), fbb, q_bb, _frac(kf.q_bb), f.p_bb)
    if not tr.in_range():
        return None
    return _arrays((new_yaw, _floor(tr, y), yb, _floor(tr, bb)), scalar)


def update(kf, ref, r, scalar: bool = False) -> tuple | None:
    """(yaw, bias, p_yy, p_yb, p_bb) raws of ``kf.update_raw(ref, r, all)`` or None (run the exact path);
    the caller applies the mask and the variance floor.  ``scalar`` as for :func:`predict`."""
    f, tr = kf.formats, _Trace(scalar)
    yaw, bias, p_yy, p_yb, p_bb, ref_raw, r_raw = _raws((kf.yaw, kf.bias, kf.p_yy, kf.p_yb, kf.p_bb, ref, r), scalar)
    one, c_360 = _constants(kf, scalar)[-2:]
    fy, fyy, fyb = _frac(kf.yaw), _frac(kf.p_yy), _frac(kf.p_yb)
    fz, fi, fky, fkb = f.yaw.frac_bits, f.inv_s.frac_bits, f.gain_yaw.frac_bits, f.gain_bias.frac_bits
    x, fx = _aligned(yaw, fy, ref_raw, _frac(ref), -1)
    z = _wrap(x, fx, f.yaw)  # the wrapped innovation
    s = _add(tr, p_yy, fyy, r_raw, _frac(r), f.p_yy)
    inv = _div(tr, one, _frac(kf.one), s, f.p_yy.frac_bits, f.inv_s)
    k_y = _mul(tr, p_yy, fyy, inv, fi, f.gain_yaw)
    k_b = _mul(tr, p_yb, fyb, inv, fi, f.gain_bias)
    z_deg = _mul(tr, z, fz, c_360, _frac(kf.c_360), f.innovation_deg)
    x, fx = _aligned(yaw, fy, _mul(tr, k_y, fky, z, fz, f.yaw), fz, -1)
    new_yaw = _wrap(x, fx, f.yaw)
    new_bias = _add(tr, bias, _frac(kf.bias), _mul(tr, k_b, fkb, z_deg, f.innovation_deg.frac_bits, f.bias),
                    f.bias.frac_bits, f.bias)
    yy = _sub(tr, p_yy, fyy, _mul(tr, k_y, fky, p_yy, fyy, f.p_yy), f.p_yy.frac_bits, f.p_yy)
    yb = _sub(tr, p_yb, fyb, _mul(tr, k_y, fky, p_yb, fyb, f.p_yb), f.p_yb.frac_bits, f.p_yb)
    bb = _sub(tr, p_bb, _frac(kf.p_bb), _mul(tr, k_b, fkb, p_yb, fyb, f.p_bb), f.p_bb.frac_bits, f.p_bb)
    if not tr.in_range():
        return None
    return _arrays((new_yaw, new_bias, yy, yb, bb), scalar)
