"""Lab experiment figures (thesis 4.2.2-4.2.4) from the bundled lab scenario.

The walking-skeleton node uses simple sensor and filter models; the chain issue re-tunes nothing per
case but replaces the models.  Tolerance: a factor of two on every figure (the goal of the chain issue).
"""

from __future__ import annotations

from importlib import resources

from nodesim.metrics import per_realization_metrics, summarize
from nodesim.scenario import load_scenario
from nodesim.simulation import simulate_lab
from nodesim.validation import Check, within_factor

REALIZATIONS = 8


def _continuous_summary() -> dict:
    path = resources.files("scenarios") / "lab" / "continuous.toml"
    with resources.as_file(path) as p:
        scenario, _ = load_scenario(p)
    scenario = scenario.with_overrides(**{"simulation.realizations": REALIZATIONS})
    run = simulate_lab(scenario)
    return summarize(per_realization_metrics(run, scenario.metrics))


def lab_continuous() -> list[Check]:
    s = _continuous_summary()
    src = "thesis table 4.22 (RMS errors, continuous mode)"
    return [
        within_factor("lab continuous: RMS azimuth error [deg]", src, s["rms_azimuth_error_deg"], 0.029, 2.0),
        within_factor("lab continuous: RMS inclination error [deg]", src, s["rms_inclination_error_deg"], 0.01, 2.0),
        within_factor(
            "lab continuous: bias convergence time [s]",
            "thesis 4.2.3 (continuous mode, ~46 s after the stop)",
            s["bias_convergence_time_s"] if s["bias_convergence_time_s"] is not None else float("nan"),
            46.0,
            2.0,
        ),
    ]


CHECKS = [lab_continuous]
