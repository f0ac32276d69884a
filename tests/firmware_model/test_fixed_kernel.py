"""The numba kernels of firmware_model.fixed_kernel give FixedYawFilter's bits, floats and per-site
overflow counts lane by lane: random predict/update sequences (hypothesis) on the default formats and on
narrow words (where intermediates saturate), from the constructor's state and from arbitrary ("wild") states;
the class is compared with its fused fast path on (as the chain runs it) and off (the exact path alone)."""

import math
import re
import types
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from firmware_model.fixed_filter import TURN_RAD, FixedFormats, FixedYawFilter
from firmware_model.fixedpoint import Fx, Overflow, QFormat, Rounding
from firmware_model.filter_factory import make_yaw_filter
from firmware_model.yaw_filter import YawFilterConfig
from firmware_model import fixed_kernel as fk
from firmware_model.errors import FirmwareError

DEG = math.pi / 180.0
CFG = YawFilterConfig(dt_s=1.0 / 1.9, arw_rad_per_sqrt_s=7.38e-3 * DEG, bias_instability_rad_s=3.33e-3 * DEG,
                      bias_tau_s=500.0)
WORDS = [32, 24, 20, 16, 12]  # below 12 bits the class's own 1 / S division shift leaves -30..30


class ExactFilter(FixedYawFilter):
    """The class with its fused fast path off (the primitive-by-primitive path only)."""

    @property
    def _fusable(self) -> bool:
        return False


class Lanes:
    """The kernel's copy of a filter: one state row and one counter row per realization."""

    def __init__(self, kf, kernel=fk):
        self.k, self.params, self.states = kernel, kernel.kernel_params(kf), kernel.lane_states(kf)
        self.counts = np.zeros((kf.realizations, len(kernel.SITES)), dtype=np.int64)

    def predict(self, rate):
        for i, s in enumerate(self.states):
            self.k.predict(s, float(rate[i]), self.params, self.counts[i])

    def update(self, ref, var):
        for i, s in enumerate(self.states):
            self.k.update(s, float(ref[i]), float(var[i]), self.params, self.counts[i])


def build(word, R, wild_seed=None, cls=None):
    formats = FixedFormats().with_word_length(word)
    kf = cls(CFG, R, formats=formats) if cls else make_yaw_filter("fixed", CFG, R, formats=formats)
    if wild_seed is not None:  # arbitrary words in every state variable: large values saturate intermediates
        rng = np.random.default_rng(wild_seed)
        for name in fk.STATE_FIELDS:
            fmt = getattr(kf, name).fmt
            raw = rng.integers(fmt.min_raw, fmt.max_raw, size=R, endpoint=True)
            if name in ("p_yy", "p_bb"):
                raw = np.abs(raw) // rng.choice([1, 1 << 8, 1 << 20], size=R) + 1
            setattr(kf, name, Fx(raw, fmt))
    return kf, dict(kf.overflow_counts)


def class_counts_since(kf, before):
    return {k: v - before.get(k, 0) for k, v in kf.overflow_counts.items() if v != before.get(k, 0)}


def assert_same(kf, before, lanes, where):
    np.testing.assert_array_equal(lanes.states, fk.lane_states(kf), err_msg=where)
    for name in ("yaw_rad", "bias_rad_s", "yaw_variance_rad2"):
        ours = np.array([getattr(lanes.k, name)(s, lanes.params) for s in lanes.states])
        np.testing.assert_array_equal(ours, getattr(kf, name), err_msg=f"{where}: {name}")  # the same doubles
    assert fk.counts_dict(lanes.counts.sum(0)) == class_counts_since(kf, before), where


def ops(R):
    """Random predict/update steps: rates up to 100 deg/s (sometimes saturating the rate word), references
    anywhere in [-4 pi, 4 pi] (sometimes huge: the binary angle wraps), variances 1e-12..10 rad^2 (P_yy's
    format holds 0.039 rad^2 at 32 bits), sometimes 0 or huge."""
    lane = lambda s: st.lists(s, min_size=R, max_size=R)  # noqa: E731
    rate = st.one_of(st.floats(-100 * DEG, 100 * DEG), st.sampled_from([1e6, -3e4, 1e300]))
    ref = st.one_of(st.floats(-4 * math.pi, 4 * math.pi), st.sampled_from([1e9, -7.5e20, 1e299]))
    var = st.one_of(st.floats(1e-12, 10.0), st.sampled_from([0.0, 1e-300, 1e30, 1e300]))
    return st.lists(st.one_of(st.tuples(st.just("predict"), lane(rate)),
                              st.tuples(st.just("update"), lane(ref), lane(var))), min_size=1, max_size=40)


