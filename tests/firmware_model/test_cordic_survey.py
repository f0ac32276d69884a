"""The integer CORDIC (firmware_model.cordic) and the survey + moving average (firmware_model.node_survey): against
math.atan2 / hypot with an error bound in the iteration count, exact tables, and the C reference
(firmware_model/c/cordic.c, survey.c) word for word on >= 10,000 hypothesis-generated cases; a deliberately
broken C rounding is caught."""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from firmware_model import c_reference, cordic
from firmware_model import node_survey as survey
from firmware_model.errors import FirmwareError

TWO_PI = 2.0 * math.pi
LSB_RAD = TWO_PI / 2**32


def bound_rad(n: int) -> float:
    """atan(2^-(n-1)) (Volder's residual) + half an LSB per table entry + the shift truncations."""
    return 2.0 ** -(n - 1) + n * LSB_RAD + (n + 4) * 2.0 ** -30


def mag_bound(n: int, h: float) -> float:
    """|CORDIC magnitude - hypot|: the residual angle's cosine (2^-2(n-1)), one truncation LSB per iteration at
    the 2^29 scale, the gain's rounding, and one unit of the inputs."""
    return h * (2.0 ** (2 - 2 * n) + (n + 2) * 2.0 ** -29) + 1.0


def angle_err(raw: int, want: float) -> float:
    return abs(math.remainder(raw * LSB_RAD - want, TWO_PI))


def _atan_series(x: Fraction, terms: int) -> Fraction:
    return sum(Fraction((-1) ** k, 2 * k + 1) * x ** (2 * k + 1) for k in range(terms))


def test_atan_table_is_exactly_rounded():
    """ATAN[i] = round_he(atan(2^-i) / 2 pi * 2^32) checked in exact rational arithmetic (Machin's pi, series
    truncated far below 2^-60), so math.atan's last-bit error did not move a rounding."""
    pi = 16 * _atan_series(Fraction(1, 5), 40) - 4 * _atan_series(Fraction(1, 239), 15)
    for i, v in enumerate(cordic.ATAN):
        a = Fraction(1, 8) * 2 * pi if i == 0 else _atan_series(Fraction(1, 2**i), 30)
        exact = a / (2 * pi) * 2**32
        assert abs(exact - int(v)) < Fraction(1, 2), i
        assert abs(abs(exact - int(v)) - Fraction(1, 2)) > Fraction(1, 10**6), i  # not near a tie


def test_c_tables_equal_the_model():
    ffi, lib = c_reference.load()
    assert [lib.cordic_atan_entry(i) for i in range(cordic.MAX_ITERATIONS)] == [int(v) for v in cordic.ATAN]
    assert [lib.cordic_gain_inv(n) for n in range(cordic.MAX_ITERATIONS + 1)] == [int(v) for v in cordic.K_INV]


@pytest.mark.parametrize("n", [8, 10, 12, 16, 20, 24, 30])
def test_atan2_error_within_the_iteration_bound_every_quadrant(n):
    rng = np.random.default_rng(n)
    worst = 0.0
    for _ in range(4000):
        x, y = (int(v) for v in rng.integers(-2**40, 2**40, 2) >> rng.integers(0, 40, 2))
        a, m = cordic.vectoring(x, y, n)
        assert -2**31 <= a < 2**31
        worst = max(worst, angle_err(a, math.atan2(y, x)) / bound_rad(n))
        if x or y:
            assert abs(m - math.hypot(x, y)) <= mag_bound(n, math.hypot(x, y))
    assert worst <= 1.0
    if n <= 16:  # the bound is not loose where the residual angle dominates
        assert worst > 0.5


