"""Firmware model throughput against library baselines timed in the same run.

- ``fixedpoint_speedup_vs_fxpmath``: Q16.16 multiply, round half-even, saturate (with the overflow counter)
  on 1e5-element arrays: fxpmath's time per element / ours.  fxpmath runs the same operation
  (``op_sizing='same'``, ``rounding='around'``, ``overflow='saturate'``); ``fixedpoint_fxpmath_agreement`` is
  the share of bit-identical results (1.0 = the same work), ``fixedpoint_overhead_vs_plain_numpy`` our
  time over a bare numpy int64 multiply-round(half-up)-clip with no overflow accounting.
- ``batched_filter_speedup_vs_filterpy``: realization-steps per second of the float filter advancing
  R = 10,000 realizations per call (predict + update each step) over a Python loop of filterpy
  ``KalmanFilter`` objects running the same filter with the same closed-loop reset.  To keep the run short
  the loop is timed on 400 filters and scaled per realization-step (its cost is linear in the count).
  ``batched_fixed_filter_speedup_vs_filterpy`` is the same for the fixed-point filter.
"""

from __future__ import annotations

import math

import numpy as np
from filterpy.kalman import KalmanFilter

from firmware_model import fixedpoint as fp
from firmware_model.fixedpoint import Overflow, QFormat, Rounding
from firmware_model.yaw_filter import YawFilterConfig, make_yaw_filter, wrap_pi
from nodesim.bench import best_time_s
from nodesim.errors import NodesimError

N_ELEMENTS = 100_000
R_BATCH = 10_000
R_LOOP = 400
STEPS = 10
DEG = math.pi / 180.0


def fixedpoint_vs_fxpmath() -> dict:
    try:
        from fxpmath import Fxp  # a test/bench dependency (pyproject [test] extra), not a runtime one
    except ImportError as exc:
        raise NodesimError("benchmark fixedpoint_vs_fxpmath needs fxpmath: pip install -e '.[test]'") from exc
    rng = np.random.default_rng(0)
    fmt = QFormat(32, 16)
    x, y = rng.uniform(-200.0, 200.0, (2, N_ELEMENTS))  # some products leave Q16.16 and saturate
    a, b = fp.from_float(x, fmt), fp.from_float(y, fmt)
    counter = fp.OverflowCounter()
    ours = lambda: fp.mul(a, b, fmt, Rounding.HALF_EVEN, Overflow.SATURATE, counter, "bench")  # noqa: E731
    cfg = dict(signed=True, n_word=32, n_frac=16, rounding="around", overflow="saturate")
    fa, fb = Fxp(x, **cfg), Fxp(y, **cfg)
    fa.config.op_sizing = "same"

    def plain():
        p = a.raw * b.raw
        p += 1 << 15
        p >>= 16
        np.clip(p, fmt.min_raw, fmt.max_raw, out=p)

    agreement = float(np.mean(ours().raw == np.asarray((fa * fb).val).astype(np.int64)))
    t_ours = best_time_s(ours, repeat=7, number=5)
    t_fxp = best_time_s(lambda: fa * fb, repeat=3)
    t_plain = best_time_s(plain, repeat=7, number=5)
    return {
        "fixedpoint_speedup_vs_fxpmath": t_fxp / t_ours,
        "fixedpoint_fxpmath_agreement": agreement,
        "fixedpoint_overhead_vs_plain_numpy": t_ours / t_plain,
        "fixedpoint_mul_1e5_s": t_ours,
        "fxpmath_mul_1e5_s": t_fxp,
        "plain_numpy_mul_1e5_s": t_plain,
    }


def _config() -> YawFilterConfig:
    return YawFilterConfig(dt_s=1 / 1.9, arw_rad_per_sqrt_s=7.38e-3 * DEG, bias_instability_rad_s=3.33e-3 * DEG, bias_tau_s=500.0)


def _inputs(R: int):
    rng = np.random.default_rng(1)
    rate = 3.6 * DEG + 0.01 * DEG * rng.standard_normal((STEPS, R))
    ref = np.cumsum(np.full((STEPS, R), 3.6 * DEG / 1.9), axis=0)
    return rate, ref


def _batched_run(kind: str, cfg: YawFilterConfig, rate, ref, var) -> None:
    kf = make_yaw_filter(kind, cfg, rate.shape[1])
    for k in range(STEPS):
        kf.predict(rate[k])
        kf.update(ref[k], var)


def _filterpy_run(cfg: YawFilterConfig, rate, ref, var) -> None:
    for r in range(rate.shape[1]):
        kf = KalmanFilter(dim_x=2, dim_z=1)
        kf.F, kf.Q, kf.H, kf.P, kf.R = cfg.phi, cfg.q_d, np.array([[1.0, 0.0]]), cfg.p0.copy(), np.array([[var]])
        yaw = bias = 0.0
        for k in range(STEPS):
            kf.predict()
            yaw += cfg.dt_s * (rate[k, r] - bias)
            kf.update(wrap_pi(yaw - ref[k, r]))
            yaw -= kf.x[0, 0]
            bias += kf.x[1, 0]
            kf.x[:] = 0.0


def batched_filter_vs_filterpy() -> dict:
    cfg = _config()
    var = (0.1015 * DEG) ** 2
    rate, ref = _inputs(R_BATCH)
    t_float = best_time_s(lambda: _batched_run("float", cfg, rate, ref, var), repeat=3)
    t_fixed = best_time_s(lambda: _batched_run("fixed", cfg, rate, ref, var), repeat=3)
    t_loop = best_time_s(lambda: _filterpy_run(cfg, rate[:, :R_LOOP], ref[:, :R_LOOP], var), repeat=2)
    steps = STEPS * R_BATCH
    float_rate, fixed_rate, loop_rate = steps / t_float, steps / t_fixed, STEPS * R_LOOP / t_loop
    return {
        "batched_filter_speedup_vs_filterpy": float_rate / loop_rate,
        "batched_fixed_filter_speedup_vs_filterpy": fixed_rate / loop_rate,
        "batched_filter_realization_steps_per_s": float_rate,
        "batched_fixed_filter_realization_steps_per_s": fixed_rate,
        "filterpy_loop_realization_steps_per_s": loop_rate,
        "batched_filter_10k_x10_steps_s": t_float,
        "batched_fixed_filter_10k_x10_steps_s": t_fixed,
        "filterpy_loop_400_x10_steps_s": t_loop,
    }


BENCHMARKS = [fixedpoint_vs_fxpmath, batched_filter_vs_filterpy]
