"""Chain simulation speed.

* ``chain_batched_speedup_vs_loop``: time of R single-realization runs divided by the time of one run with R
  realizations (same total work) on a 4-tube drilling run (SimPy engine: drilling runs there).
* ``chain100_1h_overhead_vs_skeleton``: ``scenarios/perf/chain100_1h.toml`` (100 nodes, 1 simulated hour,
  lossy soil hops with the ARQ MAC, fixed-point filters) on the default engine (compiled: lab motion), the
  full hour measured, against a bare SimPy skeleton of a process-per-node chain with stop-and-wait ARQ and no
  work (:func:`skeleton`: the same node-ticks, one frame per tick to the next node; within ~10 % of
  ../shared/tools/simpy_skeleton.py's time, docs/benchmarks.md).  Goal <= 3.
  ``chain100_1h_end_to_end_vs_skeleton``: the whole ``nodesim run`` process of that scenario (default outputs)
  against the whole skeleton process (``python benchmarks/bench_chain.py skeleton``), min of ``E2E_REPEAT``
  each; goal <= 0.5.  The compiled engine's first call in a
  process loads (or, on a fresh machine, compiles) its numba code: timed apart as ``chain_compiled_warmup_s``.
  The SimPy engine's hour is EXTRAPOLATED from two short slices (first ``SLICE_S`` simulated seconds:
  wall(T2) + (3600 - T2) x the marginal cost per simulated second between T1 and T2):
  ``chain100_1h_event_engine_overhead_vs_skeleton`` and ``chain100_compiled_speedup_vs_event_engine``.
* ``batched_mc_speedup``: R = 1000 realizations of a 20-node chain (the perf chain's links, float filters,
  ``MC_DURATION_S`` simulated) in one batched run versus one by one, on the default (compiled) engine; the
  one-by-one side runs all 1000 single runs (first_realization = 0..999: ~20 s a repetition), not a sample
  scaled up (until 2026-12-05 it was EXTRAPOLATED from 5 runs x 200).  Goal >= 20.  Each side is timed after a
  warm-up call of its own kind, best of ``MC_REPEAT``; the
  batched run's first call (fresh memory) is reported too (``batched_mc_speedup_first_call``).  The batch runs
  its realizations on every CPU this process may use (``batched_mc_threads``, :mod:`nodesim.threads`), as a
  user's ``--realizations`` run does; a single run puts its nodes' sensors and surveys on every CPU too.
  ``batched_mc_speedup_one_thread``: the same batch and the same single runs on one thread (``threads.limited(1)``, as
  ``NODESIM_THREADS=1`` would; what batching alone buys).
  ``batched_mc_speedup_event_engine``: the same on the SimPy engine, whose one-by-one side is EXTRAPOLATED from
  ``MC_SAMPLE`` single runs x 1000 / MC_SAMPLE (its 1000 runs would take ~10 min: 0.5-0.6 s each).
* ``drilling_day_1000_*``: :func:`drilling_day_1000` (the whole day of a 1000-tube string, run, not
  extrapolated; it replaced the 1000-node 24 h extrapolation of earlier benchmarks once streamed runs could run it).
"""

import os
import shutil
from importlib import resources
from pathlib import Path

import numpy as np
import simpy

from nodesim import threads
from nodesim.bench import best_time_s, best_times_s, chain_batched_vs_loop
from nodesim.scenario.schema import load_scenario

R = 8
TUBES = 4
HOUR_S = 3600.0
SLICE_S = (60.0, 120.0)
MC_R = 1000
MC_NODES = 20
MC_DURATION_S = 120.0
MC_SAMPLE = 5  # the SimPy engine's single runs, scaled up to MC_R (the compiled engine's are all run)
MC_REPEAT = 5  # best of: this host's timings of the same call vary by up to 2x


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


SKELETON_LOSS = 0.1
"""Per-try frame loss of the ARQ skeleton (the perf chain's soil hops lose ~10 % of tries)."""


