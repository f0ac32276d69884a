"""Magnetic survey baseline: Monte Carlo of MSA + MCM vectorised over replications vs one at a time.

Figures (HV Survey 4, 81 stations, scenario 3, one start per replication):
* ``msa_mc_300_reps_s``: 300 replications, vectorised in chunks of 100 (the ``nodesim validate`` size);
* ``msa_mc_loop_per_rep_s``: one replication at a time (chunk = 1), time per replication (60 timed);
* ``msa_mc_speedup_vs_loop``: loop time per replication / vectorised time per replication;
* ``msa_single_survey_8_starts_s``: one MSA of HV Survey 4 with 8 starts (the magnetic tool's cost per run).
"""

import numpy as np

from nodesim.bench import best_time_s
from nodesim.ground.magnetic_survey import FieldReference, apply_errors, params_array, tool_readings
from nodesim.ground.msa import msa
from nodesim.ground.msa_montecarlo import HV_SCENARIOS, MonteCarloConfig, run_monte_carlo, run_monte_carlo_loop
from nodesim.ground.msa_surveys import trajectory

REF = FieldReference(51.0, 72.0)
TRUTH = params_array([1.1, 0.95, 1.25], [0.25, 0.295, -0.335])


def magnetic_monte_carlo() -> dict:
    traj = trajectory("hv4")
    base = HV_SCENARIOS[3].__dict__
    vec_cfg = MonteCarloConfig(**{**base, "replications": 300})
    loop_cfg = MonteCarloConfig(**{**base, "replications": 60})
    t_vec = best_time_s(lambda: run_monte_carlo(traj, REF, TRUTH, vec_cfg, progress=False), repeat=3)
    t_loop = best_time_s(lambda: run_monte_carlo_loop(traj, REF, TRUTH, loop_cfg), repeat=1)
    g, b = tool_readings(traj.toolface_deg, traj.inc_deg, traj.azi_deg, REF)
    b_m = apply_errors(b, TRUTH) + 0.0033 * np.random.default_rng(0).standard_normal(b.shape)
    t_one = best_time_s(lambda: msa(g, b_m, REF, n_starts=8), repeat=3)
    per_rep_vec = t_vec / 300
    per_rep_loop = t_loop / 60
    return {
        "msa_mc_300_reps_s": t_vec,
        "msa_mc_loop_per_rep_s": per_rep_loop,
        "msa_mc_speedup_vs_loop": per_rep_loop / per_rep_vec,
        "msa_single_survey_8_starts_s": t_one,
    }


BENCHMARKS = [magnetic_monte_carlo]