def test_axes_zero_vector_and_extremes():
    n = cordic.DEFAULT_ITERATIONS
    assert cordic.vectoring(0, 0, n) == (0, 0)
    big = cordic.MAX_INPUT
    for (x, y), want in [((1, 0), 0.0), ((0, 1), math.pi / 2), ((-1, 0), math.pi), ((0, -1), -math.pi / 2),
                         ((big, big), math.pi / 4), ((-big, -big), -3 * math.pi / 4), ((big, -1), 0.0),
                         ((-big, 1), math.pi), ((1, big), math.pi / 2)]:
        a, m = cordic.vectoring(x, y, n)
        assert angle_err(a, want) <= bound_rad(n), (x, y)
        assert abs(m - math.hypot(x, y)) <= mag_bound(n, math.hypot(x, y)), (x, y)
    with pytest.raises(FirmwareError):
        cordic.vectoring(big + 1, 0, n)
    for bad in (cordic.MIN_ITERATIONS - 1, cordic.MAX_ITERATIONS + 1):
        with pytest.raises(FirmwareError):
            cordic.vectoring(1, 1, bad)
        with pytest.raises(FirmwareError, match="cordic_iterations"):
            cordic.check_iterations(bad)


def test_survey_resolution_against_eqs_1_1_to_1_3():
    """I = atan2(hypot(f'_x, f'_y), f'_z), A = atan2(f'_y, f'_x) + psi (mod 2 pi), thesis eqs 1.1-1.3, from
    34-sample count sums at 16384 LSB/g: CORDIC within its bound, float32 within a few float32 ulps."""
    rng = np.random.default_rng(7)
    for _ in range(3000):
        f = rng.normal(size=3) * 34 * 16384 * rng.uniform(0.01, 2.0)
        f = np.rint(f).astype(np.int64)
        yaw = int(rng.integers(-2**31, 2**31))
        want_i = math.atan2(math.hypot(f[0], f[1]), f[2])
        want_a = math.atan2(f[1], f[0]) + yaw * LSB_RAD
        i, a = survey.resolve(f[0], f[1], f[2], survey.yaw_to_ba32(yaw, 32), survey.MODE_CORDIC, 24)
        assert 0 <= i <= 2**31 and 0 <= a < 2**32
        assert angle_err(i, want_i) <= 2 * bound_rad(24) and angle_err(a, want_a) <= 2 * bound_rad(24)
        i, a = survey.resolve(f[0], f[1], f[2], survey.yaw_to_ba32(yaw, 32), survey.MODE_FPU, 24)
        assert angle_err(i, want_i) <= 4e-7 * 4 and angle_err(a, want_a) <= 4e-7 * 4


def test_moving_average_is_the_exact_mean_across_the_seam():
    """I_avg = round_he(mean I); A_avg = newest + round_he(mean of wrapped differences): 359 deg and 1 deg
    average to 0 deg, and the first N - 1 outputs average what has arrived."""
    st_ = np.zeros(survey.ma_state_size(4), np.int64)
    survey.ma_reset(st_)
    deg = lambda d: int(round(d / 360 * 2**32)) % 2**32  # noqa: E731
    assert survey.ma_push(st_, 4, 10, deg(359.0)) == (10, deg(359.0))
    assert survey.ma_push(st_, 4, 13, deg(1.0)) == (12, 0)  # 11.5 -> 12 (half even); (359 + 1) / 2 = 0 deg
    rng = np.random.default_rng(3)
    vals = [(int(rng.integers(0, 2**31)), int(rng.integers(0, 2**32))) for _ in range(20)]
    survey.ma_reset(st_)
    for k, (i, a) in enumerate(vals):
        w = vals[max(0, k - 3):k + 1]
        got_i, got_a = survey.ma_push(st_, 4, i, a)
        q = Fraction(sum(v for v, _ in w), len(w))
        assert got_i == round(q)
        d = Fraction(sum(((b - a + 2**31) % 2**32) - 2**31 for _, b in w), len(w))
        assert got_a == (a + round(d)) % 2**32


# ---- C reference vs model ----------------------------------------------------------------------------------

