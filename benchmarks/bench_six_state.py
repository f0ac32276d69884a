"""The 6-state fixed filter's cost per tick against the 2-state fixed filter's, numba kernels, measured in the same run.

``six_state_tick_ns`` / ``two_state_tick_ns``: one lane's raw predict plus a yaw update every tick (the
firmware's most expensive tick: an encoder or forwarded reference each tick) in an njit loop of TICKS ticks,
ns per tick, min over REPEAT runs (``*_median_ns`` the median); ``six_state_cost_vs_two_state`` the ratio of the
minima.  The 6-state filter: firmware_model.six_state_kernel (predict_raw, update_raw YAW_ONLY); the 2-state:
firmware_model.fixed_kernel (_predict_raw, _update_raw).  ``six_state_static_tick_ns``: the 6-state tick at rest with
the default levelling (``filter.levelling = "static"``): predict, the static test, the CORDIC tilt and the
roll/pitch updates (six_state_kernel.level_raw), then the yaw update, with the chain's build
(nodesim.chain.estimator.six_state_firmware_config); ``six_state_static_cost_vs_two_state`` its ratio.
"""

from __future__ import annotations

import math
import time

import numpy as np
from numba import njit

from firmware_model import fixed_kernel as fk
from firmware_model import six_state_kernel as k6
from firmware_model.fixed_filter import FixedYawFilter
from firmware_model.six_state_filter import SixStateFilterConfig
from firmware_model.six_state_fixed import SixStateFixedConfig, new_counts, new_work
from firmware_model.yaw_filter import YawFilterConfig

TICKS = 200_000
REPEAT = 7
DEG = math.pi / 180.0


@njit(cache=True, _nrt=False)
def _six_ticks(state, params, counts, work, rates, ref, var, n):
    for k in range(n):
        rates[2] = (60 << 16) + (k & 7)  # 60 deg/s in Q16.16, a little varying
        k6.predict_raw(state, rates, params, counts, work)
        ref[2] = state[k6.I_ATT + 2] + 1000
        k6.update_raw(state, k6.YAW_ONLY, ref, var, params, counts, work)


@njit(cache=True, _nrt=False)
def _two_ticks(state, params, counts, n):
    for k in range(n):
        fk._predict_raw(state, (60 << 16) + (k & 7), params, counts)
        fk._update_raw(state, state[fk.I_YAW] + 1000, 1 << 20, params, counts)


@njit(cache=True, _nrt=False)
def _six_static_ticks(state, params, counts, work, rates, accel, n_samples, ref, var, n):
    levelled = 0
    for k in range(n):
        rates[0], rates[1], rates[2] = k & 7, -(k & 3), k & 5  # at rest: a few LSB of Q16.16 deg/s
        k6.predict_raw(state, rates, params, counts, work)
        levelled += k6.level_raw(state, rates, accel, n_samples, params, counts, work)
        ref[2] = state[k6.I_ATT + 2] + 1000
        k6.update_raw(state, k6.YAW_ONLY, ref, var, params, counts, work)
    return levelled


def _times_ns(fn, n) -> list[float]:
    out = []
    for _ in range(REPEAT):
        t0 = time.perf_counter()
        fn(n)
        out.append((time.perf_counter() - t0) / n * 1e9)
    return out


def six_state_tick_cost() -> dict:
    dt = 1 / 1.9
    yaw_cfg = YawFilterConfig(dt_s=dt, arw_rad_per_sqrt_s=7.38e-3 * DEG, bias_instability_rad_s=3.33e-3 * DEG,
                              bias_tau_s=500.0)
    six = SixStateFixedConfig.from_filter_config(SixStateFilterConfig.from_yaw_config(yaw_cfg))
    p6, st6, c6, w6 = six.params(), six.initial_state(), new_counts(), new_work()
    rates, ref, var = np.zeros(3, np.int64), np.zeros(3, np.int64), np.full(3, 1 << 20, np.int64)
    two = FixedYawFilter(yaw_cfg, 1)
    p2, st2, c2 = fk.kernel_params(two), fk.lane_states(two)[0].copy(), np.zeros(len(fk.SITES), np.int64)
    _six_ticks(st6, p6, c6, w6, rates, ref, var, 10)  # compile / load
    _two_ticks(st2, p2, c2, 10)
    t6 = _times_ns(lambda n: _six_ticks(st6, p6, c6, w6, rates, ref, var, n), TICKS)
    t2 = _times_ns(lambda n: _two_ticks(st2, p2, c2, n), TICKS)
    ts, levelled = _static_ticks_ns()
    return {
        "six_state_static_tick_ns": min(ts), "six_state_static_tick_median_ns": float(np.median(ts)),
        "six_state_static_cost_vs_two_state": min(ts) / min(t2), "six_state_static_ticks_levelled": levelled,
        "six_state_tick_ns": min(t6), "six_state_tick_median_ns": float(np.median(t6)),
        "two_state_tick_ns": min(t2), "two_state_tick_median_ns": float(np.median(t2)),
        "six_state_cost_vs_two_state": min(t6) / min(t2),
    }


def _static_ticks_ns() -> tuple[list[float], float]:
    """The static tick's ns per tick (REPEAT runs) with the chain's default build, and the share of ticks levelled
    (1.0: every tick took the levelling path, as it should at rest)."""
    from nodesim.chain.estimator import six_state_firmware_config
    from nodesim.scenario.schema import Scenario

    _, build = six_state_firmware_config(Scenario().with_overrides(**{"filter.states": 6,
                                                                       "filter.implementation": "fixed"}))
    p, c, w = build.params(), new_counts(), new_work()
    st = build.initial_state(initial_attitude_rad=(0.0, 2.0 * DEG, 0.0))
    samples = 34  # 65 Hz samples in a 1.9 Hz tick
    g_counts = 9.80665 * build.accel_counts_per_m_s2 * samples  # a tube at rest, 2 deg off vertical
    accel = np.array([-math.sin(2 * DEG) * g_counts, 0.0, math.cos(2 * DEG) * g_counts]).round().astype(np.int64)
    rates, ref, var = np.zeros(3, np.int64), np.zeros(3, np.int64), np.full(3, 1 << 20, np.int64)
    _six_static_ticks(st, p, c, w, rates, accel, samples, ref, var, 10)  # compile / load
    done = [0]

    def run(n):
        done[0] = _six_static_ticks(st, p, c, w, rates, accel, samples, ref, var, n)

    times = _times_ns(run, TICKS)
    return times, done[0] / TICKS


BENCHMARKS = [six_state_tick_cost]
