"""Lab experiment figures (thesis 4.2.2-4.2.4, table 4.22, figs 4.13/4.17/4.19, two-node section) from the
bundled ``scenarios/lab/*.toml`` run through the chain simulation.

Every case uses the same models and parameters (z-gyro ARW and bias instability from the thesis Allan
results, table V.1; filter A = 1, B = 5; MPU-6500 datasheet accelerometer noise); nothing is tuned per
case.  Tolerance: a factor of two on every figure, plus ordering checks (azimuth error grows with timeout
length and with hop count).  ``REALIZATIONS`` Monte Carlo realizations per case (the mean is compared).
The RMS window is the thesis's 350-550 s shifted by the later end of our canonical rotation (361 s
instead of ~343 s): 370-570 s; the two-node window is the thesis's 600-1150 s.
"""

from __future__ import annotations

import math
from functools import lru_cache
from importlib import resources

from nodesim.chain.network import simulate_chain
from nodesim.chain.metrics import per_realization_metrics, summarize
from nodesim.scenario.schema import load_scenario
from nodesim.validation import Check, within_abs, within_factor
from nodesim.validation import convergence as cv

REALIZATIONS = 16
T422 = "thesis table 4.22 (RMS errors 350-550 s, 32-point MAF)"
NOISE_NOTE = (
    "the MPU-6500 datasheet accelerometer noise (300 ug/sqrt(Hz) one-sided, 212 two-sided) alone gives ~0.085 deg "
    "RMS azimuth at 2 deg inclination after the 32-point MAF; the thesis figure implies ~3x less noise; the lab "
    "alignment offset's own residual (its max and min are read from a noisy 32-point average; firmware.alignment) "
    "adds ~0.05 deg in quadrature"
)
OFFSET_NOTE = (
    "after convergence our yaw error in these modes is a few hundredths of a degree; the thesis figure is "
    "larger than its own yaw-error envelope (e.g. +/-0.2 deg at 0.2 Hz), so it likely holds an azimuth offset "
    "of the true-azimuth reference that we do not model"
)
S_CONV = "thesis secs 4.2.4 (fig 4.13), 4.2.1 (figs 4.16-4.17) and 4.2.2 (fig 4.11b)"
INC_NOTE = "inclination error here is accelerometer noise only; the thesis values scatter (0.000-0.085 deg) with no trend"


@lru_cache(maxsize=None)
def lab_summary(name: str) -> dict:
    """Summary metrics of ``scenarios/lab/<name>.toml`` with ``REALIZATIONS`` realizations (cached)."""
    with resources.as_file(resources.files("scenarios") / "lab" / f"{name}.toml") as p:
        scenario, _ = load_scenario(p)
    scenario = scenario.with_overrides(**{"simulation.realizations": REALIZATIONS})
    return summarize(per_realization_metrics(simulate_chain(scenario), scenario.metrics))


def _v(s: dict, key: str) -> float:
    return float("nan") if s.get(key) is None else float(s[key])


TABLE_4_22 = (  # scenario, label, published RMS inclination, RMS azimuth (deg)
    ("continuous", "continuous", 0.01, 0.029),
    ("windowed_20s_5s", "20 s / 5 s timeout", 0.085, 0.250),
    ("windowed_20s_10s", "20 s / 10 s timeout", 0.002, 0.384),
    ("windowed_20s_30s", "20 s / 30 s timeout", 0.000, 0.351),
    ("windowed_20s_50s", "20 s / 50 s timeout", 0.015, 1.0),
    ("windowed_20s_60s", "20 s / 60 s timeout", 0.005, 0.565),
)


def table_4_22() -> list[Check]:
    out = []
    for name, label, inc, azi in TABLE_4_22:
        s = lab_summary(name)
        note = NOISE_NOTE if name == "continuous" else (OFFSET_NOTE if azi < 0.5 else "")
        out.append(within_factor(f"lab {label}: RMS azimuth error [deg]", T422, _v(s, "rms_azimuth_error_deg"), azi, 2.0,
                                 note))
        ours_inc = _v(s, "rms_inclination_error_deg")
        if inc == 0.0:  # printed "0,000": only the rounding interval can be checked
            out.append(within_abs(f"lab {label}: RMS inclination error [deg]", T422, ours_inc, 0.0, 0.0005,
                                  "printed 0,000: checked against half the printed resolution; " + INC_NOTE))
        else:
            out.append(within_factor(f"lab {label}: RMS inclination error [deg]", T422, ours_inc, inc, 2.0, INC_NOTE))
    return out


