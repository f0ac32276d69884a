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
    """A case the fast path does not cover; the exact path computes (or rejects) it."""


class _Trace:
    """Intermediates that the exact path would saturate, with their raw limits."""

    __slots__ = ("vals", "lo", "hi")

    def __init__(self):
        self.vals, self.lo, self.hi = [], [], []

    def sat(self, x: np.ndarray, lo: int, hi: int) -> np.ndarray:
        self.vals.append(x)
        self.lo.append(lo)
        self.hi.append(hi)
        return x

    def in_range(self) -> bool:
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
    xa, xb = np.left_shift(a, f - fa), np.left_shift(b, f - fb)
    return (np.add(xa, xb) if sign > 0 else np.subtract(xa, xb)), f


def _add(tr, a, fa, b, fb, out):
    x, f = _aligned(a, fa, b, fb, 1)
    return _sat(tr, x, f, out)


def _sub(tr, a, fa, b, fb, out):
    x, f = _aligned(a, fa, b, fb, -1)
    return _sat(tr, x, f, out)


def _mul(tr, a, fa, b, fb, out):
    return _sat(tr, np.multiply(a, b), fa + fb, out)


def _div(tr, a, fa, b, fb, out):
    """Rounded a / b for positive b (others go to the exact path, which handles zero and signs)."""
    s = out.frac_bits - fa + fb
    if abs(s) > MAX_DIV_SHIFT:
        raise Unsupported
    n, d = (np.left_shift(a, s), np.asarray(b)) if s >= 0 else (np.asarray(a), np.left_shift(b, -s))
    tr.sat(d, 1, INT64_MAX)
    d = np.maximum(d, 1)
    q = n // d
    r2 = 2 * (n - q * d)
    q = q + ((r2 > d) | ((r2 == d) & (q & 1).astype(bool)))
    return tr.sat(np.asarray(q, dtype=np.int64), out.min_raw, out.max_raw)


def predict(kf, rate) -> tuple | None:
    """(yaw, p_yy, p_yb, p_bb) raws after ``kf.predict_raw(rate)`` or None (run the exact path)."""
    f, tr = kf.formats, _Trace()
    yaw, bias, p_yy, p_yb, p_bb = kf.yaw, kf.bias, kf.p_yy, kf.p_yb, kf.p_bb
    d = _sub(tr, rate.raw, rate.fmt.frac_bits, bias.raw, bias.fmt.frac_bits, f.rate)
    inc = _mul(tr, d, f.rate.frac_bits, kf.k_turns.raw, kf.k_turns.fmt.frac_bits, yaw.fmt)
    x, fx = _aligned(yaw.raw, yaw.fmt.frac_bits, inc, yaw.fmt.frac_bits, 1)
    new_yaw = _wrap(x, fx, yaw.fmt)
    fyy, fyb, fbb = f.p_yy.frac_bits, f.p_yb.frac_bits, f.p_bb.frac_bits
    y = _add(tr, p_yy.raw, p_yy.fmt.frac_bits,
             _mul(tr, p_yb.raw, p_yb.fmt.frac_bits, kf.c_2dt.raw, kf.c_2dt.fmt.frac_bits, f.p_yy), fyy, f.p_yy)
    y = _add(tr, y, fyy, _mul(tr, p_bb.raw, p_bb.fmt.frac_bits, kf.c_dt2.raw, kf.c_dt2.fmt.frac_bits, f.p_yy),
             fyy, f.p_yy)
    y = _add(tr, y, fyy, kf.q_yy.raw, kf.q_yy.fmt.frac_bits, f.p_yy)
    yb = _add(tr, p_yb.raw, p_yb.fmt.frac_bits,
              _mul(tr, p_bb.raw, p_bb.fmt.frac_bits, kf.c_dt.raw, kf.c_dt.fmt.frac_bits, f.p_yb), fyb, f.p_yb)
    yb = _mul(tr, yb, fyb, kf.c_f.raw, kf.c_f.fmt.frac_bits, f.p_yb)
    bb = _add(tr, _mul(tr, p_bb.raw, p_bb.fmt.frac_bits, kf.c_f2.raw, kf.c_f2.fmt.frac_bits, f.p_bb), fbb,
              kf.q_bb.raw, kf.q_bb.fmt.frac_bits, f.p_bb)
    if not tr.in_range():
        return None
    return new_yaw, np.maximum(y, 1), yb, np.maximum(bb, 1)


def update(kf, ref, r) -> tuple | None:
    """(yaw, bias, p_yy, p_yb, p_bb) raws of ``kf.update_raw(ref, r, all)`` or None (run the exact path);
    the caller applies the mask and the variance floor."""
    f, tr = kf.formats, _Trace()
    yaw, bias, p_yy, p_yb, p_bb = kf.yaw, kf.bias, kf.p_yy, kf.p_yb, kf.p_bb
    fy = yaw.fmt.frac_bits
    x, fx = _aligned(yaw.raw, fy, ref.raw, ref.fmt.frac_bits, -1)
    z = _wrap(x, fx, f.yaw)
    fz = f.yaw.frac_bits
    s = _add(tr, p_yy.raw, p_yy.fmt.frac_bits, r.raw, r.fmt.frac_bits, f.p_yy)
    inv = _div(tr, kf.one.raw, kf.one.fmt.frac_bits, s, f.p_yy.frac_bits, f.inv_s)
    fi = f.inv_s.frac_bits
    k_y = _mul(tr, p_yy.raw, p_yy.fmt.frac_bits, inv, fi, f.gain_yaw)
    k_b = _mul(tr, p_yb.raw, p_yb.fmt.frac_bits, inv, fi, f.gain_bias)
    fky, fkb = f.gain_yaw.frac_bits, f.gain_bias.frac_bits
    z_deg = _mul(tr, z, fz, kf.c_360.raw, kf.c_360.fmt.frac_bits, f.innovation_deg)
    x, fx = _aligned(yaw.raw, fy, _mul(tr, k_y, fky, z, fz, f.yaw), fz, -1)
    new_yaw = _wrap(x, fx, f.yaw)
    new_bias = _add(tr, bias.raw, bias.fmt.frac_bits,
                    _mul(tr, k_b, fkb, z_deg, f.innovation_deg.frac_bits, f.bias), f.bias.frac_bits, f.bias)
    fyy, fyb = p_yy.fmt.frac_bits, p_yb.fmt.frac_bits
    yy = _sub(tr, p_yy.raw, fyy, _mul(tr, k_y, fky, p_yy.raw, fyy, f.p_yy), f.p_yy.frac_bits, f.p_yy)
    yb = _sub(tr, p_yb.raw, fyb, _mul(tr, k_y, fky, p_yb.raw, fyb, f.p_yb), f.p_yb.frac_bits, f.p_yb)
    bb = _sub(tr, p_bb.raw, p_bb.fmt.frac_bits, _mul(tr, k_b, fkb, p_yb.raw, fyb, f.p_bb), f.p_bb.frac_bits,
              f.p_bb)
    if not tr.in_range():
        return None
    return new_yaw, new_bias, yy, yb, bb