def skeleton(scenario) -> int:
    """The chain's SimPy structure with no work: one process per node ticking at the node's tick times (from its
    insertion on, in a drilling run, as the chain's nodes do); on each
    tick the node sends one frame to the next node with stop-and-wait ARQ (a process per frame: airtime, then an
    ACK and a put into the next node's inbox, or the ACK timeout and another try, up to 1 + mac.max_retries tries,
    each lost with probability SKELETON_LOSS) and one sink process per inbox takes the frames.  This is the event
    structure of a process-per-node SimPy chain (../shared/tools/simpy_skeleton.py, the floor such a design
    reaches), timed against it in docs/benchmarks.md.  Returns the node-ticks."""
    import random

    from nodesim.chain.faults import stepped_ticks
    from nodesim.chain.network import node_clock, tick_times
    from nodesim.motion.chain_motion import build_motion

    env = simpy.Environment()
    dt = 1.0 / scenario.chain.firmware_rate_hz
    n = scenario.chain.nodes
    m = scenario.mac
    air_s = m.data_frame_bits / scenario.radio.bit_rate_bps  # the estimate frame on air
    ack_s = m.ack_bits / scenario.radio.bit_rate_bps
    tries = 1 + m.max_retries
    rng = random.Random(scenario.seed)
    inbox = [simpy.Store(env) for _ in range(n + 1)]
    count = [0]

    def send(i, frame):
        for _ in range(tries):
            yield env.timeout(air_s)
            if rng.random() >= SKELETON_LOSS:
                yield env.timeout(ack_s)
                yield inbox[i + 1].put(frame)
                return
            yield env.timeout(m.ack_timeout_s)

    def node(i, times):
        for t in times:
            yield env.timeout(t - env.now)
            count[0] += 1
            env.process(send(i, (i, t)))

    def sink(i):
        while True:
            yield inbox[i].get()

    present = [tl.present_from_s for tl in build_motion(scenario).timelines]  # drilling: a node ticks once inserted
    for i in range(n):
        t = tick_times(*node_clock(scenario, i + 1), dt, scenario.simulation.duration_s)
        t = stepped_ticks(scenario, i + 1, t, scenario.simulation.duration_s)
        env.process(node(i, t[t >= present[i]]))
        env.process(sink(i + 1))
    env.run(until=scenario.simulation.duration_s + 1.0)
    return count[0]


def _sliced(scenario, duration_s: float):
    return scenario.with_overrides(**{"simulation.duration_s": duration_s, "metrics.window_start_s": 0.0,
                                      "metrics.window_end_s": duration_s})


def _event_engine(scenario):
    return scenario.with_overrides(**{"simulation.engine": "event"})


def chain100_1h_overhead_vs_skeleton() -> dict:
    from nodesim.chain.network import simulate_chain

    perf = _scenario("perf", "chain100_1h.toml")
    warmup = best_time_s(lambda: simulate_chain(_sliced(perf, 60.0).with_overrides(**{"chain.nodes": 3})), repeat=1)
    run = simulate_chain(perf)
    assert run.engine == "compiled" and run.simpy_events == skeleton(perf), "same engine and node-ticks as the skeleton"
    wall = best_time_s(lambda: simulate_chain(perf), repeat=2)
    walls = [best_time_s(lambda: simulate_chain(_event_engine(_sliced(perf, t))), repeat=1) for t in SLICE_S]
    marginal = (walls[1] - walls[0]) / (SLICE_S[1] - SLICE_S[0])
    event_1h = walls[1] + (HOUR_S - SLICE_S[1]) * marginal
    t_skel = best_time_s(lambda: skeleton(perf), repeat=2)
    e2e_run, e2e_skel = _end_to_end(perf)
    return {
        "chain100_1h_end_to_end_vs_skeleton": e2e_run / e2e_skel,
        "chain100_1h_end_to_end_run_s": e2e_run,
        "chain100_1h_end_to_end_skeleton_s": e2e_skel,
        "chain100_1h_overhead_vs_skeleton": wall / t_skel,
        "chain100_1h_wall_s": wall,
        "chain100_skeleton_1h_s": t_skel,
        "chain100_1h_events": run.simpy_events,
        "chain100_events_per_s": run.simpy_events / wall,
        "chain_compiled_warmup_s": warmup,
        "chain100_1h_event_engine_wall_s_extrapolated": event_1h,
        "chain100_1h_event_engine_overhead_vs_skeleton": event_1h / t_skel,
        "chain100_compiled_speedup_vs_event_engine": event_1h / wall,
    }


E2E_REPEAT = 2