def run(kf, before, lanes, steps):
    mask = np.ones(kf.realizations, dtype=bool)
    for n, step in enumerate(steps):
        if step[0] == "predict":
            kf.predict(np.array(step[1]))
            lanes.predict(step[1])
        else:
            kf.update(np.array(step[1]), np.array(step[2]), mask=mask)
            lanes.update(step[1], step[2])
        assert_same(kf, before, lanes, f"step {n}: {step}")


@pytest.mark.filterwarnings("ignore:overflow encountered in ldexp:RuntimeWarning")  # the class on 1e300 rad/s
@settings(max_examples=300, deadline=None)
@given(data=st.data(), word=st.sampled_from(WORDS), R=st.sampled_from([1, 3]), wild=st.booleans(),
       exact=st.booleans())
def test_kernel_matches_the_class_bit_for_bit(data, word, R, wild, exact):
    kf, before = build(word, R, wild_seed=data.draw(st.integers(0, 2**32 - 1)) if wild else None,
                       cls=ExactFilter if exact else None)
    run(kf, before, Lanes(kf), data.draw(ops(R)))


def sweep(kernel=fk, seeds=range(3)):
    """A fixed random sweep over word lengths from wild states; returns the class's and the kernel's counts."""
    hit, ours = {}, {}
    for seed in seeds:
        rng = np.random.default_rng(seed)
        for word in WORDS:
            kf, before = build(word, 4, wild_seed=seed * 100 + word)
            lanes = Lanes(kf, kernel)
            for step in range(40):
                if step % 2 == 0:
                    rate = rng.uniform(-100, 100, 4) * DEG * rng.choice([1.0, 1e3], 4)
                    kf.predict(rate)
                    lanes.predict(rate)
                else:
                    ref, var = rng.uniform(-4 * math.pi, 4 * math.pi, 4), 10 ** rng.uniform(-12, 1, 4)
                    kf.update(ref, var)
                    lanes.update(ref, var)
                assert_same(kf, before, lanes, f"seed {seed}, {word} bits, step {step}")
            for k, v in class_counts_since(kf, before).items():
                hit[k] = hit.get(k, 0) + v
            for k, v in kernel.counts_dict(lanes.counts.sum(0)).items():
                ours[k] = ours.get(k, 0) + v
    return hit, ours


def test_saturations_happen_and_are_counted_per_site():
    """The sweep saturates at least a dozen different sites (so the counting is exercised), equally counted."""
    hit, ours = sweep()
    assert ours == hit
    assert len(hit) >= 12, sorted(hit)
    assert {"gyro rate", "rate - bias", "yaw increment", "reference variance", "1 / S", "K_y z"} <= set(hit)


def test_sites_are_the_class_sites():
    """Every site the class records in a saturating sweep is one of SITES, and SITES names each only once."""
    hit, _ = sweep(seeds=[0])
    assert set(hit) <= set(fk.SITES)
    assert len(set(fk.SITES)) == len(fk.SITES) == 25


def test_default_formats_after_a_long_quiet_run():
    """At 32 bits and a steady turn (the chain's normal case) 2000 steps stay bit-identical."""
    kf, before = build(32, 1)
    lanes = Lanes(kf)
    for n in range(1000):
        kf.predict(np.array([3.6 * DEG]))
        lanes.predict([3.6 * DEG])
        kf.update(np.array([n * 3.6 * DEG / 1.9]), np.array([(0.1 * DEG) ** 2]))
        lanes.update([n * 3.6 * DEG / 1.9], [(0.1 * DEG) ** 2])
    assert_same(kf, before, lanes, "after 1000 predict+update")


# ---- mutation check: a test-local copy with one wrong primitive must be caught by the same comparison -------------
HALF_EVEN_SHIFT = "return (x + (((x >> s) & 1) + (np.int64(1) << (s - 1)) - 1)) >> s"  # shift_right_round
MUTATIONS = {
    "control (no mutation)": ("", ""),
    "floor instead of half even on a right shift": (HALF_EVEN_SHIFT, "return x >> s"),
    "floor instead of rint in from_float": ("y = np.rint(math.ldexp(v, f))", "y = np.floor(math.ldexp(v, f))"),
    "saturation not counted": ("counts[site] += 1", "counts[site] += 0"),
    "half up instead of half even on a right shift": (HALF_EVEN_SHIFT, "return (x + (np.int64(1) << (s - 1))) >> s"),
}


def python_copy(old: str, new: str) -> types.ModuleType:
    """The kernel module's source as plain Python (no numba) with ``old`` replaced by ``new`` (math.ldexp takes
    a Python int exponent, the params hold numpy ints)."""
    src = Path(fk.__file__).read_text()
    assert src.count(old) >= 1
    src = re.sub(r"^@njit.*$", "", src.replace(old, new), flags=re.M).replace("math.ldexp(", "_ldexp(")
    mod = types.ModuleType("fixed_kernel_copy")
    mod._ldexp = lambda v, f: math.ldexp(v, int(f))
    exec(compile(src, "fixed_kernel_copy", "exec"), mod.__dict__)
    return mod


