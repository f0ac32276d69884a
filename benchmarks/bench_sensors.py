"""Sensor tools: overlapping Allan variance (cumsum, vectorised) against a naive loop over cluster means.

Figures:
* ``allan_speedup_vs_naive_loop``: naive pure-Python overlapping estimator (explicit cluster means) over a
  10 min record at 65 Hz and a fixed set of cluster sizes, divided by our time on the same input;
* ``allan_2h_65hz_s``: our time for the full 2 h record at 65 Hz (468 001 samples, ~100 cluster sizes);
* ``imu_2h_65hz_generation_s``: simulating that record for three MPU6500 gyro axes (int16 counts).
"""

import numpy as np

from nodesim.sensors.allan import naive_overlapping_adev, overlapping_adev
from nodesim.bench import best_time_s
from nodesim.sensors.catalogue import load_sensor


def allan_vs_naive() -> dict:
    imu = load_sensor("MPU6500").imu_spec()
    k = int(7200 * imu.sample_rate_hz) + 1
    rng = np.random.default_rng(0)
    t_gen = best_time_s(lambda: imu.gyro.measure(np.zeros((k, 3)), rng, imu.dt_s), repeat=2)
    y = imu.gyro.measure(np.zeros((k, 3)), np.random.default_rng(1), imu.dt_s).value[:, 2]
    short = y[: 600 * 65]
    clusters = np.array([1, 2, 5, 10, 20, 50, 100, 200, 500, 1000])
    t_naive = best_time_s(lambda: naive_overlapping_adev(short, imu.dt_s, clusters), repeat=1)
    t_ours = best_time_s(lambda: overlapping_adev(short, imu.dt_s, clusters), repeat=5)
    t_full = best_time_s(lambda: overlapping_adev(y, imu.dt_s), repeat=3)
    return {
        "allan_speedup_vs_naive_loop": t_naive / t_ours,
        "allan_naive_10min_s": t_naive,
        "allan_ours_10min_s": t_ours,
        "allan_2h_65hz_s": t_full,
        "imu_2h_65hz_generation_s": t_gen,
    }


BENCHMARKS = [allan_vs_naive]
