"""Every fixed-point primitive, in every rounding and overflow mode, is bit-identical to apytypes.

apytypes (an independent arbitrary-precision fixed-point library) is the oracle: its exact sums and products
are cast to the result format with the matching quantisation and overflow mode.  Operands are drawn to
include the format extremes, exact ties (a half LSB shifted out) and results far outside the range.
"""

import apytypes as apy
import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from firmware_model import fixedpoint as fp
from firmware_model.errors import FirmwareError
from firmware_model.fixedpoint import Fx, Overflow, QFormat, Rounding

QUANT = {
    Rounding.FLOOR: apy.QuantizationMode.TRN,
    Rounding.TOWARD_ZERO: apy.QuantizationMode.TRN_ZERO,
    Rounding.HALF_UP: apy.QuantizationMode.RND,  # ties toward +inf
    Rounding.HALF_EVEN: apy.QuantizationMode.RND_CONV,
}
OVER = {Overflow.SATURATE: apy.OverflowMode.SAT, Overflow.WRAP: apy.OverflowMode.WRAP}
N = 24  # elements per drawn array

formats = st.builds(QFormat, word_bits=st.integers(2, 32), frac_bits=st.integers(-8, 40))
roundings = st.sampled_from(list(Rounding))
overflows = st.sampled_from(list(Overflow))


