"""The 6-state fixed filter's numba kernels (firmware_model.six_state_kernel) equal the C reference
(firmware_model/c/six_state_filter.c) bit for bit, with equal per-site overflow counts, on hypothesis cases: random
gyro rates, references, update kinds (none, yaw only, roll/pitch/yaw), initial attitudes and covariances (random
positive definite P0 and arbitrary raw words), tunings and singularity modes, and the levelling op (level_raw:
the static test, the CORDIC tilt, R, the roll/pitch or pitch-only update) with rates near and far from the start
bias and random accelerometer sums; a saturation profile drives the overflow counters.  Also the CORDIC rotation mode (cordic.sin_cos) against cordic_sin_cos and math.sin/cos."""

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from firmware_model import c_reference, cordic
from firmware_model import six_state_kernel as k6
from firmware_model.six_state_filter import SixStateFilterConfig
from firmware_model.six_state_fixed import SixStateFixedConfig, new_counts, new_work

DEG = math.pi / 180.0
STEPS = 6  # random steps per hypothesis example
EXAMPLES_NORMAL, EXAMPLES_SATURATING = 7000, 3000  # >= 10,000 cases in all, x STEPS steps each
I32 = st.integers(-(2**31), 2**31 - 1)


def _config(margin_deg=5.0, singularity="hold", tuning_a=1.0, iterations=cordic.MAX_ITERATIONS, levelling=False,
            rate_deg_s=0.5, sigma_m_s2=1.4e-3, counts_per_m_s2=1670.0):
    f = SixStateFilterConfig(dt_s=1 / 1.9, arw_rad_per_sqrt_s=(7.38e-3 * DEG, 8e-3 * DEG, 7e-3 * DEG),
                             bias_instability_rad_s=3.33e-3 * DEG, tuning_a=tuning_a,
                             singularity_margin_rad=margin_deg * DEG, singularity=singularity, levelling=levelling,
                             levelling_rate_rad_s=rate_deg_s * DEG, levelling_force_sigma_m_s2=sigma_m_s2)
    return SixStateFixedConfig.from_filter_config(f, cordic_iterations=iterations,
                                                  accel_counts_per_m_s2=counts_per_m_s2)


CONFIGS = [_config(), _config(singularity="decouple"), _config(margin_deg=20.0, tuning_a=3.0, iterations=16),
           _config(levelling=True), _config(levelling=True, singularity="decouple", margin_deg=20.0, iterations=16,
                                            rate_deg_s=5.0, sigma_m_s2=0.05, counts_per_m_s2=100.0)]
PARAMS = [c.params() for c in CONFIGS]


@pytest.fixture(scope="module")
def clib():
    return c_reference.load()


def _run_both(clib, params, state, ops):
    ffi, lib = clib
    n = ops.shape[0]
    s_py, s_c = state.copy(), state.copy()
    c_py, c_c = new_counts(), new_counts()
    out_py = np.zeros((n, k6.STATE_SIZE), np.int64)
    out_c = np.zeros((n, k6.STATE_SIZE), np.int64)
    k6.run_ops(s_py, params, c_py, new_work(), ops, out_py)
    ptr = lambda a: ffi.cast("int64_t *", ffi.from_buffer(a))  # noqa: E731
    lib.nf6_run(ptr(s_c), ptr(params), ptr(c_c), ptr(np.ascontiguousarray(ops)), n, ptr(out_c))
    return out_py, out_c, c_py, c_c


def _state(att, bias, p_kind, p_seed, b0):
    p_entries = np.random.default_rng(p_seed).integers(-(2**31), 2**31, 36)  # hypothesis picks the seed
    st_ = np.zeros(k6.STATE_SIZE, np.int64)
    st_[:3], st_[3:6], st_[k6.I_B0:k6.I_B0 + 3] = att, bias, b0
    if p_kind == "spd":  # L L^T of a random lower-triangular L, in raw units of each block (small entries)
        lower = np.tril(np.array(p_entries, dtype=np.int64).reshape(6, 6) >> 17)
        st_[6:42] = (lower @ lower.T).reshape(-1) >> 4
    else:  # arbitrary raw words (symmetric), the diagonal >= 1
        m = np.array(p_entries, dtype=np.int64).reshape(6, 6)
        m = np.triu(m) + np.triu(m, 1).T
        np.fill_diagonal(m, np.maximum(np.diag(m), 1))
        st_[6:42] = m.reshape(-1)
    return st_


def _op(kind, rates_or_refs, variances, n=0):
    return [kind, *rates_or_refs, *variances, n]


normal_rate = st.integers(-(90 << 16), 90 << 16)  # +/- 90 deg/s in Q16.16
near_b0 = st.integers(-(1 << 15), 1 << 15)  # a level op's rate offset from b_0, +/- 0.5 deg/s (thresholds 0.5, 5)
accel_sum = st.one_of(st.integers(-(1 << 24), 1 << 24), st.integers(-200, 200), st.just(0), I32)
op_normal = st.tuples(st.sampled_from([0, 0, 1, 3, 4, 5, k6.LEVEL_OP, k6.LEVEL_OP]),
                      st.tuples(*[st.one_of(normal_rate, I32)] * 3), st.tuples(*[st.integers(0, 1 << 24)] * 3),
                      st.booleans(), st.tuples(*[near_b0] * 3), st.tuples(*[accel_sum] * 3), st.integers(0, 2000))
