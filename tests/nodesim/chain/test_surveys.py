"""The compiled survey pass of chain runs and replays against firmware_model.survey_resolution's numpy functions."""

import numpy as np
import pytest

from firmware_model.survey_resolution import circular_moving_average, resolve_survey, trailing_moving_average
from nodesim.chain.compiled.surveys import averaged_surveys


def _both(force, yaw, points):
    R, K = yaw.shape
    inc, azi = np.empty((R, K)), np.empty((R, K))
    averaged_surveys(force, yaw, points, inc, azi)
    i_raw, a_raw = resolve_survey(force, yaw)
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
    inc, azi, inc_np, azi_np, _ = _both(force, yaw, 1)
    np.testing.assert_array_equal(inc, inc_np)
    np.testing.assert_allclose(azi, azi_np, rtol=0, atol=1e-15)
    np.testing.assert_allclose(azi[0, :2], [0.3, 0.3 + np.pi], rtol=0, atol=1e-15)
