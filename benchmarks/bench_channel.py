"""Channel models: vectorised soil path loss over 1e6 parameter points versus the scalar path in a Python loop.

Figures: ``pathloss_1e6_points_s`` (Peplinski permittivity -> alpha, beta -> thesis eq 5.2 over 1e6 random
(sand, clay, vwc, distance) points in one call), ``pathloss_scalar_loop_1e6_points_s`` (the same function called
once per point on 5,000 points, scaled to 1e6) and their ratio ``pathloss_vectorised_speedup_vs_scalar_loop``.
"""

import numpy as np

from channel.soil import Soil, soil_path_loss
from nodesim.bench import best_time_s

N = 1_000_000
N_LOOP = 5_000


def _points(n: int, seed: int = 5):
    rng = np.random.default_rng(seed)
    sand = rng.uniform(0.05, 0.6, n)
    clay = rng.uniform(0.05, 0.4, n)
    vwc = rng.uniform(0.01, 0.45, n)
    dist = rng.uniform(0.1, 1.0, n)
    return sand, clay, vwc, dist


def soil_pathloss_vectorised() -> dict:
    sand, clay, vwc, dist = _points(N)
    t_vec = best_time_s(lambda: soil_path_loss(868e6, dist, Soil(sand=sand, clay=clay, vwc=vwc)), repeat=3)
    s, c, v, d = (a[:N_LOOP] for a in (sand, clay, vwc, dist))

    def loop():
        for i in range(N_LOOP):
            soil_path_loss(868e6, float(d[i]), Soil(sand=float(s[i]), clay=float(c[i]), vwc=float(v[i])))

    t_loop = best_time_s(loop, repeat=2) * (N / N_LOOP)
    return {
        "pathloss_1e6_points_s": t_vec,
        "pathloss_scalar_loop_1e6_points_s": t_loop,
        "pathloss_vectorised_speedup_vs_scalar_loop": t_loop / t_vec,
    }


BENCHMARKS = [soil_pathloss_vectorised]
