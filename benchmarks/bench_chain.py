"""Chain simulation: batched realizations versus a loop of single-realization runs, on a 4-tube drilling run.

Figure ``chain_batched_speedup_vs_loop``: time of R single-realization runs divided by the time of one run
with R realizations (same total work): the SimPy event skeleton is shared by the realizations, so
Monte Carlo cost is carried by numpy arrays, not by events.
"""

from importlib import resources

from nodesim.bench import chain_batched_vs_loop
from nodesim.scenario import load_scenario

R = 8
TUBES = 4


def chain_drilling_batched_vs_loop() -> dict:
    with resources.as_file(resources.files("scenarios") / "field" / "drilling_10_tubes.toml") as p:
        base, _ = load_scenario(p)
    duration = base.motion.drilling_duration_s(TUBES)
    short = base.with_overrides(
        **{"chain.nodes": TUBES, "simulation.duration_s": duration, "metrics.window_end_s": duration}
    )
    return chain_batched_vs_loop(short, R, "chain", repeat_loop=1, repeat_batch=2)


BENCHMARKS = [chain_drilling_batched_vs_loop]
