"""Unit conversions at the edges (scenario files, tables, plots).  Inside the code everything is SI.

Angles are radians inside, degrees at the edges; angular rates rad/s inside, deg/s or deg/h at the edges.
"""

import math

import numpy as np

DEG = math.pi / 180.0
"""Radians per degree: ``x_rad = x_deg * DEG``."""

G0_M_S2 = 9.81
"""Standard gravity used by the thesis worked examples (thesis 4.1.2 uses g = 9.81 m/s^2)."""


def deg_to_rad(x_deg):
    """Degrees -> radians (scalars or arrays)."""
    return np.multiply(x_deg, DEG)


def rad_to_deg(x_rad):
    """Radians -> degrees (scalars or arrays)."""
    return np.divide(x_rad, DEG)


def wrap_pi(angle_rad):
    """Wrap an angle into (-pi, pi]: the form used for innovations and angle errors."""
    wrapped = np.remainder(np.add(angle_rad, math.pi), 2.0 * math.pi) - math.pi
    return np.where(wrapped == -math.pi, math.pi, wrapped)


def wrap_2pi(angle_rad):
    """Wrap an angle into [0, 2 pi): the form used for azimuth and yaw outputs."""
    return np.remainder(angle_rad, 2.0 * math.pi)
