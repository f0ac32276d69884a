"""Fixed-point arithmetic of the node MCU (a 32-bit Cortex-M class core), as numpy int64 arrays.

A value is a :class:`Fx`: an int64 array ``raw`` (any shape; the leading axis is the batch of realizations)
and a :class:`QFormat` (signed two's complement, ``word_bits`` <= 32, ``frac_bits`` fraction bits), meaning
``value = raw * 2**-frac_bits``.  Intermediates (products, aligned sums, shifted numerators) are int64, as
the firmware's ``int64_t`` intermediates are.  Every primitive mirrors one C expression; ``W``/``F`` denote
the word and fraction bits of the result, ``s`` a shift count, ``MAX``/``MIN`` the result's raw limits:

- rounding on a right shift by ``s`` (``requantize``):
    floor        ``x >> s``                                   (arithmetic shift, as ARM GCC compiles it)
    toward_zero  ``(x + ((x >> 63) & ((1LL << s) - 1))) >> s``  (== ``x / (1LL << s)`` in C99)
    half_up      ``(x + (1LL << (s - 1))) >> s``              (ties toward +inf)
    half_even    ``q = x >> s; r = x & ((1LL << s) - 1); q += (r > h) || (r == h && (q & 1))``, h = 1 << (s-1)
- overflow into W bits:
    saturate     ``x > MAX ? MAX : (x < MIN ? MIN : x)``
    wrap         ``(int32_t)(uint32_t)x`` for W = 32; in general keep the low W bits and sign-extend
- ``add``/``sub``: ``sat((int64_t)a << sa  +/-  (int64_t)b << sb)`` after aligning both to the finer format
- ``mul``:  ``sat(round((int64_t)a * b, s))`` with ``s = Fa + Fb - F``
- ``div``:  ``n = (int64_t)a << s; q = n / b`` plus the rounding correction from ``n % b``
  (``s = F - Fa + Fb``); ``b == 0`` gives MAX or MIN by the sign of ``a`` and counts as an overflow
  (the firmware guards its one division instead of trapping)
- ``shift``: ``a >> n`` / ``a << n`` in the same format
- ``from_float``: ``sat(round(x * 2^F))`` (the explicit float -> fixed boundary, e.g. a float received over
  the radio); NaN or infinity is rejected with :class:`FirmwareError` (an MCU never sees them in integers)
- ``to_float``: ``(double)x / (1 << F)`` (exact while |raw| < 2**53)

An :class:`OverflowCounter` passed to a primitive adds the number of elements that overflowed (saturated
or wrapped) under a site name, so a run can report how often the firmware saturated.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import Enum

import numpy as np

from firmware_model.errors import FirmwareError

MAX_WORD_BITS = 32
MAX_SHIFT = 62  # right shifts of an int64 intermediate; left shifts are bounded per primitive below


class Rounding(str, Enum):
    """How bits shifted out of a value are rounded (see the module docstring for the C)."""

    FLOOR = "floor"
    TOWARD_ZERO = "toward_zero"
    HALF_UP = "half_up"
    HALF_EVEN = "half_even"


class Overflow(str, Enum):
    """What happens to a result outside the format's range."""

    SATURATE = "saturate"
    WRAP = "wrap"


@dataclass(frozen=True)
class QFormat:
    """Signed two's-complement Q format: ``word_bits`` in [2, 32] bits, ``frac_bits`` in [-31, 62].

    ``frac_bits`` may exceed ``word_bits`` (a small quantity such as a covariance in Q-6.38) or be negative.
    """

    word_bits: int
    frac_bits: int

    def __post_init__(self) -> None:
        if not (isinstance(self.word_bits, int) and 2 <= self.word_bits <= MAX_WORD_BITS):
            raise FirmwareError(f"QFormat.word_bits = {self.word_bits!r}: allowed integers 2..{MAX_WORD_BITS}")
        if not (isinstance(self.frac_bits, int) and -31 <= self.frac_bits <= MAX_SHIFT):
            raise FirmwareError(f"QFormat.frac_bits = {self.frac_bits!r}: allowed integers -31..{MAX_SHIFT}")

    @property
    def int_bits(self) -> int:
        """Integer bits including the sign bit (Q<int_bits - 1>.<frac_bits> in ARM's notation)."""
        return self.word_bits - self.frac_bits

    @property
    def max_raw(self) -> int:
        return (1 << (self.word_bits - 1)) - 1

    @property
    def min_raw(self) -> int:
        return -(1 << (self.word_bits - 1))

    @property
    def lsb(self) -> float:
        return 2.0**-self.frac_bits

    @property
    def max_value(self) -> float:
        return self.max_raw * self.lsb

    @property
    def min_value(self) -> float:
        return self.min_raw * self.lsb

    def __str__(self) -> str:
        return f"Q{self.int_bits}.{self.frac_bits} ({self.word_bits}-bit)"