INT = st.one_of(
    st.integers(-2**62 + 1, 2**62 - 1),
    st.integers(-2**40, 2**40),
    st.integers(-70000, 70000),
    st.integers(-3, 3),
    st.sampled_from([0, 1, -1, 2**62 - 1, -(2**62 - 1), 2**31, -2**31, 2**29, 2**28 - 1, 557056, -557056]),
)
ITERS = st.integers(cordic.MIN_ITERATIONS, cordic.MAX_ITERATIONS)
BATCH = 25  # cases per hypothesis example


def _c_vectoring(lib, ffi, x, y, n):
    a, m = ffi.new("int64_t *"), ffi.new("int64_t *")
    assert lib.cordic_vectoring(x, y, n, a, m) == 0
    return a[0], m[0]


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(st.tuples(INT, INT, ITERS), min_size=BATCH, max_size=BATCH))
def test_c_cordic_equals_the_model(cases):
    """200 examples x 25 = 5,000 vectors: every angle and magnitude word identical."""
    ffi, lib = c_reference.load()
    for x, y, n in cases:
        assert _c_vectoring(lib, ffi, x, y, n) == cordic.vectoring(x, y, n), (x, y, n)


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(st.tuples(INT, INT, INT, st.integers(-2**31, 2**31 - 1), ITERS, st.sampled_from([0, 1])),
                min_size=BATCH, max_size=BATCH))
def test_c_survey_resolution_equals_the_model(cases):
    """200 examples x 25 = 5,000 ticks, both modes: every I and A word identical."""
    ffi, lib = c_reference.load()
    i, a = ffi.new("int64_t *"), ffi.new("int64_t *")
    for fx, fy, fz, yaw, n, mode in cases:
        y32 = survey.yaw_to_ba32(yaw, 32)
        assert lib.survey_resolve(fx, fy, fz, y32, mode, n, i, a) == 0
        assert (i[0], a[0]) == survey.resolve(fx, fy, fz, y32, mode, n), (fx, fy, fz, yaw, n, mode)


def run_c(lib, ffi, accel, yaw, samples, lo, hi, points, mode, n, yaw_frac_bits):
    """The C survey_run over one stream: (return code, I words, A words, final state)."""
    K = yaw.size
    state = np.zeros(survey.ma_state_size(points), np.int64)
    inc, azi = np.zeros(K, np.int64), np.zeros(K, np.int64)
    buf = lambda v: ffi.from_buffer("int64_t[]", v)  # noqa: E731
    rc = lib.survey_run(buf(np.ascontiguousarray(accel)), buf(np.ascontiguousarray(yaw)),
                        buf(np.ascontiguousarray(samples)), K, lo, hi, points, mode, n, yaw_frac_bits, buf(state),
                        buf(inc), buf(azi))
    return rc, inc, azi, state


def run_model(accel, yaw, samples, lo, hi, points, mode, n, yaw_frac_bits):
    """The model over one stream, tick by tick (survey_tick, as fixed_surveys): (I, A, final state), or None if it
    raised FirmwareError."""
    K = yaw.size
    state = np.zeros(survey.ma_state_size(points), np.int64)
    inc, azi = np.zeros(K, np.int64), np.zeros(K, np.int64)
    survey.ma_reset(state)
    try:
        for k in range(K):
            inc[k], azi[k] = survey.survey_tick(state, points, accel[k, 0], accel[k, 1], accel[k, 2], samples[k],
                                                survey.yaw_to_ba32(yaw[k], yaw_frac_bits), lo <= k < hi, mode, n)
    except FirmwareError:
        return None
    return inc, azi, state


