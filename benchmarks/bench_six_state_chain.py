"""The fixed-point 6-state node firmware in the chain (issue 24) against the 2-state fixed firmware, measured in the
same run.

* ``six_state_fixed_chain_node_tick_ns`` / ``two_state_fixed_chain_node_tick_ns``: the compiled engine's phase 2 of
  the fixed firmware (:func:`nodesim.chain.compiled.filters.run_node_firmware`, the whole node tick: rates, static
  window, predict, reference, update, the sent words) per node-tick and realization, on the same short chain run
  (:data:`CHAIN`: 8 soil hops with the ARQ MAC, lab spin at 2 deg, R realizations) with ``filter.states`` = 6 and
  2, one thread (``threads.limited(1)``); min over REPEAT runs (``*_median_ns`` the median), ``*_cost_ratio`` the
  ratio of the minima; ``*_run_s`` the minimum whole-run time (sensors, phase 1, frames, surveys alike).
* ``drilling_day_first_1h_states6_wall_s`` and ``..._peak_rss_gb``: ``scenarios/perf/drilling_day_1000.toml``'s
  first hour (:func:`bench_chain._day_slice`) with ``filter.states = 6`` (fixed, as the scenario) as a whole
  ``nodesim run`` process, beside the same hour with 2 states (``drilling_day_first_1h_states2_*``) in this run.
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from nodesim import threads
from nodesim.chain.compiled import engine, filters
from nodesim.chain.network import simulate_chain
from nodesim.scenario.schema import Scenario

sys.path.insert(0, str(Path(__file__).parent))
from bench_chain import PEAK, _day_slice, _process  # noqa: E402

REPEAT = 5
CHAIN = {"chain.nodes": 8, "simulation.duration_s": 600.0, "simulation.realizations": 8,
         "metrics.window_start_s": 60.0, "metrics.window_end_s": 600.0, "radio.model": "channel",
         "radio.shadowing_sigma_db": 0.0, "radio.soil.distance_m": 0.5, "mac.enabled": True,
         "filter.implementation": "fixed", "simulation.engine": "compiled"}


def _phase2_ns_per_node_tick(scenario: Scenario) -> tuple[float, float]:
    """(ns per node-tick and realization in run_node_firmware, the whole run's s) of one run."""
    spent, lane_ticks = [0.0], [0]
    inner = filters.run_node_firmware

    def timed(*args):
        t0 = time.perf_counter()
        inner(*args)
        spent[0] += time.perf_counter() - t0
        lane_ticks[0] += int(args[9]) * (int(args[32]) - int(args[31]))  # k_end x (r_end - r_first)

    engine.filters.run_node_firmware = timed
    try:
        t0 = time.perf_counter()
        simulate_chain(scenario)
        run_s = time.perf_counter() - t0
    finally:
        engine.filters.run_node_firmware = inner
    return spent[0] / lane_ticks[0] * 1e9, run_s


def six_state_fixed_chain_node_tick_cost() -> dict:
    out = {}
    with threads.limited(1):
        for states in (6, 2):
            s = Scenario().with_overrides(**CHAIN, **{"filter.states": states})
            _phase2_ns_per_node_tick(s.with_overrides(**{"simulation.duration_s": 80.0,
                                                         "metrics.window_end_s": 80.0}))  # compile / load
            runs = [_phase2_ns_per_node_tick(s) for _ in range(REPEAT)]
            ns = [r[0] for r in runs]
            name = "six" if states == 6 else "two"
            out[f"{name}_state_fixed_chain_node_tick_ns"] = min(ns)
            out[f"{name}_state_fixed_chain_node_tick_median_ns"] = float(np.median(ns))
            out[f"{name}_state_fixed_chain_run_s"] = min(r[1] for r in runs)
    out["six_state_fixed_chain_node_tick_cost_ratio"] = (out["six_state_fixed_chain_node_tick_ns"]
                                                         / out["two_state_fixed_chain_node_tick_ns"])
    return out


def _states6(path: Path) -> Path:
    text = path.read_text()
    assert "[filter]\n" in text and 'implementation = "fixed"' in text
    six = path.with_name(path.stem + "_states6.toml")
    six.write_text(text.replace("[filter]\n", "[filter]\nstates = 6\n", 1))
    return six


def drilling_day_first_1h_states6() -> dict:
    """The drilling day's first hour with 6 and with 2 states (module docstring): whole processes, wall and peak."""
    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        two = _day_slice(tmp, 1)
        for states, path in ((6, _states6(two)), (2, two)):
            wall, peak, _, _ = _process(["-c", PEAK, "run", str(path), "--out", str(tmp / f"run{states}"), "--quiet",
                                         "--json"])
            out[f"drilling_day_first_1h_states{states}_wall_s"] = wall
            out[f"drilling_day_first_1h_states{states}_peak_rss_gb"] = peak / 1e9
    out["drilling_day_first_1h_states6_vs_states2_wall"] = (out["drilling_day_first_1h_states6_wall_s"]
                                                            / out["drilling_day_first_1h_states2_wall_s"])
    return out


BENCHMARKS = [six_state_fixed_chain_node_tick_cost, drilling_day_first_1h_states6]


if __name__ == "__main__":  # python benchmarks/bench_six_state_chain.py [tick|day]
    import json

    which = sys.argv[1:] or ["tick", "day"]
    for fn in ([six_state_fixed_chain_node_tick_cost] if "tick" in which else []) + (
            [drilling_day_first_1h_states6] if "day" in which else []):
        print(json.dumps(fn(), indent=1), flush=True)