@st.composite
def operands(draw, fmt: QFormat):
    """Raw values of ``fmt``: extremes, zero, +/-1, ties (odd multiples of a power of two) and random."""
    lo, hi = fmt.min_raw, fmt.max_raw
    special = st.sampled_from([lo, hi, 0, 1, -1, lo + 1, hi - 1, hi // 2, lo // 2])
    power = st.integers(0, fmt.word_bits - 2).map(lambda k: 1 << k)
    ties = st.tuples(power, st.integers(-3, 3)).map(lambda t: max(lo, min(hi, t[0] * (2 * t[1] + 1))))
    values = draw(st.lists(st.one_of(special, ties, st.integers(lo, hi)), min_size=N, max_size=N))
    return np.array(values, dtype=np.int64)


def oracle_can_shift(exact_bits: int, left_shift: int) -> bool:
    """apytypes 0.5.1 mis-saturates a cast whose left-shifted value needs more than 63 bits
    (2**23 in 25 bits cast to 2 bits with 40 fraction bits saturates to the minimum, with 41 to zero),
    so the oracle is consulted only where the shifted exact value fits 63 bits."""
    return exact_bits + max(0, left_shift) <= 63


def oracle(raw, fmt):
    return apy.APyFixedArray(np.asarray(raw, dtype=np.int64), bits=fmt.word_bits, frac_bits=fmt.frac_bits)


def signed_ints(x: apy.APyFixedArray) -> list[int]:
    """The two's-complement integers behind an apytypes array (any width), as Python ints."""
    w = x.bits
    return [v - (1 << w) if v >= 1 << (w - 1) else v for v in (int(u) for u in np.ravel(x.to_bits()))]


def signed_bits(x: apy.APyFixedArray, fmt: QFormat) -> np.ndarray:
    assert x.bits == fmt.word_bits
    return np.array(signed_ints(x), dtype=np.int64)


def cast(x, out, rounding, overflow):
    return signed_bits(x.cast(bits=out.word_bits, frac_bits=out.frac_bits, quantization=QUANT[rounding], overflow=OVER[overflow]), out)


def n_overflowed(exact: apy.APyFixedArray, out: QFormat, rounding: Rounding) -> int:
    """Elements whose rounded exact value lies outside ``out`` (what the overflow counter must count)."""
    wide = exact.cast(bits=out.word_bits + 100, frac_bits=out.frac_bits, quantization=QUANT[rounding])
    return sum(1 for v in signed_ints(wide) if not out.min_raw <= v <= out.max_raw)


@settings(max_examples=150, deadline=None)
@given(st.data(), formats, formats, roundings, overflows)
def test_convert_matches_apytypes(data, fin, out, rounding, overflow):
    assume(abs(fin.frac_bits - out.frac_bits) <= 40)
    assume(oracle_can_shift(fin.word_bits, out.frac_bits - fin.frac_bits))
    raw = data.draw(operands(fin))
    counter = fp.OverflowCounter()
    ours = fp.convert(Fx(raw, fin), out, rounding, overflow, counter, "c")
    assert np.array_equal(ours.raw, cast(oracle(raw, fin), out, rounding, overflow))
    assert counter.total == n_overflowed(oracle(raw, fin), out, rounding)


@settings(max_examples=150, deadline=None)
@given(st.data(), formats, formats, formats, roundings, overflows, st.sampled_from(["add", "sub", "mul"]))
def test_add_sub_mul_match_apytypes(data, fa, fb, out, rounding, overflow, op):
    assume(abs(fa.frac_bits - fb.frac_bits) <= 31)
    f_exact = max(fa.frac_bits, fb.frac_bits) if op != "mul" else fa.frac_bits + fb.frac_bits
    assume(-40 <= f_exact - out.frac_bits <= 62)
    if op == "mul":
        exact_bits = fa.word_bits + fb.word_bits
    else:
        exact_bits = max(fa.word_bits + f_exact - fa.frac_bits, fb.word_bits + f_exact - fb.frac_bits) + 1
    assume(oracle_can_shift(exact_bits, out.frac_bits - f_exact))
    a, b = data.draw(operands(fa)), data.draw(operands(fb))
    counter = fp.OverflowCounter()
    ours = getattr(fp, op)(Fx(a, fa), Fx(b, fb), out, rounding, overflow, counter, op)
    xa, xb = oracle(a, fa), oracle(b, fb)
    exact = {"add": lambda: xa + xb, "sub": lambda: xa - xb, "mul": lambda: xa * xb}[op]()
    assert np.array_equal(ours.raw, cast(exact, out, rounding, overflow))
    assert counter.total == n_overflowed(exact, out, rounding)


@settings(max_examples=150, deadline=None)
@given(st.data(), formats, formats, formats, roundings, overflows)
def test_div_matches_apytypes(data, fa, fb, out, rounding, overflow):
    s = out.frac_bits - fa.frac_bits + fb.frac_bits
    assume(-30 <= s <= 30)
    a, b = data.draw(operands(fa)), data.draw(operands(fb))
    # half of the divisors are +/- powers of two, so that exact ties (q + 1/2 LSB) are frequent
    pow2 = data.draw(st.lists(st.integers(0, fb.word_bits - 2), min_size=N, max_size=N))
    sign = data.draw(st.lists(st.sampled_from([-1, 1]), min_size=N, max_size=N))
    b = np.where(np.arange(N) % 2 == 0, np.array(sign) << np.array(pow2), b)
    b = np.where(b == 0, 1, b)
    ours = fp.div(Fx(a, fa), Fx(b, fb), out, rounding, overflow)
    # apytypes truncates a quotient to its own fraction bits; 64 extra bits make a truncated tie a true tie
    # (the remainder of n / b is a multiple of 1/|b| >= 2**-32 of an LSB, see the docstring of fp.div)
    xa = oracle(a, fa).cast(bits=fa.word_bits + 64 + 40, frac_bits=fa.frac_bits + 64 + 40)
    assert np.array_equal(ours.raw, cast(xa / oracle(b, fb), out, rounding, overflow))


@settings(max_examples=100, deadline=None)
@given(st.data(), formats, st.integers(-20, 20), roundings, overflows)
def test_shift_matches_apytypes(data, fmt, n, rounding, overflow):
    assume(-31 <= fmt.frac_bits - n <= 62)
    assume(oracle_can_shift(fmt.word_bits, n))
    raw = data.draw(operands(fmt))
    ours = fp.shift(Fx(raw, fmt), n, rounding, overflow)
    moved = apy.APyFixedArray(raw, bits=fmt.word_bits, frac_bits=fmt.frac_bits - n)  # same bits, value * 2**n
    assert np.array_equal(ours.raw, cast(moved, fmt, rounding, overflow))


@settings(max_examples=150, deadline=None)
@given(st.data(), formats, roundings, overflows)
def test_from_float_matches_apytypes(data, fmt, rounding, overflow):
    # dyadic floats with at most 40 significant bits: exactly representable in apytypes at F + 24 bits
    k = data.draw(st.lists(st.integers(-(2**39), 2**39), min_size=N, max_size=N))
    e = data.draw(st.integers(-fmt.frac_bits - 24 + 0, 8))
    x = np.ldexp(np.array(k, dtype=float), e)
    ours = fp.from_float(x, fmt, rounding, overflow)
    exact = apy.APyFixedArray.from_float(x, bits=fmt.frac_bits + 24 + 60 + 8, frac_bits=fmt.frac_bits + 24)
    assert np.array_equal(ours.raw, cast(exact, fmt, rounding, overflow))
    if overflow is Overflow.SATURATE:
        assert np.all(np.abs(fp.to_float(ours) - np.clip(x, fmt.min_value, fmt.max_value)) <= fmt.lsb)


def test_from_float_rejects_nan_and_inf_naming_the_index():
    with pytest.raises(FirmwareError, match=r"gyro.*index \(2,\)"):
        fp.from_float([0.0, 1.0, np.nan], QFormat(32, 16), site="gyro")
    with pytest.raises(FirmwareError, match="non-finite"):
        fp.from_float([np.inf], QFormat(32, 16))


def test_half_up_from_float_is_not_fooled_by_the_0_49999999999999994_case():
    fmt = QFormat(16, 0)
    assert fp.from_float([0.49999999999999994, 0.5, -0.5, 2.5], fmt, Rounding.HALF_UP).raw.tolist() == [0, 1, 0, 3]


def test_division_by_zero_saturates_and_is_counted():
    counter = fp.OverflowCounter()
    fmt = QFormat(16, 8)
    q = fp.div(Fx(np.array([256, -256, 0]), fmt), Fx(np.array([0, 0, 0]), fmt), fmt, counter=counter, site="kalman_gain")
    assert q.raw.tolist() == [fmt.max_raw, fmt.min_raw, fmt.max_raw]
    assert counter.counts == {"kalman_gain": 3}


def test_counter_counts_saturated_elements_per_site():
    counter = fp.OverflowCounter()
    fmt = QFormat(8, 0)
    fp.mul(Fx(np.array([100, 2, -100]), fmt), Fx(np.array([2, 2, 2]), fmt), fmt, counter=counter, site="p")
    fp.add(Fx(np.array([127]), fmt), Fx(np.array([1]), fmt), fmt, counter=counter, site="q")
    assert counter.counts == {"p": 2, "q": 1} and counter.total == 3


@pytest.mark.parametrize("bad", [dict(word_bits=1, frac_bits=0), dict(word_bits=33, frac_bits=0), dict(word_bits=16, frac_bits=63)])
def test_qformat_rejects_out_of_range_formats(bad):
    with pytest.raises(FirmwareError, match="allowed"):
        QFormat(**bad)


def test_shift_limits_are_enforced():
    with pytest.raises(FirmwareError, match="allowed -30..30"):
        fp.div(Fx(np.array([1]), QFormat(32, 0)), Fx(np.array([1]), QFormat(32, 40)), QFormat(32, 0))
    with pytest.raises(FirmwareError, match="at most 31"):
        fp.add(Fx(np.array([1]), QFormat(32, 0)), Fx(np.array([1]), QFormat(32, 40)), QFormat(32, 0))