def _end_to_end(perf) -> tuple[float, float]:
    """(whole ``nodesim run`` process, whole skeleton process) wall times [s] for the perf chain, min of
    ``E2E_REPEAT`` each, interleaved."""
    import subprocess
    import sys
    import tempfile
    import time
    from pathlib import Path

    with resources.as_file(resources.files("scenarios") / "perf" / "chain100_1h.toml") as path:
        runs, skels = [], []
        for _ in range(E2E_REPEAT):
            with tempfile.TemporaryDirectory() as tmp:
                t = time.perf_counter()
                subprocess.run([sys.executable, "-m", "nodesim.cli.main", "run", str(path), "--out",
                                str(Path(tmp) / "run"), "--quiet", "--json"], check=True, stdout=subprocess.DEVNULL)
                runs.append(time.perf_counter() - t)
            t = time.perf_counter()
            subprocess.run([sys.executable, __file__, "skeleton", str(path)], check=True, stdout=subprocess.DEVNULL)
            skels.append(time.perf_counter() - t)
    return min(runs), min(skels)


def _batched_vs_one_by_one(base, repeat: int, one_thread: bool = True, sample: int = MC_R) -> tuple[float, ...]:
    """(one-by-one time for MC_R realizations, batched time, single-run time, the batched run's first call, batched
    time on one thread and the one-by-one time on one thread (NaN unless ``one_thread``)).  The one-by-one side
    runs ``sample`` single runs (first_realization = 0 .. sample - 1), scaled by MC_R / ``sample`` (1: all run).
    Each is timed after a warm-up call of its own kind (what timeit does), best of ``repeat`` (the same for every
    side), the two sides' calls interleaved (:func:`nodesim.bench.best_times_s`: each side sees the same minutes of
    a host whose speed drifts): the first batched call in a process also pays the first touch of its ~0.5 GB of
    fresh arrays, kept apart."""
    from nodesim.chain.network import simulate_chain

    singles = [base.with_overrides(**{"simulation.first_realization": r}) for r in range(sample)]
    batched = base.with_overrides(**{"simulation.realizations": MC_R})
    simulate_chain(singles[0])  # warm (the compiled engine's first call loads its code)
    t_first = best_time_s(lambda: simulate_chain(batched), repeat=1)
    t_one, t_batch = best_times_s([lambda: [simulate_chain(s) for s in singles], lambda: simulate_chain(batched)],
                                  repeat=repeat)
    t_one /= sample
    t_batch_1 = t_one_1 = float("nan")
    if one_thread:  # both sides on one thread (a single-realization run puts its nodes on every CPU otherwise)
        with threads.limited(1):
            t_one_1, t_batch_1 = best_times_s([lambda: [simulate_chain(s) for s in singles],
                                               lambda: simulate_chain(batched)], repeat=repeat)
            t_one_1 /= sample
    return t_one * MC_R, t_batch, t_one, t_first, t_batch_1, t_one_1 * MC_R


def batched_mc_speedup() -> dict:
    base = _sliced(_scenario("perf", "chain100_1h.toml"), MC_DURATION_S).with_overrides(
        **{"chain.nodes": MC_NODES, "filter.implementation": "float"})
    one, batch, single, first, batch_1, one_1 = _batched_vs_one_by_one(base, repeat=MC_REPEAT)
    with threads.limited(1):  # the SimPy engine's batch is numpy over realizations, ~10 s a side
        one_ev, batch_ev, single_ev, _, _, _ = _batched_vs_one_by_one(_event_engine(base), 1, False, MC_SAMPLE)
    return {
        "batched_mc_speedup": one / batch,
        "batched_mc_speedup_one_thread": one_1 / batch_1,
        "batched_mc_one_by_one_1000_one_thread_s": one_1,
        "batched_mc_threads": len(threads.chunks(MC_R)),
        "batched_mc_speedup_first_call": one / first,
        "batched_mc_1000_realizations_s": batch,
        "batched_mc_1000_realizations_one_thread_s": batch_1,
        "batched_mc_1000_realizations_first_call_s": first,
        "batched_mc_one_by_one_1000_s": one,
        "batched_mc_single_run_s": single,
        "batched_mc_speedup_event_engine": one_ev / batch_ev,
        "batched_mc_1000_realizations_event_engine_s": batch_ev,
        "batched_mc_single_run_event_engine_s": single_ev,
        "batched_mc_one_by_one_1000_event_engine_s_extrapolated": one_ev,
    }


DAY_HOURS = {1: 793, 2: 802}
"""The drilling day's first hour and first two hours as runs of their own: the 785 tubes in the hole and the 8 (17)
new ones the hour (two hours) inserts; with 400 s per new tube their programmes end at exactly 3600 s (7200 s)."""


