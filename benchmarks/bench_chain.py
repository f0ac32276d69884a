"""Chain simulation: batched realizations versus a loop of single-realization runs, on a 4-tube drilling run.

Figure ``chain_batched_speedup_vs_loop``: time of R single-realization runs divided by the time of one run
with R realizations (same total work): the SimPy event skeleton is shared by the realizations, so
Monte Carlo cost is carried by numpy arrays, not by events.
"""

from importlib import resources

from nodesim.bench import best_time_s
from nodesim.chain import simulate_chain
from nodesim.scenario import load_scenario

R = 8
TUBES = 4


def chain_batched_vs_loop() -> dict:
    with resources.as_file(resources.files("scenarios") / "field" / "drilling_10_tubes.toml") as p:
        base, _ = load_scenario(p)
    duration = base.motion.drilling_duration_s(TUBES)
    short = {"chain.nodes": TUBES, "simulation.duration_s": duration, "metrics.window_end_s": duration}
    single = [base.with_overrides(seed=base.seed + i, **short, **{"simulation.realizations": 1}) for i in range(R)]
    batched = base.with_overrides(**short, **{"simulation.realizations": R})
    t_loop = best_time_s(lambda: [simulate_chain(s) for s in single], repeat=1)
    t_batch = best_time_s(lambda: simulate_chain(batched), repeat=2)
    return {
        "chain_batched_speedup_vs_loop": t_loop / t_batch,
        "chain_loop_8_runs_s": t_loop,
        "chain_batched_8_realizations_s": t_batch,
    }


BENCHMARKS = [chain_batched_vs_loop]
