"""The fused fast path of the fixed filter (firmware_model.fixed_fast) gives the same bits and the same
overflow counts as the primitive-by-primitive exact path, for random states (including ones that saturate,
so the fallback runs), random inputs and masks, several word lengths and a non-default policy."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from firmware_model import fixed_fast
from firmware_model.fixed_filter import FixedFormats, FixedYawFilter
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
