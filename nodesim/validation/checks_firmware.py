"""Firmware-model figures (thesis 4.2.2-4.2.3 tuning; thesis digest 2.7 fixed-point acceptance).

Each runs the bundled lab scenario (8 realizations) through the chain simulation (a chain of one node):
- bias convergence after the rotation stops with B = 5 and B = 1 (thesis fig 4.11b: ~82.8 s and
  ~177.98 s), the criterion of the thesis digest 5.4 (within +/- 0.002 deg/s of the true bias for 10 s), under the
  default ``filter.b_tuning`` (nodesim.validation.convergence, which also holds the lab convergence times);
- the fixed-point filter (default formats) against the float filter on the same inputs: RMS yaw difference
  (digest 2.7 acceptance < 0.01 deg), with continuous updates and with 20 s / 30 s windowed updates, and
  the number of saturations (none expected with the default formats).

Kinds: the convergence rows are reproductions of fig 4.11b; the fixed-point rows are ``self_consistency`` (our
fixed-point filter against our float filter on the same inputs, judged by the digest's acceptance rule: no
published figure is reproduced).
"""

from __future__ import annotations

from functools import lru_cache
from importlib import resources

import numpy as np

from nodesim.chain.network import ChainRun, simulate_chain
from nodesim.scenario.schema import Scenario, load_scenario
from nodesim.units import rad_to_deg, wrap_pi
from nodesim.validation import Check, within_abs, within_factor, within_rel
from nodesim.validation import convergence as cv

REALIZATIONS = 8
FIG_4_11B = "thesis fig 4.11b / sec 4.2.2 (bias convergence after the rotation stops)"
DIGEST_FIXED = "thesis digest 2.7 fixed-point acceptance (not in the thesis; [A])"


@lru_cache(maxsize=1)
def _base() -> Scenario:
    with resources.as_file(resources.files("scenarios") / "lab" / "continuous.toml") as p:
        scenario, _ = load_scenario(p)
    return scenario.with_overrides(**{"simulation.realizations": REALIZATIONS})


def tuning_convergence() -> list[Check]:
    b5, b1 = (cv.convergence_s(k) for k in cv.FIG_4_11B_KEYS)
    reading = cv.DEFAULT_B_TUNING
    note_b5 = (
        f"filter.b_tuning = '{reading}'; the thesis prints two continuous-mode B = 5 figures, ~46 s (sec 4.2.4, "
        "digest 5.4) and this ~82.8 s (on a run whose timeline the extraction does not give): one model can at best "
        "sit between them (the log-RMS row of the lab convergence times weighs all 8)"
    )
    p5, p1 = (cv.BY_KEY[k] for k in cv.FIG_4_11B_KEYS)
    return [
        within_rel("firmware: bias convergence, B = 5 [s]", FIG_4_11B, b5, p5.seconds, 0.25, note_b5),
        within_rel("firmware: bias convergence, B = 1 [s]", FIG_4_11B, b1, p1.seconds, 0.25,
                   "B = 1: both readings of filter.b_tuning give the same Q (B^2 = B)"),
        within_factor("firmware: convergence ratio B=1 / B=5", FIG_4_11B, b1 / b5, p1.seconds / p5.seconds, 2.0,
                      f"filter.b_tuning = '{reading}'"),
    ]


def _yaw_difference(scenario: Scenario) -> tuple[float, ChainRun]:
    node_float = simulate_chain(scenario).nodes[0]
    run_fixed = simulate_chain(scenario.with_overrides(**{"filter.implementation": "fixed"}))
    node_fixed = run_fixed.nodes[0]
    sel = node_float.t_s >= node_float.filter_start_s
    diff = wrap_pi(node_fixed.yaw_est_rad[:, sel] - node_float.yaw_est_rad[:, sel])
    return float(rad_to_deg(np.sqrt(np.mean(diff**2)))), run_fixed


def fixed_vs_float() -> list[Check]:
    windowed = _base().with_overrides(**{"schedule.mode": "windowed", "schedule.update_s": 20.0, "schedule.timeout_s": 30.0})
    rms_cont, run_cont = _yaw_difference(_base())
    rms_win, run_win = _yaw_difference(windowed)
    saturations = sum(sum(n.firmware_overflows.values()) for run in (run_cont, run_win) for n in run.nodes)
    ours_vs_ours = "self-consistency: our fixed-point filter against our float filter on the same inputs"
    return [
        within_abs("firmware: fixed vs float RMS yaw difference, continuous [deg]", DIGEST_FIXED, rms_cont, 0.0, 0.01,
                   ours_vs_ours, kind="self_consistency"),
        within_abs("firmware: fixed vs float RMS yaw difference, 20 s / 30 s windows [deg]", DIGEST_FIXED, rms_win, 0.0,
                   0.01, ours_vs_ours, kind="self_consistency"),
        within_abs(
            "firmware: saturations of the default fixed formats on the lab profile",
            DIGEST_FIXED,
            float(saturations),
            0.0,
            0.0,
            "self-consistency: our fixed-point runs counted; rates up to 71 deg/s in Q16.16; a too-narrow format is "
            "shown to saturate in tests/firmware_model",
            kind="self_consistency",
        ),
    ]


CHECKS = [tuning_convergence, fixed_vs_float]
