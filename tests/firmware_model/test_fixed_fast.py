"""The fused fast path of the fixed filter (firmware_model.fixed_fast) gives the same bits and the same
overflow counts as the primitive-by-primitive exact path, for random states (including ones that saturate,
so the fallback runs), random inputs and masks, several word lengths and a non-default policy."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from firmware_model import fixed_fast
from firmware_model.fixed_filter import FUSE_MAX_REALIZATIONS, FixedFormats, FixedYawFilter
from firmware_model.fixedpoint import Fx, Overflow, Rounding
from firmware_model.yaw_filter import YawFilterConfig

DEG = math.pi / 180.0
CFG = YawFilterConfig(dt_s=1.0 / 1.9, arw_rad_per_sqrt_s=7.38e-3 * DEG, bias_instability_rad_s=3.33e-3 * DEG,
                      bias_tau_s=500.0)
STATE = ("yaw", "bias", "p_yy", "p_yb", "p_bb")


class ExactFilter(FixedYawFilter):
    """The same filter with the fused fast path switched off (the engine before the fast path)."""

    @property
    def _fusable(self) -> bool:
        return False


def pair(formats, R, rng, wild):
    fast, exact = FixedYawFilter(CFG, R, formats=formats), ExactFilter(CFG, R, formats=formats)
    if wild:  # arbitrary words in every state variable: large values saturate intermediates
        for name in STATE:
            fmt = getattr(fast, name).fmt
            raw = rng.integers(fmt.min_raw, fmt.max_raw, size=R, endpoint=True)
            if name in ("p_yy", "p_bb"):
                raw = np.abs(raw) // rng.choice([1, 1 << 8, 1 << 20], size=R) + 1
            for f in (fast, exact):
                setattr(f, name, Fx(raw.copy(), fmt))
    return fast, exact


def assert_same(fast, exact):
    for name in STATE:
        a, b = getattr(fast, name), getattr(exact, name)
        assert a.fmt == b.fmt, name
        np.testing.assert_array_equal(a.raw, b.raw, err_msg=name)
    assert fast.overflow_counts == exact.overflow_counts


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), word=st.sampled_from([32, 24, 16, 12]), R=st.integers(1, 6),
       wild=st.booleans())
def test_fast_path_matches_the_exact_path_bit_for_bit(seed, word, R, wild):
    rng = np.random.default_rng(seed)
    fast, exact = pair(FixedFormats().with_word_length(word), R, rng, wild)
    for _ in range(12):
        rate = rng.normal(0.0, rng.choice([1e-3, 0.5, 50.0]), R)
        for f in (fast, exact):
            f.predict(rate)
        assert_same(fast, exact)
        ref = rng.uniform(-4.0, 4.0, R)
        var = rng.choice([0.0, 1e-6, 1e-3, 10.0, 1e4]) * rng.uniform(0.0, 1.0, R)
        mask = rng.random(R) < 0.7
        for f in (fast, exact):
            f.update(ref, var, mask=mask)
        assert_same(fast, exact)


def test_saturating_states_take_the_exact_path_and_count_overflows():
    rng = np.random.default_rng(3)
    fast, exact = pair(FixedFormats(), 4, rng, wild=True)
    big = Fx(np.full(4, fast.p_yy.fmt.max_raw), fast.p_yy.fmt)
    fast.p_yy = exact.p_yy = big
    assert fixed_fast.predict(fast, fast.ctx.from_float(np.zeros(4), fast.formats.rate, "gyro rate")) is None
    fast.predict(np.zeros(4))
    exact.predict(np.zeros(4))
    assert_same(fast, exact)
    assert fast.overflow_counts  # the saturations were counted, as by the exact path


@pytest.mark.parametrize("rounding", [Rounding.FLOOR, Rounding.HALF_UP])
def test_other_policies_use_the_exact_path(rounding):
    f = FixedYawFilter(CFG, 2, formats=FixedFormats(rounding=rounding))
    assert not f._fusable
    f.predict(np.ones(2) * 0.01)
    f.update(np.zeros(2), np.ones(2) * 1e-4)
    assert FixedYawFilter(CFG, 2, formats=FixedFormats(overflow=Overflow.SATURATE))._fusable
    big = FixedYawFilter(CFG, FUSE_MAX_REALIZATIONS + 1)  # large batches: the primitives' scratch arrays win
    assert not big._fusable
    big.predict(np.full(FUSE_MAX_REALIZATIONS + 1, 0.01))


@settings(max_examples=300, deadline=None)
@given(v=st.one_of(st.floats(allow_nan=False, allow_infinity=False),
                   st.integers(-(1 << 40), 1 << 40).map(lambda n: n / 2.0),  # ties at every scale
                   st.floats(-1e-3, 1e-3)),
       word=st.integers(2, 32), frac=st.integers(-31, 62), overflow=st.sampled_from(list(Overflow)))
def test_scalar_from_float_matches_the_array_path(v, word, frac, overflow):
    """One number goes through Python floats (fixedpoint._from_float_one), two through numpy: same raw, same
    overflow count, same type for a 0-d input."""
    from firmware_model.fixedpoint import OverflowCounter, QFormat, from_float

    fmt = QFormat(word, frac)
    c1, c2 = OverflowCounter(), OverflowCounter()
    with np.errstate(over="ignore", invalid="ignore"):  # 2**F scaling to inf: both take the array path
        one = from_float(np.array([v]), fmt, overflow=overflow, counter=c1)
        two = from_float(np.array([v, 0.0]), fmt, overflow=overflow, counter=c2)
        zero_d = from_float(v, fmt, overflow=overflow)
        pair_raw = from_float(np.array([v, v]), fmt, overflow=overflow).raw
    assert one.raw.dtype == np.int64 and one.raw.shape == (1,)
    assert int(one.raw[0]) == int(two.raw[0])
    assert c1.counts == c2.counts
    assert type(zero_d.raw) is type(pair_raw[0])
    assert int(zero_d.raw) == int(one.raw[0])