def random_stream(rng, K):
    """A node's survey stream: near-vertical to horizontal tilt, noisy count sums of 1..40 samples with a
    transverse offset (the residual tilt), a turning yaw; sometimes extreme or zero samples."""
    tilt = rng.uniform(0.0, math.pi)
    tf = rng.uniform(-math.pi, math.pi) + np.cumsum(rng.normal(0, 0.3, K))
    samples = rng.integers(1, 41, K) if rng.random() < 0.5 else np.full(K, 34)
    g = samples * 16384 * rng.uniform(0.5, 2.0)
    off = rng.normal(0, 300, 2)
    f = np.stack([g * math.sin(tilt) * np.cos(tf) + off[0] * samples, g * math.sin(tilt) * np.sin(tf) + off[1] * samples,
                  g * math.cos(tilt)], -1)
    f = np.rint(f + rng.normal(0, rng.uniform(0, 3000), (K, 3))).astype(np.int64)
    odd = rng.random(K) < (0.05 if rng.random() < 0.5 else 0.0)
    f[odd] = rng.choice([0, 1, -1, 2**40, -2**40, 2**40 + 1, 2**62 - 1, -(2**62 - 1)], (int(odd.sum()), 3))
    yaw = rng.integers(-2**31, 2**31) + np.cumsum(rng.integers(-2**28, 2**28, K))
    return f, yaw, samples.astype(np.int64)


def sweep_streams(lib, ffi, n_streams, seed):
    """Random streams (lengths, average lengths, modes, iterations, yaw formats, alignment windows): every I and
    A word and the final state identical, or both refuse (the model raises, C returns an error code)."""
    rng = np.random.default_rng(seed)
    refused = aligned = 0
    for _ in range(n_streams):
        K, points = int(rng.integers(1, 160)), int(rng.choice([1, 2, 5, 32, 33, 100]))
        mode, n = int(rng.integers(0, 2)), int(rng.integers(cordic.MIN_ITERATIONS, cordic.MAX_ITERATIONS + 1))
        fb = int(rng.choice([32, 24, 16, 34]))
        f, yaw, samples = random_stream(rng, K)
        lo, hi = sorted(int(v) for v in rng.integers(-5, K + 5, 2)) if rng.random() < 0.8 else (0, 0)
        yaw = (yaw >> max(0, 32 - fb)) if fb <= 32 else yaw << (fb - 32)
        yaw = yaw & ((1 << min(fb, 62)) - 1)
        model = run_model(f, yaw, samples, lo, hi, points, mode, n, fb)
        rc, inc_c, azi_c, state_c = run_c(lib, ffi, f, yaw, samples, lo, hi, points, mode, n, fb)
        if model is None:
            assert rc != 0
            refused += 1
            continue
        assert rc == 0
        inc_m, azi_m, state_m = model
        np.testing.assert_array_equal(inc_c, inc_m)
        np.testing.assert_array_equal(azi_c, azi_m)
        np.testing.assert_array_equal(state_c, state_m)
        aligned += int(state_m[survey.AL_PHASE] == survey.ALIGN_APPLIED)
        inc_b, azi_b = np.zeros((1, K), np.int64), np.zeros((1, K), np.int64)
        survey.fixed_surveys(f[None], yaw[None], samples, lo, hi, points, mode, n, inc_b, azi_b, fb)
        np.testing.assert_array_equal(inc_b[0], inc_m)  # the batched loop runs the same ticks
        np.testing.assert_array_equal(azi_b[0], azi_m)
        states = np.zeros((1, survey.ma_state_size(points)), np.int64)  # in windows (the state carried): the same
        cut_rng = np.random.default_rng(K * 1000 + points)  # (the sweep's own draws unchanged)
        cuts = [0, *sorted(set(int(c) for c in cut_rng.integers(1, K, 3))), K] if K > 1 else [0, K]
        for a, b in zip(cuts[:-1], cuts[1:]):
            i_w, a_w = np.zeros((1, b - a), np.int64), np.zeros((1, b - a), np.int64)
            survey.fixed_surveys_window(np.ascontiguousarray(f[None, a:b]), np.ascontiguousarray(yaw[None, a:b]),
                                        np.ascontiguousarray(samples[a:b]), a, lo, hi, points, mode, n, states,
                                        i_w, a_w, fb)
            inc_b[:, a:b], azi_b[:, a:b] = i_w, a_w
        np.testing.assert_array_equal(inc_b[0], inc_m)
        np.testing.assert_array_equal(azi_b[0], azi_m)
    assert refused > 0 and aligned > n_streams // 10  # both branches exercised


