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
- ``fixed_kernel_speedup_vs_numpy_r1``: 2000 predict+update steps of one fixed-point filter (R = 1) through
  ``FixedYawFilter`` over the same steps through the numba kernels of ``firmware_model.fixed_kernel``
  in an njit loop (warmed up first); ``fixed_kernel_bits_equal`` is 1.0 when both end in the same raws and
  overflow counts; ``fixed_kernel_compile_s`` the kernels' first call in a fresh process with an empty numba
  cache (compilation from scratch; later processes load the on-disk cache).
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
import tempfile

import numpy as np
from numba import njit

from firmware_model import fixedpoint as fp
from firmware_model.fixedpoint import Overflow, QFormat, Rounding
from firmware_model.filter_factory import make_yaw_filter
from firmware_model.yaw_filter import YawFilterConfig, wrap_pi
from nodesim.bench import best_time_s
from firmware_model import fixed_kernel as fk
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
        raise NodesimError("benchmark fixedpoint_vs_fxpmath needs fxpmath: pip install -e '.[bench]'") from exc
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
    try:
        from filterpy.kalman import KalmanFilter  # a bench dependency (pyproject [bench] extra), not a runtime one
    except ImportError as exc:
        raise NodesimError("benchmark batched_filter_vs_filterpy needs filterpy: pip install -e '.[bench]'") from exc
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


KERNEL_STEPS = 2000
_COMPILE_PROBE = """
import time
import numpy as np
t0 = time.perf_counter()
from firmware_model.fixed_filter import FixedYawFilter
from firmware_model.yaw_filter import YawFilterConfig
from firmware_model import fixed_kernel as fk
kf = FixedYawFilter(YawFilterConfig(dt_s=0.5, arw_rad_per_sqrt_s=1e-4, bias_instability_rad_s=1e-5, bias_tau_s=500.0), 1)
params, state, counts = fk.kernel_params(kf), fk.lane_states(kf)[0], np.zeros(len(fk.SITES), dtype=np.int64)
t1 = time.perf_counter()
fk.predict(state, 0.01, params, counts)
fk.update(state, 0.1, 1e-6, params, counts)
fk.yaw_rad(state, params), fk.bias_rad_s(state, params), fk.yaw_variance_rad2(state, params)
print(time.perf_counter() - t1)
"""


@njit
def _kernel_steps(state, rate, ref, var, params, counts):
    for k in range(rate.size):
        fk.predict(state, rate[k], params, counts)
        fk.update(state, ref[k], var, params, counts)


def _class_steps(cfg, rate, ref, var):
    kf = make_yaw_filter("fixed", cfg, 1)
    for k in range(rate.size):
        kf.predict(rate[k])
        kf.update(ref[k], var)
    return kf


def fixed_kernel_vs_numpy() -> dict:
    cfg = _config()
    var = (0.1015 * DEG) ** 2
    rng = np.random.default_rng(2)
    rate = 3.6 * DEG + 0.01 * DEG * rng.standard_normal(KERNEL_STEPS)
    ref = np.cumsum(np.full(KERNEL_STEPS, 3.6 * DEG / 1.9)) + 0.1 * DEG * rng.standard_normal(KERNEL_STEPS)
    kf0 = make_yaw_filter("fixed", cfg, 1)
    params, counts0 = fk.kernel_params(kf0), dict(kf0.overflow_counts)
    state, counts = fk.lane_states(kf0)[0].copy(), np.zeros(len(fk.SITES), dtype=np.int64)
    _kernel_steps(state, rate, ref, var, params, counts)  # warm-up: compiles the loop (and loads the kernels)
    kf = _class_steps(cfg, rate, ref, var)
    new_counts = {k: v - counts0.get(k, 0) for k, v in kf.overflow_counts.items() if v != counts0.get(k, 0)}
    same = bool((fk.lane_states(kf)[0] == state).all() and fk.counts_dict(counts) == new_counts)

    def kernel_run():
        s, c = fk.lane_states(kf0)[0].copy(), np.zeros(len(fk.SITES), dtype=np.int64)
        _kernel_steps(s, rate, ref, var, params, c)

    t_class = best_time_s(lambda: _class_steps(cfg, rate, ref, var), repeat=3)
    t_kernel = best_time_s(kernel_run, repeat=7, number=5)
    with tempfile.TemporaryDirectory() as cache:
        probe = subprocess.run([sys.executable, "-c", _COMPILE_PROBE], capture_output=True, text=True, check=True,
                               env={**os.environ, "NUMBA_CACHE_DIR": cache})
    return {
        "fixed_kernel_speedup_vs_numpy_r1": t_class / t_kernel,
        "fixed_kernel_bits_equal": float(same),
        "fixed_kernel_compile_s": float(probe.stdout.split()[-1]),
        "fixed_filter_r1_2000_steps_s": t_class,
        "fixed_kernel_r1_2000_steps_s": t_kernel,
    }


BENCHMARKS = [fixedpoint_vs_fxpmath, batched_filter_vs_filterpy, fixed_kernel_vs_numpy]
