"""The chain IMU's two sampling modes (nodesim.sensors.chain_imu, ``[sensor] sampling``), timed on whole runs.

- ``tick_sum_speedup_vs_per_sample``: ``scenarios/perf/chain100_1h.toml`` (100 nodes, 1 simulated hour, compiled
  engine) with ``sampling = "per_sample"`` (every int16 sample at 65 Hz drawn, quantised and summed) over the same
  run with ``"tick_sum"`` (each tick's sum drawn directly): ratio of the minima of ``REPEAT`` interleaved whole runs
  (simulation core, no outputs), after one warm-up run of each; minima and medians reported under ``*_s``.
- ``chain_imu_node_hour_tick_sum_s`` / ``..._per_sample_s``: the sensor model alone for one node-hour
  (:func:`nodesim.chain.sensing.node_signals`), best of ``REPEAT``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from nodesim.bench import best_time_s

ROOT = Path(__file__).resolve().parents[1]
REPEAT = 3


def tick_sum_speedup_vs_per_sample() -> dict:
    from nodesim.chain.network import simulate_chain
    from nodesim.scenario.schema import load_scenario

    fast, _ = load_scenario(ROOT / "scenarios" / "perf" / "chain100_1h.toml")
    fast = fast.with_overrides(**{"sensor.model": "mpu6500_counts"})
    slow = fast.with_overrides(**{"sensor.sampling": "per_sample"})
    simulate_chain(fast)
    simulate_chain(slow)
    t_fast, t_slow = [], []
    for _ in range(REPEAT):
        t_fast.append(best_time_s(lambda: simulate_chain(fast), repeat=1))
        t_slow.append(best_time_s(lambda: simulate_chain(slow), repeat=1))
    return {
        "tick_sum_speedup_vs_per_sample": min(t_slow) / min(t_fast),
        "chain100_1h_tick_sum_s": min(t_fast),
        "chain100_1h_tick_sum_median_s": float(np.median(t_fast)),
        "chain100_1h_per_sample_s": min(t_slow),
        "chain100_1h_per_sample_median_s": float(np.median(t_slow)),
    }


def chain_imu_node_hour() -> dict:
    from nodesim.chain.network import node_clock, tick_times
    from nodesim.chain.sensing import node_signals
    from nodesim.motion.chain_motion import build_motion
    from nodesim.rng.streams import RunStreams
    from nodesim.scenario.schema import Scenario

    out = {}
    for mode in ("tick_sum", "per_sample"):
        s = Scenario().with_overrides(**{"simulation.duration_s": 3600.0, "sensor.model": "mpu6500_counts", "sensor.sampling": mode})
        motion, streams = build_motion(s), RunStreams(s.seed, 1)
        dt = 1.0 / s.chain.firmware_rate_hz
        offset, drift = node_clock(s, 1)
        t = tick_times(offset, drift, dt, 3600.0)
        out[f"chain_imu_node_hour_{mode}_s"] = best_time_s(lambda: node_signals(s, motion, streams, 0, t, dt),
                                                           repeat=REPEAT)
    return out


BENCHMARKS = [tick_sum_speedup_vs_per_sample, chain_imu_node_hour]
