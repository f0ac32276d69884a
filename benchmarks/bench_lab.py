"""Lab simulation: batched realizations versus a loop of single-realization runs (same total work).

Figure ``lab_batched_speedup_vs_loop``: time of R single-realization runs divided by the time of one run
with R realizations.  It shows that Monte Carlo cost is carried by numpy arrays, not SimPy events.
"""

from importlib import resources

from nodesim.bench import chain_batched_vs_loop
from nodesim.scenario.schema import load_scenario

R = 32


def lab_batched_vs_loop() -> dict:
    with resources.as_file(resources.files("scenarios") / "lab" / "continuous.toml") as p:
        base, _ = load_scenario(p)
    return chain_batched_vs_loop(base, R, "lab")


BENCHMARKS = [lab_batched_vs_loop]
