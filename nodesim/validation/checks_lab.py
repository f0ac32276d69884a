"""Lab experiment figures (thesis 4.2.2-4.2.4, table 4.22, figs 4.13/4.17/4.19, two-node section) from the
bundled ``scenarios/lab/*.toml`` run through the chain simulation.

Every case uses the same models and parameters (z-gyro ARW and bias instability from the thesis Allan
results, table V.1; filter A = 1, B = 5; MPU-6500 datasheet accelerometer noise; the rig's measured truth,
``metrics.reference_accuracy_pct`` = 1.126, thesis sec 4.2.3 and table 4.20); the cases differ only in what the
thesis says differs (schedule, nodes, window: tests/nodesim/validation/test_lab_scenarios.py); nothing is tuned
per case.

Each published RMS figure is one lab run, so it is compared with the distribution of ours: one batched run of
``REALIZATIONS`` realizations per scenario (all rows of a scenario read the same run), our median (``ours``), 5th
and 95th percentiles and the percentile at which the published value falls; the row is ok when the published value
lies inside our 5-95 % band (:func:`nodesim.validation.within_band`).  :func:`band_summary` counts the published
values inside their bands (~90 % if the model is right).  Orderings compare our medians, like with like (azimuth
with azimuth).  The bias convergence rows keep their own runs and rule (:mod:`nodesim.validation.convergence`).
The RMS window is the thesis's 350-550 s shifted by the later end of our canonical rotation (361 s instead of
~343 s): 370-570 s; the two-node window is the thesis's 600-1150 s.
"""

from __future__ import annotations

import dataclasses
import math
from functools import lru_cache
from importlib import resources

import numpy as np

from nodesim.chain.network import simulate_chain
from nodesim.chain.metrics import per_realization_metrics, summarize
from nodesim.scenario.schema import load_scenario
from nodesim.validation import Check, within_band, within_factor
from nodesim.validation import convergence as cv

REALIZATIONS = 256
"""Realizations per lab scenario (one batched compiled run each, ~1 s): the 5 % tails from ~13 runs each."""
T422 = "thesis table 4.22 (RMS errors 350-550 s, 32-point MAF)"
S_CONV = "thesis secs 4.2.4 (fig 4.13), 4.2.1 (figs 4.16-4.17) and 4.2.2 (fig 4.11b)"
S_SINGLE = "thesis 4.2.1 single updates at 0.2 Hz (RMS I 0.0089 deg, RMS A 0.5213 deg)"
S_TWO = "thesis two-node experiment, encoder -> A at 0.8 Hz, 600-1150 s"
NOISE_NOTE = (
    "the MPU-6500 datasheet accelerometer noise (300 ug/sqrt(Hz) one-sided, 212 two-sided) alone gives ~0.085 deg "
    "RMS azimuth at 2 deg inclination after the 32-point MAF, in every run; the thesis figure implies ~3x less noise "
    "(and a run whose reference error across the tilt was small)"
)
INC_FLOOR_NOTE = (
    "below our inclination floor: the accelerometer noise after the 32-point MAF and the alignment offset's own "
    "residual give ~0.003 deg in every run, before the reference error; the thesis's accelerometer noise was lower "
    "(cf. the continuous azimuth row)"
)


def lab_scenario(name: str):
    """``scenarios/lab/<name>.toml`` as bundled, with ``REALIZATIONS`` realizations (the one override)."""
    with resources.as_file(resources.files("scenarios") / "lab" / f"{name}.toml") as p:
        scenario, _ = load_scenario(p)
    return scenario.with_overrides(**{"simulation.realizations": REALIZATIONS})


@lru_cache(maxsize=None)
def lab_metrics(name: str) -> dict[str, np.ndarray]:
    """Per-realization metrics (R,) of :func:`lab_scenario` (cached: one batched run per scenario serves all its
    rows)."""
    scenario = lab_scenario(name)
    return per_realization_metrics(simulate_chain(scenario), scenario.metrics)