def convergence_times() -> list[Check]:
    """The six lab convergence times the thesis prints (secs 4.2.4 and 4.2.1; the fig 4.11b pair is in
    checks_firmware) and the summary over all eight: the log-RMS error under the default ``filter.b_tuning`` and,
    for comparison, under the other reading (nodesim.validation.convergence)."""
    rows = [
        within_factor(f"lab {p.label}: bias convergence time [s]", p.source, cv.convergence_s(p.key), p.seconds, 2.0)
        for p in (cv.BY_KEY[k] for k in cv.LAB_KEYS)
    ]
    default = cv.DEFAULT_B_TUNING
    other = next(b for b in cv.B_TUNINGS if b != default)
    ours, alternative = cv.log_rms_error(default), cv.log_rms_error(other)
    limit = math.log(2.0)
    note = (
        f"sqrt(mean(ln(ours / published)^2)) over the 8 published times (the 6 rows above and firmware fig 4.11b "
        f"B = 5 / B = 1): {ours:.3f} with filter.b_tuning = '{default}' (the project default), {alternative:.3f} with "
        f"'{other}'; " + ("the default is the reading with the lower value" if ours <= alternative else
                          "the other reading is lower now: the default should be revisited") +
        " ('process_noise': Q_bb = B 2 sigma_b^2 / tau, "
        "G_D = sqrt(B); 'noise_gain': Q_bb = B^2 2 sigma_b^2 / tau, G_D = B; thesis eqs 4.14-4.15 are lost in the "
        "text, so the reading is a one-bit choice made on these 8 values). Ok when below ln 2, the factor 2 of the rows"
    )
    rows.append(Check("lab + fig 4.11b: bias convergence, log-RMS error over the 8 published times",
                      f"{S_CONV}; ours under filter.b_tuning = '{default}'", ours, 0.0,
                      "log-RMS <= ln 2 = 0.693", bool(ours <= limit), note, "reproduction"))
    return rows


def single_updates() -> list[Check]:
    s = lab_summary("single_0p2hz")
    src = "thesis 4.2.1 single updates at 0.2 Hz (RMS I 0.0089 deg, RMS A 0.5213 deg)"
    mean_azi = sum(_v(lab_summary(n), "rms_azimuth_error_deg") for n in ("single_0p2hz", "single_0p1hz", "single_0p05hz")) / 3
    return [
        within_factor("lab single 0.2 Hz: RMS azimuth error [deg]", src, _v(s, "rms_azimuth_error_deg"), 0.5213, 2.0,
                      OFFSET_NOTE),
        within_factor("lab single 0.2 Hz: RMS inclination error [deg]", src, _v(s, "rms_inclination_error_deg"), 0.0089,
                      2.0, INC_NOTE),
        within_factor("lab single 0.05/0.1/0.2 Hz: mean RMS azimuth error [deg]",
                      "thesis 4.2.3 (single updates at 0.05/0.1/0.2 Hz average ~0.5 deg)", mean_azi, 0.5, 2.0),
    ]


def two_nodes() -> list[Check]:
    s = lab_summary("two_nodes_0p8hz")
    src = "thesis two-node experiment, encoder -> A at 0.8 Hz, 600-1150 s"
    note = OFFSET_NOTE + "; the thesis notes R barely grows from A to B, so B is close to single-node behaviour"
    return [
        within_factor("lab two nodes: node A RMS azimuth error [deg]", src, _v(s, "node1_rms_azimuth_error_deg"), 0.442,
                      2.0, note),
        within_factor("lab two nodes: node B RMS azimuth error [deg]", src, _v(s, "node2_rms_azimuth_error_deg"), 0.761,
                      2.0, note),
        within_factor("lab two nodes: node A RMS inclination error [deg]", src,
                      _v(s, "node1_rms_inclination_error_deg"), 0.002, 2.0, INC_NOTE),
        within_factor("lab two nodes: node B RMS inclination error [deg]", src,
                      _v(s, "node2_rms_inclination_error_deg"), 0.027, 2.0, INC_NOTE),
    ]


