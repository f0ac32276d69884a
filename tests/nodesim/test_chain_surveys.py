"""The compiled survey pass of a chain run against firmware_model.survey's numpy functions."""

import numpy as np
import pytest

from firmware_model.survey import circular_moving_average, resolve_survey, trailing_moving_average
from nodesim.chain.compiled.surveys import averaged_surveys


@pytest.mark.parametrize("points", [1, 4, 32])
def test_compiled_surveys_equal_resolve_then_moving_averages(points):
    rng = np.random.default_rng(points)
    R, K = 3, 200
    force = rng.normal([0.1, -0.05, 9.8], 0.3, size=(R, K, 3))
    force[1, 50:, :2] *= -1.0  # toolface through +-pi: the circular average has to wrap
    yaw = rng.uniform(-4.0, 4.0, size=(R, K))
    inc, azi = np.empty((R, K)), np.empty((R, K))
    averaged_surveys(force, yaw, points, inc, azi)
    i_raw, a_raw = resolve_survey(force, yaw)
    # the same operations in the same order; libm and numpy's own SIMD loops agree here bit for bit, and a
    # machine where they do not would differ by an ulp or so
    np.testing.assert_allclose(inc, trailing_moving_average(i_raw, points), rtol=0, atol=1e-13)
    np.testing.assert_allclose(azi, circular_moving_average(a_raw, points), rtol=0, atol=1e-13)
    assert ((azi >= 0.0) & (azi < 2 * np.pi)).all()