@dataclass
class OverflowCounter:
    """Number of overflowed elements per site (the firmware's saturation counters)."""

    counts: dict[str, int] = field(default_factory=dict)

    def record(self, site: str, n: int) -> None:
        if n:
            self.counts[site] = self.counts.get(site, 0) + int(n)

    @property
    def total(self) -> int:
        return sum(self.counts.values())


@dataclass(frozen=True)
class Fx:
    """A fixed-point array: raw int64 values and their format."""

    raw: np.ndarray
    fmt: QFormat

    def to_float(self) -> np.ndarray:
        return to_float(self)


def _as_raw(raw) -> np.ndarray:
    return np.asarray(raw, dtype=np.int64)


def _overflow(x: np.ndarray, fmt: QFormat, overflow: Overflow, counter, site: str) -> np.ndarray:
    """Bring int64 ``x`` into ``fmt``'s range by saturating or wrapping (``x`` may be modified in place)."""
    lo, hi = fmt.min_raw, fmt.max_raw
    if x.size == 0 or (x.min() >= lo and x.max() <= hi):  # fast path: nothing overflowed
        return x
    if counter is not None:
        counter.record(site, np.count_nonzero(x > hi) + np.count_nonzero(x < lo))
    if overflow is Overflow.SATURATE:
        return np.clip(x, lo, hi, out=x)
    w = fmt.word_bits
    x &= (1 << w) - 1
    x -= (x >> (w - 1)) << w  # sign-extend bit W-1
    return x


_SCRATCH: dict[tuple, np.ndarray] = {}


def _scratch_like(x: np.ndarray) -> np.ndarray:
    """A reusable int64 work array of ``x``'s shape (one kept at a time).  Allocating a fresh large
    temporary per primitive costs page faults that dominate the arithmetic on 1e5-element arrays."""
    buf = _SCRATCH.get(x.shape)
    if buf is None:
        _SCRATCH.clear()
        buf = _SCRATCH[x.shape] = np.empty(x.shape, dtype=np.int64)
    return buf


def _round_shift_right(x: np.ndarray, s: int, rounding: Rounding) -> np.ndarray:
    """Divide int64 ``x`` by 2**s (s >= 1) with the rounding mode, in place (``x`` must be owned)."""
    if s > MAX_SHIFT:
        raise FirmwareError(f"right shift by {s} bits: allowed 0..{MAX_SHIFT}")
    if rounding is Rounding.FLOOR:
        x >>= s
        return x
    if rounding is Rounding.TOWARD_ZERO:
        t = np.right_shift(x, 63, out=_scratch_like(x))
        t &= (1 << s) - 1
    elif rounding is Rounding.HALF_UP:
        t = (1 << (s - 1))
    elif rounding is Rounding.HALF_EVEN:
        # (x + h - 1 + ((x >> s) & 1)) >> s: rounds up iff the remainder exceeds h, or equals h with q odd
        t = np.right_shift(x, s, out=_scratch_like(x))
        t &= 1
        t += (1 << (s - 1)) - 1
    else:
        raise FirmwareError(f"rounding = {rounding!r}: allowed {[m.value for m in Rounding]}")
    x += t
    x >>= s
    return x


def requantize(
    raw,
    frac_in: int,
    out: QFormat,
    rounding: Rounding = Rounding.HALF_EVEN,
    overflow: Overflow = Overflow.SATURATE,
    counter: OverflowCounter | None = None,
    site: str = "requantize",
) -> Fx:
    """Convert int64 ``raw`` with ``frac_in`` fraction bits to format ``out`` (C: ``sat(round(x, s))``).

    ``raw`` is an int64 intermediate below 2**62 in magnitude (a product of two 32-bit words at most), so
    that adding the rounding constant cannot overflow int64."""
    return _requantize(np.array(raw, dtype=np.int64), frac_in, out, Rounding(rounding), Overflow(overflow), counter, site)


def _requantize(x: np.ndarray, frac_in: int, out: QFormat, rounding: Rounding, overflow: Overflow, counter, site: str) -> Fx:
    """:func:`requantize` on an int64 array the caller owns (modified in place)."""
    x = np.asarray(x)
    s = frac_in - out.frac_bits
    if s > 0:
        x = _round_shift_right(x, s, rounding)
    elif s < 0:
        ls = -s
        if ls > MAX_SHIFT:
            raise FirmwareError(f"left shift by {ls} bits: allowed 0..{MAX_SHIFT}")
        lo, hi = out.min_raw, out.max_raw
        x_lo, x_hi = -((-lo) >> ls), hi >> ls  # x << ls stays in range iff x_lo <= x <= x_hi
        over = (x > x_hi) | (x < x_lo)
        if counter is not None:
            counter.record(site, np.count_nonzero(over))
        if overflow is Overflow.SATURATE:
            x = np.where(over, np.where(x > 0, hi, lo), np.clip(x, x_lo, x_hi) << ls)
        elif ls >= out.word_bits:
            x = np.zeros_like(x)
        else:
            x = (x & ((1 << (out.word_bits - ls)) - 1)) << ls  # the low bits that survive, mod 2**W
            x -= (x >> (out.word_bits - 1)) << out.word_bits
        return Fx(x, out)
    return Fx(_overflow(x, out, overflow, counter, site), out)