TWO_NODE_AZIMUTH_DEG = (0.442, 0.761)
"""Thesis two-node table (4.2.2): RMS azimuth error of node A and node B [deg]; the thesis gives no yaw figures."""


def excess_within_factor(ratio: float, published_ratio: float, factor: float = 2.0) -> bool:
    """How much worse, ``ratio - 1``, within ``factor`` of the published ``published_ratio - 1`` (> 0).

    The lab rows' factor of two applied to the excess rather than to the ratio itself: a factor 2 on a ratio of
    1.72 would accept 0.86, i.e. the reverse ordering, and 1.01, no ordering at all."""
    excess, published_excess = ratio - 1.0, published_ratio - 1.0
    return bool(published_excess / factor <= excess <= published_excess * factor)


def orderings() -> list[Check]:
    """Orderings: azimuth error grows with the timeout (table 4.22) and from node A to node B (two-node table).

    Like is compared with like: our azimuth ratio B / A against the published azimuth ratio (a reproduction);
    the yaw ratio only against our own node A (self-consistency: no yaw figure is published)."""
    azi = {n: _v(lab_summary(n), "rms_azimuth_error_deg") for n in
           ("continuous", "windowed_20s_5s", "windowed_20s_30s", "windowed_20s_60s")}
    chain = [azi["continuous"], azi["windowed_20s_5s"], azi["windowed_20s_30s"], azi["windowed_20s_60s"]]
    grows = all(a < b for a, b in zip(chain, chain[1:]))
    two = lab_summary("two_nodes_0p8hz")
    azi_a, azi_b = _v(two, "node1_rms_azimuth_error_deg"), _v(two, "node2_rms_azimuth_error_deg")
    yaw_a, yaw_b = _v(two, "node1_rms_yaw_error_deg"), _v(two, "node2_rms_yaw_error_deg")
    azi_ratio, yaw_ratio = azi_b / azi_a, yaw_b / yaw_a
    pub_a, pub_b = TWO_NODE_AZIMUTH_DEG
    pub_ratio = pub_b / pub_a
    azi_ok = excess_within_factor(azi_ratio, pub_ratio)
    azi_note = f"ours: A {azi_a:.4f}, B {azi_b:.4f} deg"
    if not azi_ok:
        azi_note += (
            f"; B is {100 * (azi_ratio - 1):.1f} % worse than A, the thesis {100 * (pub_ratio - 1):.0f} %: each node's "
            f"own, independent accelerometer noise (~0.085 deg of azimuth at 2 deg inclination) dominates both nodes, "
            f"and what B inherits from A is yaw error (yaw A {yaw_a:.4f}, B {yaw_b:.4f} deg), too small to show; "
            "the thesis's 0.442 / 0.761 needs a per-node azimuth error we do not model"
        )
    return [
        Check("lab ordering: RMS azimuth 60 s / 5 s timeout (continuous < 5 s < 30 s < 60 s)", T422,
              azi["windowed_20s_60s"] / azi["windowed_20s_5s"], 0.565 / 0.250, "ordering (ratio > 1, chain increasing)",
              bool(grows), "ours: " + " < ".join(f"{v:.3f}" for v in chain)),
        Check("lab ordering: RMS azimuth error node B / node A (hop count)",
              f"thesis two-node experiment (azimuth {pub_b} / {pub_a} deg)", azi_ratio, pub_ratio,
              f"factor 2 on B/A - 1 (B {50 * (pub_ratio - 1):.0f}-{200 * (pub_ratio - 1):.0f} % worse than A)",
              bool(azi_ok), azi_note),
        Check("lab ordering: RMS yaw error node B / node A (hop count), ours only",
              "thesis two-node experiment set-up (no yaw figure published)", yaw_ratio, float("nan"),
              "ordering (ratio > 1)", bool(yaw_ratio > 1.0),
              f"self-consistency: our node B against our node A (yaw A {yaw_a:.4f}, B {yaw_b:.4f} deg); B's "
              "measurement is A's estimate, so B should inherit A's yaw error", kind="self_consistency"),
    ]


CHECKS = [table_4_22, convergence_times, single_updates, two_nodes, orderings]