def _day_slice(tmp: Path, hours: int) -> Path:
    with resources.as_file(resources.files("scenarios") / "perf" / "drilling_day_1000.toml") as p:
        text = p.read_text()
    end = 3600.0 * hours
    for a, b in (("nodes = 1000", f"nodes = {DAY_HOURS[hours]}"), ("duration_s = 86400.0", f"duration_s = {end}"),
                 ("window_end_s = 86400.0", f"window_end_s = {end}")):
        assert a in text, a
        text = text.replace(a, b)
    path = tmp / f"drilling_{hours}h.toml"
    path.write_text(text)
    return path


PEAK = ("import os, sys\nfrom nodesim.cli.main import console\ncode = console(sys.argv[1:])\n"
        "hwm = [l for l in open('/proc/self/status') if l.startswith('VmHWM:')][0].split()[1]\n"
        "print('peak_kib', hwm, file=sys.stderr)\nprint('cpu_s', sum(os.times()[:2]), file=sys.stderr)\n"
        "sys.exit(code)")


def _process(args: list[str]) -> tuple[float, float, str, float]:
    """(wall [s], peak RSS [bytes], stdout, CPU [s]) of a whole Python process ``python ARGS``; the peak and the
    CPU (user + system, every thread) are the process's own VmHWM and ``os.times()`` where it prints them
    (:data:`PEAK`), else NaN."""
    import subprocess
    import sys
    import time

    t = time.perf_counter()
    proc = subprocess.run([sys.executable, *args], capture_output=True, text=True, check=False)
    wall = time.perf_counter() - t
    if proc.returncode:
        raise RuntimeError(f"python {' '.join(args[-6:])} failed: {proc.stderr[-2000:]}")
    peak = [float(x.split()[1]) * 1024.0 for x in proc.stderr.splitlines() if x.startswith("peak_kib ")]
    cpu = [float(x.split()[1]) for x in proc.stderr.splitlines() if x.startswith("cpu_s ")]
    return wall, peak[0] if peak else float("nan"), proc.stdout, cpu[0] if cpu else float("nan")


SKELETON_RUNS = 2
"""The chain100 skeleton is timed this many times in :func:`drilling_day_1000`; its rate is taken from the fastest."""


def _day_rate_vs_skeleton(day_wall_s: float, day_node_ticks: int) -> dict:
    """``drilling_day_node_ticks_per_s_vs_skeleton`` as issue 20 defines it: the day's node-ticks per second (its
    node-ticks over the wall time of its whole ``nodesim run`` process, outputs included) over the node-ticks per
    second of the bare SimPy skeleton of ``chain100_1h_overhead_vs_skeleton`` (:func:`skeleton` of
    ``scenarios/perf/chain100_1h.toml``: 100 nodes, one hour), timed here, in the same run, in this process (no
    process start or imports on its side), the fastest of :data:`SKELETON_RUNS`.  NaN when the day did not run."""
    perf = _scenario("perf", "chain100_1h.toml")
    ticks = []
    wall = best_time_s(lambda: ticks.append(skeleton(perf)), repeat=SKELETON_RUNS)
    skel_rate, day_rate = ticks[-1] / wall, day_node_ticks / day_wall_s
    return {"drilling_day_node_ticks_per_s": day_rate, "drilling_day_skeleton_node_ticks_per_s": skel_rate,
            "drilling_day_skeleton_wall_s": wall, "drilling_day_skeleton_node_ticks": ticks[-1],
            "drilling_day_node_ticks_per_s_vs_skeleton": day_rate / skel_rate}


DAY_RUNS = 3
"""The whole day is timed this many times: ``drilling_day_1000_wall_s`` the median, ``_wall_min_s`` the min, every
wall in ``_walls_s``; its peak RSS the largest of them."""


HOUR_RUNS = 3
"""The day's first hour is timed this many times (its wall the median, ``_wall_min_s`` the min); the skeleton's
hour (~2 min) once."""


