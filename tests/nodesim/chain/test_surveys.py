"""The compiled survey pass of chain runs and replays against firmware_model.survey_resolution's numpy functions."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numba import njit

from firmware_model.survey_resolution import circular_moving_average, resolve_survey, trailing_moving_average
from nodesim.chain.compiled.angles import mod_two_pi
from nodesim.chain.compiled.surveys import averaged_surveys


def mid_window_yaw(yaw):
    """The oracle of the survey's yaw: the circular midpoint of the previous and this tick's yaw (the first as is)."""
    mid = yaw.copy()
    mid[:, 1:] = yaw[:, :-1] + 0.5 * (np.remainder(yaw[:, 1:] - yaw[:, :-1] + np.pi, 2 * np.pi) - np.pi)
    return mid


def _both(force, yaw, points):
    R, K = yaw.shape
    inc, azi = np.empty((R, K)), np.empty((R, K))
    averaged_surveys(force, yaw, 0, 0, points, inc, azi)
    i_raw, a_raw = resolve_survey(force, mid_window_yaw(yaw))
    return inc, azi, trailing_moving_average(i_raw, points), circular_moving_average(a_raw, points), a_raw


@pytest.mark.parametrize("points", [1, 4, 32])
def test_compiled_surveys_equal_resolve_then_moving_averages(points):
    rng = np.random.default_rng(points)
    R, K = 3, 200
    force = rng.normal([0.1, -0.05, 9.8], 0.3, size=(R, K, 3))
    force[1, 50:, :2] *= -1.0  # toolface through +-pi: the circular average has to wrap
    yaw = rng.uniform(-4.0, 4.0, size=(R, K))
    inc, azi, inc_np, azi_np, a_raw = _both(force, yaw, points)
    # inclination: the same operations in the same order (libm and numpy's loops agree here bit for bit; a
    # machine where they do not would differ by an ulp or so)
    np.testing.assert_allclose(inc, inc_np, rtol=0, atol=1e-13)
    # azimuth: its unit vector comes from a rotation instead of cos/sin of the angle, equal to rounding; the
    # averaged angle's error is that rounding over the length of the mean unit vector, plus a few ulps of an
    # angle up to 2 pi (8.9e-16 each)
    rho = np.hypot(trailing_moving_average(np.cos(a_raw), points), trailing_moving_average(np.sin(a_raw), points))
    diff = np.abs(np.angle(np.exp(1j * (azi - azi_np))))
    assert (diff <= 4e-15 * (1.0 + 1.0 / rho)).all(), (diff / (1.0 + 1.0 / rho)).max()
    assert diff.max() < 1e-12
    assert ((azi >= 0.0) & (azi < 2 * np.pi)).all()


def test_a_vertical_force_keeps_atan2s_convention():
    """No horizontal component (h = 0): toolface atan2(0, 0) = 0 or pi by the signs of the zeros, as numpy."""
    force = np.array([[[0.0, 0.0, 9.8], [-0.0, 0.0, 9.8], [0.0, -0.0, -9.8], [1e-3, 0.0, 9.8]]])
    yaw = np.array([[0.3, 0.3, 5.0, 0.3]])
    inc, azi, inc_np, azi_np, _ = _both(force, yaw, 1)  # mid-window yaw: 0.3, 0.3, ~(0.3 + 5) / 2 ...
    np.testing.assert_array_equal(inc, inc_np)
    np.testing.assert_allclose(azi, azi_np, rtol=0, atol=1e-15)
    np.testing.assert_allclose(azi[0, :2], [0.3, 0.3 + np.pi], rtol=0, atol=1e-15)


def test_the_mid_window_yaw_removes_the_half_tick_lag_of_a_turning_string():
    """A string turning at a constant rate: the tick-mean force points at the middle of the tick's arc; paired with
    the mid-window yaw the azimuth is exact, paired with the tick-end yaw it would be off by half a tick's turn."""
    K, dpsi, inc_t, azi_t = 60, np.radians(37.4), np.radians(2.0), np.radians(45.0)
    psi_end = dpsi * np.arange(1, K + 1)
    tau_mid = azi_t - (psi_end - dpsi / 2)  # toolface at the arc's middle
    g = 9.81 * np.sinc(dpsi / 2 / np.pi)  # the mean of a turning vector is shorter, not turned
    force = np.stack([g * np.sin(inc_t) * np.cos(tau_mid), g * np.sin(inc_t) * np.sin(tau_mid),
                      np.full(K, 9.81 * np.cos(inc_t))], -1)[None]
    inc, azi = np.empty((1, K)), np.empty((1, K))
    averaged_surveys(force, psi_end[None], 0, 0, 1, inc, azi)
    err = np.degrees(np.angle(np.exp(1j * (azi[0, 1:] - azi_t))))
    assert np.abs(err).max() < 1e-9
    assert abs(np.degrees(np.angle(np.exp(1j * (azi[0, 0] - azi_t)))) - 18.7) < 0.01  # first tick: no previous yaw


