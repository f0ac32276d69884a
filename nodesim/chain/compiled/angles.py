"""Angle reduction for the compiled kernels: numpy's ``remainder(x, 2 pi)`` bit for bit, fast where it is trivial.

The kernels reduce angle differences that are almost always within one turn (a filter's innovation, the step of the
yaw between two ticks, an averaged azimuth); there the floor-mod is the identity or one addition, and skipping the
general remainder (an fmod call) makes the float filter's phase 2 about twice as fast.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True, inline="always")
def mod_two_pi(x: float) -> float:
    """``np.remainder(x, 2 pi)`` bit for bit, without the remainder where it is the identity (0 < x < 2 pi, the
    common case) or one addition (-2 pi < x < 0): numpy's floor-mod (fmod, then + 2 pi for a negative remainder;
    a zero result is +0.0)."""
    two_pi = 2.0 * math.pi
    if 0.0 < x < two_pi:
        return x
    if -two_pi < x < 0.0:
        return x + two_pi
    return np.remainder(x, two_pi)