def convert(a: Fx, out: QFormat, rounding=Rounding.HALF_EVEN, overflow=Overflow.SATURATE, counter=None, site="convert") -> Fx:
    """Format conversion (C: ``sat(round(a, Fa - F))``, a shift and a clamp)."""
    return requantize(a.raw, a.fmt.frac_bits, out, rounding, overflow, counter, site)


def shift(a: Fx, n: int, rounding=Rounding.FLOOR, overflow=Overflow.SATURATE, counter=None, site="shift") -> Fx:
    """Multiply by 2**n in the same format (C: ``a << n`` for n > 0, ``round(a >> -n)`` for n < 0)."""
    return requantize(a.raw, a.fmt.frac_bits - n, a.fmt, rounding, overflow, counter, site)


def _align(a: Fx, b: Fx) -> tuple[np.ndarray, np.ndarray, int]:
    fa, fb = a.fmt.frac_bits, b.fmt.frac_bits
    if abs(fa - fb) > 31:
        raise FirmwareError(f"add/sub of {a.fmt} and {b.fmt}: fraction bits may differ by at most 31")
    f = max(fa, fb)
    return _as_raw(a.raw) << (f - fa), _as_raw(b.raw) << (f - fb), f


def add(a: Fx, b: Fx, out: QFormat, rounding=Rounding.HALF_EVEN, overflow=Overflow.SATURATE, counter=None, site="add") -> Fx:
    """a + b (C: ``sat(round(((int64_t)a << sa) + ((int64_t)b << sb), s))``)."""
    xa, xb, f = _align(a, b)
    return _requantize(np.add(xa, xb), f, out, Rounding(rounding), Overflow(overflow), counter, site)


def sub(a: Fx, b: Fx, out: QFormat, rounding=Rounding.HALF_EVEN, overflow=Overflow.SATURATE, counter=None, site="sub") -> Fx:
    """a - b (C: ``sat(round(((int64_t)a << sa) - ((int64_t)b << sb), s))``)."""
    xa, xb, f = _align(a, b)
    return _requantize(np.subtract(xa, xb), f, out, Rounding(rounding), Overflow(overflow), counter, site)


def mul(a: Fx, b: Fx, out: QFormat, rounding=Rounding.HALF_EVEN, overflow=Overflow.SATURATE, counter=None, site="mul") -> Fx:
    """a * b (C: ``sat(round((int64_t)a * b, Fa + Fb - F))``; the 64-bit product is exact)."""
    p = np.multiply(_as_raw(a.raw), _as_raw(b.raw))
    return _requantize(p, a.fmt.frac_bits + b.fmt.frac_bits, out, Rounding(rounding), Overflow(overflow), counter, site)


def div(a: Fx, b: Fx, out: QFormat, rounding=Rounding.HALF_EVEN, overflow=Overflow.SATURATE, counter=None, site="div") -> Fx:
    """a / b (C: ``n = (int64_t)a << s; q = n / b;`` then the rounding fix-up from ``n % b``).

    ``s = F - Fa + Fb`` must lie in [-30, 30] (the numerator stays inside int64).  A zero divisor gives
    MAX (a >= 0) or MIN (a < 0) and counts as an overflow.
    """
    rounding, overflow = Rounding(rounding), Overflow(overflow)
    s = out.frac_bits - a.fmt.frac_bits + b.fmt.frac_bits
    if abs(s) > 30:
        raise FirmwareError(f"div {a.fmt} / {b.fmt} -> {out}: shift {s} outside the allowed -30..30")
    n, d = np.broadcast_arrays(_as_raw(a.raw), _as_raw(b.raw))
    if s >= 0:
        n = n << s
    else:
        d = d << (-s)
    zero = d == 0
    sign_d = np.where(d < 0, -1, 1)
    n = n * sign_d  # normalise to d > 0
    d = np.where(zero, 1, d * sign_d)
    q = n // d  # floor
    r = n - q * d  # 0 <= r < d
    if rounding is Rounding.TOWARD_ZERO:
        q = q + ((r != 0) & (q < 0))
    elif rounding is Rounding.HALF_UP:
        q = q + (2 * r >= d)
    elif rounding is Rounding.HALF_EVEN:
        q = q + ((2 * r > d) | ((2 * r == d) & (q & 1).astype(bool)))
    if zero.any():
        if counter is not None:
            counter.record(site, np.count_nonzero(zero))
        q = np.where(zero, np.where(n >= 0, out.max_raw, out.min_raw), q)
    return Fx(_overflow(np.array(q, dtype=np.int64), out, overflow, counter, site), out)