def test_c_moving_average_equals_the_model_on_random_streams():
    ffi, lib = c_reference.load()
    sweep_streams(lib, ffi, 400, seed=19)


@pytest.mark.parametrize("file,old,new", [
    ("fixedpoint.c", "return (x + (((x >> s) & 1) + ((int64_t)1 << (s - 1)) - 1)) >> s;",
     "return (x + ((int64_t)1 << (s - 1))) >> s;"),  # round half up instead of half even
    ("survey.c", "*azi_avg = (azi + fx_div_round(d, n)) & SURVEY_MASK32;",
     "*azi_avg = (azi + d / n) & SURVEY_MASK32;"),  # truncating division
    ("survey.c", "state[SURVEY_AL_OFF_X] = fx_shift_round(state[SURVEY_AL_MAX_X] + state[SURVEY_AL_MIN_X], 1);",
     "state[SURVEY_AL_OFF_X] = (state[SURVEY_AL_MAX_X] + state[SURVEY_AL_MIN_X]) >> 1;"),  # floor, not half even
    ("survey.c", "return (prev + fx_shift_round(cordic_wrap32(yaw32 - prev), 1)) & SURVEY_MASK32;",
     "return (prev + cordic_wrap32(yaw32 - prev) / 2) & SURVEY_MASK32;"),  # truncating mid-window yaw
])
def test_a_broken_c_rounding_is_caught(tmp_path, file, old, new):
    ffi, lib = c_reference.load_modified({file: (old, new)}, tmp_path)
    with pytest.raises(AssertionError):
        sweep_streams(lib, ffi, 400, seed=19)


# ---- eqs 1.1-1.3 (moved from the deleted tests/firmware_model/test_preprocessing.py), float and fixed ---------

def rotating_tube(inc_rad, azi_rad, yaw):
    """Sensor-frame specific force of a tube at (I, A) rotated by yaw (no mounting offset)."""
    g = 9.81
    f = np.array([g * math.sin(inc_rad) * math.cos(azi_rad), g * math.sin(inc_rad) * math.sin(azi_rad), g * math.cos(inc_rad)])
    c, s = np.cos(yaw), np.sin(yaw)
    return np.stack([c * f[0] + s * f[1], -s * f[0] + c * f[1], np.full_like(c, f[2])], -1)  # tube frame


def fixed_of(f, yaw_rad, mode=survey.MODE_CORDIC, n=cordic.DEFAULT_ITERATIONS):
    """The firmware's (I, A) [rad] of one tick: 34-sample count sums at 16384 LSB/g, the yaw as a binary angle."""
    counts = np.rint(f / 9.81 * 16384 * 34).astype(np.int64)
    yaw32 = int(round(yaw_rad / TWO_PI * 2**32)) % 2**32
    i, a = survey.resolve(counts[0], counts[1], counts[2], yaw32, mode, n)
    return float(survey.inclination_rad(i)), float(survey.azimuth_rad(a))