def lab_summary(name: str) -> dict:
    """Summary (means over the realizations, p95) of :func:`lab_metrics`."""
    return summarize(lab_metrics(name))


def median(name: str, key: str) -> float:
    return float(np.nanmedian(lab_metrics(name)[key]))


def reference_sigma_deg(name: str = "continuous") -> float:
    """Sigma of each component of the lab's reference tilt error [deg]: the scenario's accuracy x its inclination."""
    scenario = lab_scenario(name)
    return scenario.metrics.reference_accuracy_pct / 100.0 * scenario.motion.inclination_deg


def _azimuth_row(label: str, source: str, name: str, node: str, published: float, note: str = "") -> Check:
    m = lab_metrics(name)
    azi, yaw = m[f"{node}rms_azimuth_error_deg"], m[f"{node}rms_yaw_error_deg"]
    c = within_band(f"lab {label}: RMS azimuth error [deg]", source, azi, published)
    yaw_median = float(np.median(yaw))
    why = f"our median RMS yaw error {yaw_median:.3f} deg"
    if not c.ok and published < c.band_p5:
        why += "; " + (note or (
            "the published value is below what our yaw error between updates alone gives: our gyro drifts more "
            "between updates than the thesis's did" if yaw_median > published else
            "below our band: our accelerometer noise and the reference error give more in nearly every run"))
    elif not c.ok:
        why += "; " + (note or "above our band: a larger error than our model's yaw, noise and reference error give")
    return _with_note(c, why)


def _inclination_row(label: str, source: str, name: str, node: str, published: float) -> Check:
    values = lab_metrics(name)[f"{node}rms_inclination_error_deg"]
    zero = published == 0.0  # printed "0,000": anywhere in [0, 0.0005)
    c = within_band(f"lab {label}: RMS inclination error [deg]", source, values, published,
                    printed_below=0.0005 if zero else None)
    why = "printed 0,000: ok if [0, 0.0005) reaches into our band; its percentile is that of 0.0005" if zero else ""
    if not c.ok and (zero or published < c.band_p5):
        why = (why + "; " if why else "") + INC_FLOOR_NOTE
    elif not c.ok:
        sigma = reference_sigma_deg(name)
        why = f"above our band: needs a static inclination error of ~{published:.3f} deg"
        why += (f", {published / sigma:.1f} sigma of the reference accuracy ({sigma:.4f} deg at 2 deg, thesis table "
                "4.20)" if sigma > 0 else "")
    return _with_note(c, why)


def _with_note(c: Check, note: str) -> Check:
    return dataclasses.replace(c, note=note) if note else c


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
        out.append(_azimuth_row(label, T422, name, "", azi, NOISE_NOTE if name == "continuous" else ""))
        out.append(_inclination_row(label, T422, name, "", inc))
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


SINGLE_MEAN = ("single_0p2hz", "single_0p1hz", "single_0p05hz")