def from_float(
    x, fmt: QFormat, rounding=Rounding.HALF_EVEN, overflow=Overflow.SATURATE, counter=None, site="from_float"
) -> Fx:
    """Explicit float -> fixed conversion (C: ``sat(round(x * (1 << F)))``); NaN/inf raise FirmwareError."""
    rounding, overflow = Rounding(rounding), Overflow(overflow)
    x = np.asarray(x, dtype=float)
    if x.size == 1 and rounding is Rounding.HALF_EVEN:
        raw = _from_float_one(float(x.reshape(-1)[0]), fmt, overflow, counter, site)
        if raw is not None:
            return Fx(np.int64(raw) if x.ndim == 0 else np.full(x.shape, raw, dtype=np.int64), fmt)
    bad = ~np.isfinite(x)
    if bad.any():
        idx = tuple(int(i) for i in np.argwhere(bad)[0])
        raise FirmwareError(f"{site}: non-finite input {x[idx]} at index {idx}; the firmware accepts finite numbers only")
    y = np.ldexp(x, fmt.frac_bits)  # exact scaling by 2**F
    if rounding is Rounding.FLOOR:
        y = np.floor(y)
    elif rounding is Rounding.TOWARD_ZERO:
        y = np.trunc(y)
    elif rounding is Rounding.HALF_UP:
        f = np.floor(y)
        y = f + (y - f >= 0.5)
    else:
        y = np.rint(y)  # IEEE round-half-even
    lo, hi = fmt.min_raw, fmt.max_raw
    over = (y > hi) | (y < lo)
    if over.any():
        if counter is not None:
            counter.record(site, np.count_nonzero(over))
        if overflow is Overflow.SATURATE:
            y = np.clip(y, lo, hi)
        else:
            y = np.fmod(y, 2.0**fmt.word_bits)  # exact; then two's-complement wrap below
    raw = y.astype(np.int64)
    if overflow is Overflow.WRAP:
        raw = _overflow(raw, fmt, Overflow.WRAP, None, site)
    return Fx(raw, fmt)


def _from_float_one(v: float, fmt: QFormat, overflow: Overflow, counter, site: str) -> int | None:
    """:func:`from_float` of one number with round half even, on Python numbers (no numpy call; the same IEEE
    operations: exact scaling by 2**F, ``round`` is round-half-even like ``np.rint``, the limits of a <= 32-bit
    word are exact doubles).  None for what the array path handles (non-finite input, scaling overflow)."""
    if not math.isfinite(v):
        return None
    try:
        y = round(math.ldexp(v, fmt.frac_bits))
    except OverflowError:
        return None
    lo, hi = fmt.min_raw, fmt.max_raw
    if lo <= y <= hi:
        return y
    if counter is not None:
        counter.record(site, 1)
    if overflow is Overflow.SATURATE:
        return hi if y > hi else lo
    w = fmt.word_bits
    y &= (1 << w) - 1
    return y - ((y >> (w - 1)) << w)


def to_float(a: Fx) -> np.ndarray:
    """Fixed -> float (C: ``(double)a / (1 << F)``), exact for |raw| < 2**53."""
    return np.ldexp(_as_raw(a.raw).astype(float), -a.fmt.frac_bits)


@dataclass
class FixedContext:
    """The rounding and overflow policy of one firmware build plus its overflow counter."""

    rounding: Rounding = Rounding.HALF_EVEN
    overflow: Overflow = Overflow.SATURATE
    counter: OverflowCounter = field(default_factory=OverflowCounter)

    def mul(self, a: Fx, b: Fx, out: QFormat, site: str) -> Fx:
        return mul(a, b, out, self.rounding, self.overflow, self.counter, site)

    def add(self, a: Fx, b: Fx, out: QFormat, site: str) -> Fx:
        return add(a, b, out, self.rounding, self.overflow, self.counter, site)

    def sub(self, a: Fx, b: Fx, out: QFormat, site: str) -> Fx:
        return sub(a, b, out, self.rounding, self.overflow, self.counter, site)

    def div(self, a: Fx, b: Fx, out: QFormat, site: str) -> Fx:
        return div(a, b, out, self.rounding, self.overflow, self.counter, site)

    def convert(self, a: Fx, out: QFormat, site: str) -> Fx:
        return convert(a, out, self.rounding, self.overflow, self.counter, site)

    def from_float(self, x, fmt: QFormat, site: str) -> Fx:
        return from_float(x, fmt, self.rounding, self.overflow, self.counter, site)