op_saturating = st.tuples(st.sampled_from([0, 1, 3, 4, 5, k6.LEVEL_OP]), st.tuples(I32, I32, I32),
                          st.tuples(I32, I32, I32), st.booleans(), st.tuples(*[near_b0] * 3),
                          st.tuples(I32, I32, I32), st.integers(0, 1 << 20))


def _ops(ops, b0):
    """The op rows: a level op takes the accelerometer sums and n, its rates b_0 + offset where ``near``."""
    rows = []
    for kind, a, v, near, offset, acc, n in ops:
        if kind == k6.LEVEL_OP:
            rates = [b + o for b, o in zip(b0, offset)] if near else a
            rows.append(_op(kind, rates, acc, n))
        else:
            rows.append(_op(kind, a, np.abs(np.array(v)) if kind else v))
    return np.array(rows, dtype=np.int64)


def _check(clib, cfg_i, att, bias, p_kind, p_entries, ops, b0=None):
    b0 = bias if b0 is None else b0
    state = _state(att, bias, p_kind, p_entries, b0)
    ops = _ops(ops, b0)
    out_py, out_c, c_py, c_c = _run_both(clib, PARAMS[cfg_i], state, ops)
    np.testing.assert_array_equal(out_py, out_c)
    np.testing.assert_array_equal(c_py, c_c)
    before = np.vstack([state[None], out_py[:-1]])
    for n in np.flatnonzero(ops[:, 0] == k6.LEVEL_OP) if PARAMS[cfg_i][k6.P_LEVEL] else ():
        # a level op of a levelling build that changed the lane levelled it
        LEVEL_OPS["levelled" if np.any(out_py[n] != before[n]) else "skipped"] += 1
    return c_py


LEVEL_OPS = {"levelled": 0, "skipped": 0}
SETTINGS = dict(deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


@settings(max_examples=EXAMPLES_NORMAL, **SETTINGS)
@given(cfg_i=st.integers(0, len(CONFIGS) - 1), att=st.tuples(I32, st.integers(-(2**30), 2**30), I32),
       bias=st.tuples(*[st.integers(-(2 << 16), 2 << 16)] * 3), p_kind=st.sampled_from(["spd", "raw"]),
       p_entries=st.integers(0, 2**64 - 1), ops=st.lists(op_normal, min_size=STEPS, max_size=STEPS))
def test_kernel_equals_c_bit_for_bit(clib, cfg_i, att, bias, p_kind, p_entries, ops):
    _check(clib, cfg_i, att, bias, p_kind, p_entries, ops)


SATURATED: dict[str, int] = {}


@settings(max_examples=EXAMPLES_SATURATING, **SETTINGS)
@given(cfg_i=st.integers(0, len(CONFIGS) - 1), att=st.tuples(I32, I32, I32), bias=st.tuples(I32, I32, I32),
       p_entries=st.integers(0, 2**64 - 1), ops=st.lists(op_saturating, min_size=STEPS, max_size=STEPS),
       b0=st.tuples(I32, I32, I32))
def test_kernel_equals_c_when_saturating(clib, cfg_i, att, bias, p_entries, ops, b0):
    counts = _check(clib, cfg_i, att, bias, "raw", p_entries, ops, b0)
    for i in np.flatnonzero(counts):
        SATURATED[k6.SITES[i]] = SATURATED.get(k6.SITES[i], 0) + int(counts[i])


def test_the_saturation_cases_hit_the_counters():
    """Runs after the saturating test (file order): its cases saturated at many sites (so the counters were
    compared where they count, not only as zeros)."""
    if not SATURATED:
        pytest.skip("run with test_kernel_equals_c_when_saturating")
    assert len(SATURATED) >= 10, SATURATED


def test_the_level_ops_were_exercised():
    """Runs after the hypothesis tests: a good share of the levelling builds' level ops was static and updated (the
    comparison covered the update, not only the static test's early return), and the levelling's sites saturated."""
    if not SATURATED:
        pytest.skip("run with the hypothesis tests")
    total = LEVEL_OPS["levelled"] + LEVEL_OPS["skipped"]
    assert LEVEL_OPS["levelled"] >= 0.2 * total, LEVEL_OPS
    assert {"level sigma", "level R"} <= set(SATURATED), SATURATED


def test_layout_constants_agree(clib):
    _, lib = clib
    assert [lib.nf6_layout(i) for i in range(6)] == [k6.N_PARAMS, len(k6.SITES), k6.STATE_SIZE, k6.T_SERIES,
                                                      k6.P_DT_T, k6.C_360]


@settings(max_examples=2000, deadline=None)
@given(angle=I32, iterations=st.integers(cordic.MIN_ITERATIONS, cordic.MAX_ITERATIONS))
def test_cordic_sin_cos_equals_c_and_is_within_its_bound(clib, angle, iterations):
    ffi, lib = clib
    s, c = cordic.sin_cos(angle, iterations)
    out = ffi.new("int64_t[2]")
    assert lib.cordic_sin_cos(angle, iterations, out, out + 1) == 0
    assert (int(s), int(c)) == (out[0], out[1])
    a = angle / 2**32 * 2 * math.pi
    bound = math.atan(2.0 ** -(iterations - 1)) + (2 * iterations + 1) * 2.0**-30  # cordic.sin_cos docstring
    assert abs(s / 2**30 - math.sin(a)) <= bound and abs(c / 2**30 - math.cos(a)) <= bound