@pytest.mark.parametrize("points", [1, 8, 32])
def test_the_alignment_offset_removes_a_constant_transverse_offset(points):
    """Thesis 4.2.3: over a full slow turn (max + min) / 2 of each transverse axis is the sensor-frame offset; it is
    subtracted from every tick after the window (and only after it)."""
    K, lo, hi = 900, 100, 500
    tau = np.concatenate([np.zeros(lo), np.radians(1.9) * np.arange(hi - lo), np.full(K - hi, 0.7)])
    off = np.array([3e-3, -2e-3])
    f = np.stack([0.34 * np.cos(tau) + off[0], 0.34 * np.sin(tau) + off[1], np.full(K, 9.8)], -1)[None]
    yaw = np.zeros((1, K))
    inc, azi, inc0, azi0 = (np.empty((1, K)) for _ in range(4))
    averaged_surveys(f, yaw, lo, hi, points, inc, azi)
    averaged_surveys(f, yaw, 0, 0, points, inc0, azi0)
    np.testing.assert_array_equal(azi[:, :hi], azi0[:, :hi])  # nothing changes before the window ends
    clean = np.stack([0.34 * np.cos(tau), 0.34 * np.sin(tau), np.full(K, 9.8)], -1)[None]
    ic, ac = np.empty((1, K)), np.empty((1, K))
    averaged_surveys(clean, yaw, 0, 0, points, ic, ac)
    late = slice(hi + points, None)
    before = np.abs(np.angle(np.exp(1j * (azi0[:, late] - ac[:, late])))).max()
    after = np.abs(np.angle(np.exp(1j * (azi[:, late] - ac[:, late])))).max()
    assert before > 5e-3 and after < 2e-3 * before  # the offset's 0.6 deg is gone to the sinc of the arc


_MOD_TWO_PI = njit(lambda v: mod_two_pi(v))


@settings(max_examples=500, deadline=None)
@given(x=st.one_of(st.floats(-20.0, 20.0), st.sampled_from([0.0, -0.0, 2 * np.pi, -2 * np.pi, -1e-300, -1e-17, np.pi,
                                                             np.nextafter(2 * np.pi, 0), np.nextafter(-2 * np.pi, 0)])))
def test_mod_two_pi_is_numpys_remainder_bit_for_bit(x):
    got = _MOD_TWO_PI(x)
    assert np.float64(got).tobytes() == np.float64(np.remainder(x, 2 * np.pi)).tobytes()


@pytest.mark.parametrize("seed", [1, 2, 3, 4, 5, 6])
def test_surveys_in_windows_of_ticks_equal_all_ticks_at_once(seed):
    """averaged_surveys_window with the state carried (running sums, the last N sums, the alignment's average,
    extremes and ring, the yaw of the tick before) over windows of 1 tick to hundreds, the alignment window and
    the average crossing their edges: the words of one pass over all ticks, bit for bit."""
    from nodesim.chain.compiled import surveys

    rng = np.random.default_rng(seed)
    R, K, points = 3, int(rng.integers(200, 1500)), int(rng.choice([1, 2, 5, 32]))
    f = rng.normal(scale=0.3, size=(R, K, 3)) + np.array([0.1, -0.2, 9.8])
    yaw = np.cumsum(rng.normal(size=(R, K)), axis=1)
    lo, hi = sorted(int(v) for v in rng.integers(0, K, 2))
    want = np.empty((R, K)), np.empty((R, K))
    averaged_surveys(f, yaw, lo, hi, points, *want)
    state = (np.zeros((R, surveys.SURVEY_FLOATS)), np.zeros((R, surveys.SURVEY_INTS), np.int64),
             np.empty((R, 2, points)), np.empty((R, 3, points)))
    cuts = np.unique(np.concatenate([[0, 1, 2, K], rng.integers(0, K, 10), [lo, lo + 1, hi, hi + 1]]))
    cuts = cuts[cuts <= K]
    got = np.empty((R, K)), np.empty((R, K))
    for a, b in zip(cuts[:-1], cuts[1:]):
        out = np.empty((R, b - a)), np.empty((R, b - a))
        surveys.averaged_surveys_window(np.ascontiguousarray(f[:, a:b]), np.ascontiguousarray(yaw[:, a:b]), a, lo, hi,
                                        points, *state, *out)
        got[0][:, a:b], got[1][:, a:b] = out
    assert np.array_equal(got[0], want[0]) and np.array_equal(got[1], want[1])
