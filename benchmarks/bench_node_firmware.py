"""The node firmware pipeline's cost (firmware_model.node_firmware), measured in the same run as its baselines.

- ``firmware_tick_ns``: one lane's :func:`node_tick` (gyro read, predict, a forwarded update with the eq 3.29
  advance and R on every tick: the firmware's most expensive tick) in an njit loop of 10^6 ticks, ns per tick;
  ``firmware_predict_only_tick_ns`` the same with no reference (a timeout tick).
- ``firmware_chain100_1h_fixed_s`` / ``firmware_chain100_1h_float_s``: the whole compiled-engine run of
  ``scenarios/perf/chain100_1h.toml`` (simulation core, no outputs) with the fixed-point firmware and with the
  float reference filter, best of 3 each, interleaved; ``firmware_chain100_1h_node_tick_ns`` the fixed run per
  node-tick (MAC and sensors included).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from numba import njit

from firmware_model import node_firmware as nf
from firmware_model.config import FirmwareConfig
from firmware_model.fixed_filter import FixedFormats
from firmware_model.yaw_filter import YawFilterConfig
from nodesim.bench import best_time_s

TICKS = 1_000_000
DEG = math.pi / 180.0
ROOT = Path(__file__).resolve().parents[1]


@njit(cache=True)
def _ticks(state, params, fparams, counts, inp, out, n):
    for k in range(n):
        inp[nf.IN_GZ] = 4454 + (k & 7)
        nf.node_tick(state, params, fparams, counts, inp, out)


def _config() -> FirmwareConfig:
    f = YawFilterConfig(dt_s=1 / 1.9, arw_rad_per_sqrt_s=7.38e-3 * DEG, bias_instability_rad_s=3.33e-3 * DEG,
                        bias_tau_s=500.0, tuning_a=1.0, tuning_b=5.0)
    return FirmwareConfig(filter=f, formats=FixedFormats(), sigma_rate_rad_s=0.08 * DEG)


def firmware_tick_cost() -> dict:
    cfg = _config()
    p, fp = cfg.params(), cfg.filter_params()
    figures = {}
    for name, kind in (("firmware_tick_ns", nf.FORWARDED_REF), ("firmware_predict_only_tick_ns", nf.NO_REF)):
        st, counts = np.zeros(nf.STATE_SIZE, np.int64), np.zeros(len(nf.SITES), np.int64)
        inp, out = np.zeros(len(nf.INPUTS), np.int64), np.zeros(len(nf.OUTPUTS), np.int64)
        nf.init_lane(st)
        inp[nf.IN_PHASE], inp[nf.IN_N] = nf.START, 34
        nf.node_tick(st, p, fp, counts, inp, out)
        inp[nf.IN_PHASE], inp[nf.IN_REF], inp[nf.IN_REF_YAW] = nf.RUN, kind, 123456789
        inp[nf.IN_REF_AUX], inp[nf.IN_TRANSFER] = 1 << 20, 20_000
        _ticks(st, p, fp, counts, inp, out, 10)  # compile / load
        figures[name] = best_time_s(lambda: _ticks(st, p, fp, counts, inp, out, TICKS), repeat=5) / TICKS * 1e9
    return figures


def firmware_chain100_1h() -> dict:
    from nodesim.chain.network import simulate_chain
    from nodesim.scenario.schema import load_scenario

    fixed, _ = load_scenario(ROOT / "scenarios" / "perf" / "chain100_1h.toml")
    flt = fixed.with_overrides(**{"filter.implementation": "float"})
    run = simulate_chain(fixed)
    simulate_chain(flt)
    t_fixed, t_float = [], []
    for _ in range(3):
        t_fixed.append(best_time_s(lambda: simulate_chain(fixed), repeat=1))
        t_float.append(best_time_s(lambda: simulate_chain(flt), repeat=1))
    node_ticks = sum(int(np.count_nonzero(n.yaw_est_rad.shape[-1])) * n.yaw_est_rad.shape[-1] for n in run.nodes)
    return {
        "firmware_chain100_1h_fixed_s": min(t_fixed),
        "firmware_chain100_1h_fixed_median_s": float(np.median(t_fixed)),
        "firmware_chain100_1h_float_s": min(t_float),
        "firmware_chain100_1h_float_median_s": float(np.median(t_float)),
        "firmware_chain100_1h_node_tick_ns": min(t_fixed) / node_ticks * 1e9,
    }


BENCHMARKS = [firmware_tick_cost, firmware_chain100_1h]
