"""Lab simulation: batched realizations versus a loop of single-realization runs (same total work).

Figure ``lab_batched_speedup_vs_loop``: time of R single-realization runs divided by the time of one run
with R realizations.  It shows that Monte Carlo cost is carried by numpy arrays, not SimPy events.
"""

from importlib import resources

from nodesim.bench import best_time_s
from nodesim.scenario import load_scenario
from nodesim.chain import simulate_chain

R = 32


def lab_batched_vs_loop() -> dict:
    with resources.as_file(resources.files("scenarios") / "lab" / "continuous.toml") as p:
        base, _ = load_scenario(p)
    single = [base.with_overrides(seed=base.seed + i, **{"simulation.realizations": 1}) for i in range(R)]
    batched = base.with_overrides(**{"simulation.realizations": R})
    t_loop = best_time_s(lambda: [simulate_chain(s) for s in single], repeat=2)
    t_batch = best_time_s(lambda: simulate_chain(batched), repeat=3)
    return {
        "lab_batched_speedup_vs_loop": t_loop / t_batch,
        "lab_loop_32_runs_s": t_loop,
        "lab_batched_32_realizations_s": t_batch,
    }


BENCHMARKS = [lab_batched_vs_loop]