def single_updates() -> list[Check]:
    out = [_azimuth_row("single 0.2 Hz", S_SINGLE, "single_0p2hz", "", 0.5213),
           _inclination_row("single 0.2 Hz", S_SINGLE, "single_0p2hz", "", 0.0089)]
    # the mean of three runs (one per rate): realization r of the first, r + R/3 of the second, r + 2R/3 of the third,
    # so that the three runs of a sample are independent (the cases share their seeds: realization r is the same
    # sensor, reference and noise draw in every case)
    azi = [lab_metrics(n)["rms_azimuth_error_deg"] for n in SINGLE_MEAN]
    R = azi[0].size
    mean = sum(np.roll(a, -(i * R // len(azi))) for i, a in enumerate(azi)) / len(azi)
    c = within_band("lab single 0.05/0.1/0.2 Hz: mean RMS azimuth error [deg]",
                    "thesis 4.2.3 (single updates at 0.05/0.1/0.2 Hz average ~0.5 deg)", mean, 0.5)
    out.append(_with_note(c, "our distribution of the mean of three independent runs, one per rate (realizations "
                             "r, r + R/3, r + 2R/3 of the three cases)"))
    return out


def two_nodes() -> list[Check]:
    name = "two_nodes_0p8hz"
    rows = [_azimuth_row("two nodes: node A", S_TWO, name, "node1_", 0.442),
            _azimuth_row("two nodes: node B", S_TWO, name, "node2_", 0.761),
            _inclination_row("two nodes: node A", S_TWO, name, "node1_", 0.002),
            _inclination_row("two nodes: node B", S_TWO, name, "node2_", 0.027)]
    note = "the thesis notes R barely grows from A to B, so B is close to single-node behaviour"
    return [_with_note(c, c.note + ("; " if c.note else "") + note) for c in rows]


def binomial_lower_quantile(n: int, p: float, q: float = 0.05) -> int:
    """The largest k with P(X < k) <= q for X ~ Binomial(n, p): fewer than k successes is the q-tail."""
    cdf, k = 0.0, 0
    while k <= n:
        nxt = cdf + math.comb(n, k) * p**k * (1.0 - p) ** (n - k)  # P(X <= k)
        if nxt > q:
            return k
        cdf, k = nxt, k + 1
    return n


def band_rows() -> list[Check]:
    """Every distribution row of the published lab values (table 4.22, single updates, two nodes)."""
    return [c for c in table_4_22() + single_updates() + two_nodes() if c.band_p5 is not None]


def band_summary() -> list[Check]:
    """The share of published lab values inside our 5-95 % band.  If the model is right each falls inside with
    probability 0.9, so the count is Binomial(n, 0.9); the row is ok unless the count is in that law's lower 5 %
    tail."""
    rows = band_rows()
    n, inside = len(rows), sum(c.ok for c in rows)
    k_min = binomial_lower_quantile(n, 0.9)
    outside = "; ".join(f"{c.name.removeprefix('lab ').split(': RMS')[0]} {'A' if 'azimuth' in c.name else 'I'} "
                        f"{c.published:g} at {c.published_percentile:.0f} %" for c in rows if not c.ok)
    note = (f"{inside} of {n} published lab values inside our 5-95 % band ({REALIZATIONS} runs per scenario; table "
            f"4.22, single updates, two nodes; the bias convergence times keep their factor-2 rule). Under a right "
            f"model the count is Binomial({n}, 0.9): mean {0.9 * n:.1f}, ok when >= {k_min} (its lower 5 % tail "
            f"below). "
            f"Outside: {outside or 'none'}")
    return [Check("lab: share of published values inside our 5-95 % band", f"{T422}; {S_SINGLE}; {S_TWO}",
                  inside / n, 0.9, f"count >= {k_min} of {n} (Binomial(n, 0.9) lower 5 % tail)", bool(inside >= k_min),
                  note, "reproduction")]


TWO_NODE_AZIMUTH_DEG = (0.442, 0.761)
"""Thesis two-node table (4.2.2): RMS azimuth error of node A and node B [deg]; the thesis gives no yaw figures."""


def excess_within_factor(ratio: float, published_ratio: float, factor: float = 2.0) -> bool:
    """How much worse, ``ratio - 1``, within ``factor`` of the published ``published_ratio - 1`` (> 0).

    The lab rows' factor of two applied to the excess rather than to the ratio itself: a factor 2 on a ratio of
    1.72 would accept 0.86, i.e. the reverse ordering, and 1.01, no ordering at all."""
    excess, published_excess = ratio - 1.0, published_ratio - 1.0
    return bool(published_excess / factor <= excess <= published_excess * factor)


ORDER_CHAIN = ("continuous", "windowed_20s_5s", "windowed_20s_30s", "windowed_20s_60s")


def orderings() -> list[Check]:
    """Orderings: azimuth error grows with the timeout (table 4.22) and from node A to node B (two-node table).

    Like is compared with like, on our medians over the ``REALIZATIONS`` runs: our azimuth chain and our azimuth
    ratio B / A against the published azimuths (reproductions); the yaw ratio only against our own node A
    (self-consistency: no yaw figure is published)."""
    azi = {n: median(n, "rms_azimuth_error_deg") for n in ORDER_CHAIN}
    chain = [azi[n] for n in ORDER_CHAIN]
    grows = all(a < b for a, b in zip(chain, chain[1:]))
    two = lab_metrics("two_nodes_0p8hz")
    azi_a, azi_b = (median("two_nodes_0p8hz", f"node{i}_rms_azimuth_error_deg") for i in (1, 2))
    yaw_a, yaw_b = (median("two_nodes_0p8hz", f"node{i}_rms_yaw_error_deg") for i in (1, 2))
    azi_ratio, yaw_ratio = azi_b / azi_a, yaw_b / yaw_a
    pub_a, pub_b = TWO_NODE_AZIMUTH_DEG
    pub_ratio = pub_b / pub_a
    azi_ok = excess_within_factor(azi_ratio, pub_ratio)
    per_run = two["node2_rms_azimuth_error_deg"] / two["node1_rms_azimuth_error_deg"]
    share = 100.0 * float(np.mean(per_run >= pub_ratio))
    azi_note = (f"medians of {REALIZATIONS} runs: A {azi_a:.4f}, B {azi_b:.4f} deg (B / A of the medians); in "
                f"{share:.0f} % of our runs B / A >= the published {pub_ratio:.3f}")
    if not azi_ok:
        azi_note += (
            f"; our median B is {100 * (azi_ratio - 1):+.1f} % against A, the thesis's "
            f"{100 * (pub_ratio - 1):.0f} % worse: "
            f"each node's own static reference error (sigma {reference_sigma_deg('two_nodes_0p8hz'):.4f} deg across "
            "the tilt, ~0.64 deg of azimuth at 2 deg) and accelerometer noise dominate both nodes, and what B inherits "
            f"from A is yaw error (median yaw A {yaw_a:.4f}, B {yaw_b:.4f} deg), too small to show; the published "
            "0.442 / 0.761 is one draw of two independent per-node errors")
    return [
        Check("lab ordering: RMS azimuth 60 s / 5 s timeout (continuous < 5 s < 30 s < 60 s)", T422,
              azi["windowed_20s_60s"] / azi["windowed_20s_5s"], 0.565 / 0.250,
              "ordering of the medians (chain increasing)", bool(grows),
              f"medians of {REALIZATIONS} runs (the cases share their seeds, so each realization's reference error "
              "and sensor draws are common to the four and the medians differ by the schedule): "
              + " < ".join(f"{v:.3f}" for v in chain) + "; published 0.029 < 0.250 < 0.351 < 0.565"),
        Check("lab ordering: RMS azimuth error node B / node A (hop count)",
              f"thesis two-node experiment (azimuth {pub_b} / {pub_a} deg)", azi_ratio, pub_ratio,
              f"factor 2 on B/A - 1 of the medians (B {50 * (pub_ratio - 1):.0f}-{200 * (pub_ratio - 1):.0f} % worse "
              "than A)", bool(azi_ok), azi_note),
        Check("lab ordering: RMS yaw error node B / node A (hop count), ours only",
              "thesis two-node experiment set-up (no yaw figure published)", yaw_ratio, float("nan"),
              "ordering of the medians (ratio > 1)", bool(yaw_ratio > 1.0),
              f"self-consistency: our node B against our node A (median yaw A {yaw_a:.4f}, B {yaw_b:.4f} deg); B's "
              "measurement is A's estimate, so B should inherit A's yaw error", kind="self_consistency"),
    ]


CHECKS = [table_4_22, convergence_times, single_updates, two_nodes, band_summary, orderings]
