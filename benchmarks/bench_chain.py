"""Chain simulation speed.

* ``chain_batched_speedup_vs_loop``: time of R single-realization runs divided by the time of one run with R
  realizations (same total work) on a 4-tube drilling run.
* ``chain100_1h_overhead_vs_skeleton``: ``scenarios/perf/chain100_1h.toml`` (100 nodes, 1 simulated hour,
  lossy soil hops with the ARQ MAC, fixed-point filters) against a bare SimPy skeleton with the same processes
  and events (one process per node, one timeout per tick at the same times) and no work.  The chain's wall
  time for the hour is EXTRAPOLATED from two short slices (first ``SLICE_S`` simulated seconds: wall(T2) +
  (3600 - T2) x the marginal cost per simulated second between T1 and T2), so the benchmark stays short; the
  skeleton runs the full hour.  Keys: ``chain100_1h_wall_s_extrapolated``, ``chain100_skeleton_1h_s``,
  ``chain100_1h_overhead_vs_skeleton`` (ratio; goal <= 3), ``chain100_events_per_s``.
* ``batched_mc_speedup``: R = 1000 realizations of a 20-node chain (the perf chain's links, float filters,
  ``MC_DURATION_S`` simulated) in one batched run versus one by one; the one-by-one time is EXTRAPOLATED
  from ``MC_SAMPLE`` single runs (first_realization = 0..MC_SAMPLE-1) x 1000 / MC_SAMPLE.  Goal >= 20.
"""

from importlib import resources

import simpy

from nodesim.bench import best_time_s, chain_batched_vs_loop
from nodesim.scenario import load_scenario

R = 8
TUBES = 4
HOUR_S = 3600.0
SLICE_S = (60.0, 120.0)
MC_R = 1000
MC_NODES = 20
MC_DURATION_S = 120.0
MC_SAMPLE = 5


def _scenario(folder: str, name: str):
    with resources.as_file(resources.files("scenarios") / folder / name) as p:
        return load_scenario(p)[0]


def chain_drilling_batched_vs_loop() -> dict:
    base = _scenario("field", "drilling_10_tubes.toml")
    duration = base.motion.drilling_duration_s(TUBES)
    short = base.with_overrides(
        **{"chain.nodes": TUBES, "simulation.duration_s": duration, "metrics.window_end_s": duration}
    )
    return chain_batched_vs_loop(short, R, "chain", repeat_loop=1, repeat_batch=2)


def skeleton(scenario) -> int:
    """The chain's SimPy structure without work: one process per node, one timeout per tick."""
    from nodesim.chain.faults import stepped_ticks
    from nodesim.chain.network import node_clock, tick_times

    env = simpy.Environment()
    dt = 1.0 / scenario.chain.firmware_rate_hz
    count = [0]

    def node(times):
        for t in times:
            yield env.timeout(t - env.now)
            count[0] += 1

    for i in range(scenario.chain.nodes):
        t = tick_times(*node_clock(scenario, i + 1), dt, scenario.simulation.duration_s)
        env.process(node(stepped_ticks(scenario, i + 1, t, scenario.simulation.duration_s)))
    env.run()
    return count[0]


def _sliced(scenario, duration_s: float):
    return scenario.with_overrides(**{"simulation.duration_s": duration_s, "metrics.window_start_s": 0.0,
                                      "metrics.window_end_s": duration_s})


def chain100_1h_overhead_vs_skeleton() -> dict:
    from nodesim.chain import simulate_chain

    perf = _scenario("perf", "chain100_1h.toml")
    walls, events = [], 0
    for t in SLICE_S:
        s = _sliced(perf, t)
        walls.append(best_time_s(lambda: simulate_chain(s), repeat=1))
    run = simulate_chain(_sliced(perf, SLICE_S[0]))
    assert run.simpy_events == skeleton(_sliced(perf, SLICE_S[0])), "skeleton and chain must share the events"
    marginal = (walls[1] - walls[0]) / (SLICE_S[1] - SLICE_S[0])
    chain_1h = walls[1] + (HOUR_S - SLICE_S[1]) * marginal
    t_skel = best_time_s(lambda: skeleton(perf), repeat=2)
    events = skeleton(perf)
    return {
        "chain100_1h_overhead_vs_skeleton": chain_1h / t_skel,
        "chain100_1h_wall_s_extrapolated": chain_1h,
        "chain100_slice_120s_wall_s": walls[1],
        "chain100_skeleton_1h_s": t_skel,
        "chain100_1h_events": events,
        "chain100_events_per_s": events / chain_1h,
    }


def batched_mc_speedup() -> dict:
    from nodesim.chain import simulate_chain

    base = _sliced(_scenario("perf", "chain100_1h.toml"), MC_DURATION_S).with_overrides(
        **{"chain.nodes": MC_NODES, "filter.implementation": "float"})
    singles = [base.with_overrides(**{"simulation.first_realization": r}) for r in range(MC_SAMPLE)]
    t_one = best_time_s(lambda: [simulate_chain(s) for s in singles], repeat=1) / MC_SAMPLE
    batched = base.with_overrides(**{"simulation.realizations": MC_R})
    t_batch = best_time_s(lambda: simulate_chain(batched), repeat=1)
    return {
        "batched_mc_speedup": t_one * MC_R / t_batch,
        "batched_mc_1000_realizations_s": t_batch,
        "batched_mc_one_by_one_1000_s_extrapolated": t_one * MC_R,
        "batched_mc_single_run_s": t_one,
    }


BENCHMARKS = [chain_drilling_batched_vs_loop, chain100_1h_overhead_vs_skeleton, batched_mc_speedup]
