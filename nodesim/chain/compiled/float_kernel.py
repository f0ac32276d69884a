"""The float yaw filter (:class:`firmware_model.yaw_filter.FloatYawFilter`) as compiled scalar functions on one
realization, with the same operations in the same order (bit-identical results).

State (5,) float64: yaw, bias, P_yy, P_yb, P_bb.  Params: dt, 2 dt, dt^2, q_yy, f = 1 - dt/tau, f^2, q_bb.
    predict:  yaw += dt (rate - bias);  P_yy += 2 dt P_yb + dt^2 P_bb + q_yy;  P_yb = f (P_yb + dt P_bb);
              P_bb = f^2 P_bb + q_bb
    update:   z = wrap_pi(yaw - ref);  K = P h / (P_yy + R);  x -= K z;  P = (I - K H) P
``counts`` (the fixed filter's overflow counters) is unused: the float filter never overflows.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from firmware_model.yaw_filter import FloatYawFilter
from nodesim.chain.compiled.angles import mod_two_pi


def kernel_params(kf: FloatYawFilter) -> np.ndarray:
    two_dt, dt2, q_y, dt, f, f2, q_b = kf._c
    return np.array([kf.config.dt_s, two_dt, dt2, q_y, f, f2, q_b])


def lane_states(kf: FloatYawFilter) -> np.ndarray:
    """(R, 5) float64: yaw, bias, P_yy, P_yb, P_bb."""
    return np.stack([kf.yaw_rad, kf.bias_rad_s, kf.p_yy, kf.p_yb, kf.p_bb], axis=1).astype(float)


@njit(cache=True, _nrt=False)
def predict(state, rate_rad_s, params, counts) -> None:
    dt, two_dt, dt2, q_y, f, f2, q_b = params[0], params[1], params[2], params[3], params[4], params[5], params[6]
    yy, yb, bb = state[2], state[3], state[4]
    state[0] = state[0] + dt * (rate_rad_s - state[1])
    state[2] = yy + two_dt * yb + dt2 * bb + q_y
    state[3] = f * (yb + params[0] * bb)
    state[4] = f2 * bb + q_b


@njit(cache=True, _nrt=False)
def update(state, ref_rad, var_rad2, params, counts) -> None:
    innovation = mod_two_pi(state[0] - ref_rad + math.pi) - math.pi  # np.remainder's bits
    yy, yb, bb = state[2], state[3], state[4]
    inv_s = 1.0 / (yy + var_rad2)
    k_y, k_b = yy * inv_s, yb * inv_s
    state[0] = state[0] - k_y * innovation
    state[1] = state[1] + k_b * innovation
    state[2] = yy - k_y * yy
    state[3] = yb - k_y * yb
    state[4] = bb - k_b * yb


@njit(cache=True, _nrt=False)
def yaw_rad(state, params) -> float:
    return state[0]


@njit(cache=True, _nrt=False)
def bias_rad_s(state, params) -> float:
    return state[1]


@njit(cache=True, _nrt=False)
def yaw_variance_rad2(state, params) -> float:
    return state[2]