@settings(max_examples=50, deadline=None)
@given(st.floats(0.5, 60.0), st.floats(0.0, 359.0), st.floats(-720.0, 720.0))
def test_resolve_eqs_1_1_to_1_3(inc_deg, azi_deg, yaw_deg):
    """I independent of yaw, A = tau' + psi (dA/dpsi = 1), A recovers the true azimuth (digest 1.2); the fixed
    survey (CORDIC and float32) gives the same to its resolution."""
    from firmware_model.survey_resolution import resolve, resolve_survey

    DEG = math.pi / 180
    yaw = np.array([yaw_deg * DEG])
    f = rotating_tube(inc_deg * DEG, azi_deg * DEG, yaw)
    s = resolve(f, yaw)
    assert s.inclination_rad[0] == pytest.approx(inc_deg * DEG, abs=1e-12)
    err = np.angle(np.exp(1j * (s.azimuth_rad[0] - azi_deg * DEG)))
    assert abs(err) < 1e-9
    assert np.remainder(s.toolface_rad[0] + yaw[0] - s.azimuth_rad[0] + 1.0, 2 * math.pi) == pytest.approx(1.0)
    s2 = resolve(f, yaw + 0.01)  # a yaw error becomes the same azimuth error
    assert np.angle(np.exp(1j * (s2.azimuth_rad[0] - s.azimuth_rad[0]))) == pytest.approx(0.01, abs=1e-12)
    i, a = resolve_survey(f, yaw)
    assert i[0] == s.inclination_rad[0] and a[0] == s.azimuth_rad[0]
    # count quantisation: 1 LSB of the horizontal sum over |f_xy| >= sin(0.5 deg) 34 16384 LSB -> < 2e-4 rad
    for mode in (survey.MODE_CORDIC, survey.MODE_FPU):
        fi, fa = fixed_of(f[0], yaw[0], mode)
        assert fi == pytest.approx(inc_deg * DEG, abs=2e-6)
        assert abs(np.angle(np.exp(1j * (fa - azi_deg * DEG)))) < 2e-4


def test_northward_tilt_gives_azimuth_zero():
    """Digest 9 item 2: a bottom displaced northward must give A = 0 (z up-hole, toolface to high side)."""
    from firmware_model.survey_resolution import resolve

    f = rotating_tube(3.0 * math.pi / 180, 0.0, np.array([0.0]))
    assert resolve(f, np.array([0.0])).azimuth_rad[0] == pytest.approx(0.0, abs=1e-12)
    _, a = fixed_of(f[0], 0.0)
    assert abs(np.angle(np.exp(1j * a))) < 1e-6


@settings(max_examples=3000, deadline=None)
@given(st.integers(-(2**40), 2**40), st.integers(1, 4096))
def test_the_average_divides_by_its_count_as_div_round_does(x, n):
    """ma_push divides by a power-of-two count with a rounding shift: the same value as the division."""
    from firmware_model.fixed_kernel import div_round

    assert survey._div_round_count(x, n) == div_round(x, n)


@settings(max_examples=3000, deadline=None)
@given(st.integers(1, 2**62), st.one_of(st.integers(1, 2**62), st.integers(1, 2**49)),
       st.sampled_from([cordic.MAX_INPUT, 2**40, 12345]))
def test_the_offset_overflow_test_is_the_division_test(n, a, limit):
    """align_correction's overflow test by multiplication (where it cannot overflow) is ``n > limit // a``."""
    assert survey._times_exceeds(n, a, limit) == (n > limit // a)
    assert survey._times_exceeds(min(n, 2**14 - 1), min(a, 2**48 - 1), limit) == (
        min(n, 2**14 - 1) > limit // min(a, 2**48 - 1))


def test_angle_rad_into_gives_angle_rads_bits():
    """The in-place conversion the chain's surveys use equals angle_rad bit for bit, on every edge of the word range
    and on random words, into a strided view (a record's columns from the node's first tick on)."""
    rng = np.random.default_rng(7)
    edges = np.array([0, 1, 2, 2**31 - 1, 2**31, 2**31 + 1, 2**32 - 2, 2**32 - 1, -1, -(2**31)], dtype=np.int64)
    raw = np.concatenate([edges, rng.integers(-(2**33), 2**33, 5000)]).reshape(2, -1)
    out = np.full((2, raw.shape[1] + 3), np.nan)
    cordic.angle_rad_into(raw, out[:, 3:])
    want = cordic.angle_rad(raw)
    assert np.array_equal(out[:, 3:].view(np.int64), want.view(np.int64))
    assert np.isnan(out[:, :3]).all()  # nothing written outside the view