def mutant_sweep(mod):
    sweep(kernel=mod, seeds=[0, 1])


@pytest.mark.parametrize("mutation", list(MUTATIONS))
def test_a_wrong_primitive_in_a_copy_is_caught(mutation):
    old, new = MUTATIONS[mutation]
    mod = python_copy(old, new)
    if not old:
        mutant_sweep(mod)  # the unmutated copy passes: the failures below come from the mutation
        return
    with pytest.raises(AssertionError):
        mutant_sweep(mod)


def test_from_float_ties_round_to_even():
    """References exactly halfway between two binary-angle LSBs (odd and even neighbours) round to even."""
    refs = [r for r in ((k + 0.5) * 2.0**-32 * TURN_RAD for k in range(1, 400)) if (r / TURN_RAD) * 2.0**32 % 1 == 0.5]
    parity = {math.floor((r / TURN_RAD) * 2.0**32) % 2 for r in refs}
    assert len(refs) >= 20 and parity == {0, 1}
    for r in refs:
        kf, before = build(32, 1)
        lanes = Lanes(kf)
        kf.update(np.array([r]), np.array([1e-6]))
        lanes.update([r], [1e-6])
        assert_same(kf, before, lanes, f"ref {r!r}")


@pytest.mark.parametrize("p_yy, saturates", [(0, True), (-5, True), (-(1 << 31), False)])
def test_zero_and_negative_divisors(p_yy, saturates):
    """S = P_yy + R <= 0 (a state the class accepts though the filter never makes it): the guarded division
    (MAX for 0, counted), 1 / -5 LSB (saturates to MIN) and 1 / -128 deg^2 (in range) give the class's bits
    and counts."""
    kf, before = build(32, 1)
    kf.p_yy = Fx(np.array([p_yy]), kf.p_yy.fmt)
    lanes = Lanes(kf)
    kf.update(np.array([0.3]), np.array([0.0]))
    lanes.update([0.3], [0.0])
    assert_same(kf, before, lanes, f"P_yy = {p_yy}")
    assert class_counts_since(kf, before).get("1 / S", 0) == saturates


# ---- errors ------------------------------------------------------------------------------------------------------
def test_other_policies_are_rejected():
    for kw in ({"rounding": Rounding.FLOOR}, {"overflow": Overflow.WRAP}):
        kf = FixedYawFilter(CFG, 1, formats=FixedFormats(**kw))
        with pytest.raises(FirmwareError, match="allowed only rounding=half_even, overflow=saturate"):
            fk.kernel_params(kf)


def test_bad_inputs_raise_like_the_class():
    kf, _ = build(32, 1)
    lanes = Lanes(kf)
    state, params, counts = lanes.states[0], lanes.params, lanes.counts[0]
    for ref, var in ((math.nan, 0.1), (0.1, math.inf), (0.1, -1e-9), (0.1, 1e306)):
        with pytest.raises(FirmwareError, match="reference"):
            fk.update(state, ref, var, params, counts)
    for rate in (math.inf, 1e307):
        with pytest.raises(FirmwareError, match="gyro rate"):
            fk.predict(state, rate, params, counts)
    np.testing.assert_array_equal(lanes.states, fk.lane_states(kf))  # nothing changed


def test_formats_whose_division_the_class_rejects_raise():
    """At 10 bits the class's 1 / S shift is -34 (FirmwareError); the kernel raises it there too."""
    kf, _ = build(10, 1)
    with pytest.raises(Exception, match="-30..30"):
        kf.update(np.array([0.1]), np.array([0.01]))
    lanes = Lanes(kf)
    with pytest.raises(FirmwareError, match="-30..30"):
        lanes.update([0.1], [0.01])


def test_custom_formats_in_range():
    """A FixedFormats with other fraction bits (not a word-length scaling) also matches."""
    formats = FixedFormats(rate=QFormat(24, 10), bias=QFormat(28, 20), p_yy=QFormat(20, 12), inv_s=QFormat(32, 20))
    kf = FixedYawFilter(CFG, 2, formats=formats)
    before, lanes = dict(kf.overflow_counts), Lanes(kf)
    rng = np.random.default_rng(5)
    for _ in range(50):
        rate = rng.uniform(-100, 100, 2) * DEG
        kf.predict(rate)
        lanes.predict(rate)
        ref, var = rng.uniform(-4 * math.pi, 4 * math.pi, 2), 10 ** rng.uniform(-12, 1, 2)
        kf.update(ref, var)
        lanes.update(ref, var)
        assert_same(kf, before, lanes, "custom formats")