def drilling_day_1000() -> dict:
    """``scenarios/perf/drilling_day_1000.toml`` (issue 20): the whole day, :data:`DAY_RUNS` whole ``nodesim run``
    processes with default outputs (streamed: wall, peak RSS), if the memory guard lets it run here, else its
    estimate; then its first hour and first two hours the same way, the hour against the bare SimPy skeleton
    process with the same node-ticks (``drilling_day_first_1h_node_ticks_per_s_vs_skeleton``: the same work on each
    side; the skeleton's whole day would take ~45 min); the day's node-ticks per second against the chain100 skeleton's
    (:func:`_day_rate_vs_skeleton`, issue 20's ``drilling_day_node_ticks_per_s_vs_skeleton``); and
    ``drilling_10_tubes`` on both engines."""
    import json
    import tempfile

    from nodesim.chain.compiled.engine import choose_engine
    from nodesim.chain.memory_budget import available_memory_bytes, estimate_run_memory
    from nodesim.chain.network import simulate_chain

    day = _scenario("perf", "drilling_day_1000.toml")
    need = estimate_run_memory(day, choose_engine(day), streamed=True)  # nodesim run streams
    out = {"drilling_day_1000_estimated_peak_gb": need.total_bytes / 1e9, "drilling_day_1000_node_ticks": need.node_ticks}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        available = available_memory_bytes()
        if available is not None and need.total_bytes > available:
            out["drilling_day_1000_wall_s"] = float("nan")  # refused by the memory guard: not run, not extrapolated
        else:
            walls, peaks, cpus = [], [], []
            with resources.as_file(resources.files("scenarios") / "perf" / "drilling_day_1000.toml") as p:
                for _ in range(DAY_RUNS):
                    wall, peak, text, cpu = _process(["-c", PEAK, "run", str(p), "--out", str(tmp / "day"), "--quiet",
                                                      "--json"])
                    walls.append(wall)
                    peaks.append(peak)
                    cpus.append(cpu)
                    shutil.rmtree(tmp / "day")  # its 4.4 GB table, flushed to disk before the next process is timed
                    os.sync()
            out["drilling_day_1000_wall_s"] = float(np.median(walls))
            out["drilling_day_1000_wall_min_s"], out["drilling_day_1000_walls_s"] = min(walls), walls
            out["drilling_day_1000_peak_rss_gb"] = max(peaks) / 1e9
            out["drilling_day_1000_cpu_s"], out["drilling_day_1000_cpus_s"] = float(np.median(cpus)), cpus  # user +
            # system of the same processes: what two cores share (the wall is at least half of it)
            out["drilling_day_1000_node_ticks"] = int(json.loads(text)["simpy_events"])  # run's own count
        for hours in DAY_HOURS:
            path = _day_slice(tmp, hours)
            walls = []
            for i in range(HOUR_RUNS if hours == 1 else 1):
                wall, peak, text, _ = _process(["-c", PEAK, "run", str(path), "--out", str(tmp / f"run{hours}_{i}"),
                                                "--quiet", "--json"])
                walls.append(wall)
            wall = float(np.median(walls))
            ticks = int(json.loads(text)["simpy_events"])
            out[f"drilling_day_first_{hours}h_wall_s"] = wall
            out[f"drilling_day_first_{hours}h_peak_rss_gb"] = peak / 1e9
            out[f"drilling_day_first_{hours}h_node_ticks"] = ticks
            if hours == 1:
                out["drilling_day_first_1h_wall_min_s"] = min(walls)
                skel_wall, _, skel_text, _ = _process([__file__, "skeleton", str(path)])
                assert int(skel_text.strip()) == ticks, "the skeleton ticks the same nodes at the same times"
                out["drilling_day_first_1h_skeleton_wall_s"] = skel_wall
                # same node-ticks on each side; ours the median of its runs
                out["drilling_day_first_1h_node_ticks_per_s_vs_skeleton"] = skel_wall / wall
        out["drilling_day_peak_rss_2h_over_1h"] = (out["drilling_day_first_2h_peak_rss_gb"]
                                                   / out["drilling_day_first_1h_peak_rss_gb"])
    out.update(_day_rate_vs_skeleton(out["drilling_day_1000_wall_s"], out["drilling_day_1000_node_ticks"]))
    field = _scenario("field", "drilling_10_tubes.toml")
    for engine in ("compiled", "event"):
        s = field.with_overrides(**{"simulation.engine": engine})
        simulate_chain(s.with_overrides(**{"simulation.realizations": 1}))  # warm
        out[f"drilling_10_tubes_{engine}_s"] = best_time_s(lambda: simulate_chain(s), repeat=2)
    out["drilling_10_tubes_compiled_speedup_vs_event"] = out["drilling_10_tubes_event_s"] / out["drilling_10_tubes_compiled_s"]
    return out


BENCHMARKS = [chain_drilling_batched_vs_loop, chain100_1h_overhead_vs_skeleton, batched_mc_speedup,
              drilling_day_1000]


if __name__ == "__main__":  # the skeleton as a process of its own: python bench_chain.py skeleton SCENARIO.toml
    import sys

    if sys.argv[1:2] == ["skeleton"]:
        print(skeleton(load_scenario(sys.argv[2])[0]))
