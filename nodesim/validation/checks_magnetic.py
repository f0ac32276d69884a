"""Magnetic survey baseline: HV spreadsheet triads/azimuths, MCM sheet, HV Monte Carlo, SV WLS and covariance.

Sources: HV = bsc_msa_monte_carlo (Figs 8-1, 8-3, Tables 9 and 11); SV = bsc_covariance_method (Tables 5,
7, 10, 11); trajectories and numbers via the digest msa_mcm_covariance_digest.md sections 12-14.  The
published numbers are bundled in ``nodesim/data/magnetic/published.json``.

Tolerances:
* printed digits: half a unit of the last printed digit (0.005 for 2 decimals, 0.05 for 1, 0.5 m for 1 m);
* Monte Carlo spreads: ours (M replications) and HV's (300) are both sample standard deviations with
  relative standard error 1/sqrt(2 (M - 1)); the ratio's relative error is the root-sum-square of both,
  and we accept 3 of those (17 % at M = 300);
* SV covariance method: SV's inputs are Table 5 3-sigma values printed to 3 decimals, so up to ~4 %
  (0.0005 / 0.012) uncertain; we accept rel 5 %.

Every row is a ``reproduction``: our field, survey, Monte Carlo, WLS and covariance code run on the published
inputs against the published outputs (the WLS estimates are not the truths fed in: SV's prior and noise model
pull them away, e.g. T3 b_z 4.19 uT for a truth of -0.335 uT).
"""

from __future__ import annotations

import numpy as np

from nodesim.ground.magnetic_survey import FieldReference, apply_errors, params_array, survey_from_readings, tool_readings
from nodesim.ground.msa import condition_numbers
from nodesim.ground.msa_montecarlo import HV_SCENARIOS, MonteCarloConfig, run_monte_carlo
from nodesim.ground.msa_surveys import hv_mcm_sheet, hv_spreadsheet2, published_numbers, trajectory
from nodesim.ground.wellpath import displacements
from nodesim.ground.wls import covariance_position, wls_estimate
from nodesim.units import DEG
from nodesim.validation import Check, within_abs, within_rel

HV = "HV thesis (bsc_msa_monte_carlo)"
SV = "SV thesis (bsc_covariance_method)"
HV_REFERENCE = FieldReference(51.0, 72.0)
HV_TRUTH = params_array([1.1, 0.95, 1.25], [0.25, 0.295, -0.335])
VALIDATE_REPLICATIONS = 300
MC_SURVEYS = ("hv1", "hv2", "hv4", "hv5", "hv6")
ILL_CONDITIONED = ("hv3", "hv7")


def mc_tolerance(replications: int, published_replications: int = 300) -> float:
    """3 x relative standard error of the ratio of two sample standard deviations."""
    return 3.0 * np.sqrt(1.0 / (2.0 * (replications - 1)) + 1.0 / (2.0 * (published_replications - 1)))


def _worst(name, source, ours, published, tol, note=""):
    """One check for a table: the entry with the largest |ours - published|."""
    ours, published = np.ravel(ours), np.ravel(published)
    k = int(np.argmax(np.abs(ours - published)))
    return within_abs(name, source, ours[k], published[k], tol, note or f"worst of {ours.size} entries (#{k + 1})")


def spreadsheet_checks() -> list[Check]:
    """HV Fig 8-1: clean and measured triads (2 decimals), survey without MSA (1 decimal)."""
    pub = published_numbers()["hv_spreadsheet2"]
    traj = hv_spreadsheet2()
    ref = FieldReference(pub["b_total_ut"], pub["dip_deg"])
    g, b = tool_readings(traj.toolface_deg, traj.inc_deg, traj.azi_deg, ref)
    b_m = apply_errors(b, params_array(pub["scale"], pub["bias_ut"]))
    s = survey_from_readings(g, b_m)
    rows = pub["rows"]
    k = np.searchsorted(traj.md_m, [r["md_m"] for r in rows])
    src = f"{HV} Fig 8-1 (spreadsheet 2), digest 13.1"
    out = [
        _worst("HV sheet: clean accelerometer triads [g]", src, g[k], [r["g"] for r in rows], 0.005),
        _worst("HV sheet: clean magnetometer triads [uT]", src, b[k], [r["b_clean"] for r in rows], 0.005),
        _worst("HV sheet: measured magnetometer triads [uT]", src, b_m[k], [r["b_meas"] for r in rows], 0.005),
        _worst("HV sheet: dip without MSA [deg]", src, s.dip_rad[k] / DEG, [r["dip_deg"] for r in rows], 0.05),
        _worst("HV sheet: total field without MSA [uT]", src, s.b_total_ut[k], [r["b_total_ut"] for r in rows], 0.05),
    ]
    azi = {r["md_m"]: r["azi_deg"] for r in rows if r["azi_deg"] is not None}
    azi.update({float(m): a for m, a in pub["more_azimuths_deg"].items()})
    md = np.array(sorted(azi))
    ours = s.azi_rad[np.searchsorted(traj.md_m, md)] / DEG
    out.append(_worst("HV sheet: azimuth without MSA [deg]", src, ours, [azi[m] for m in md], 0.05))
    return out


def mcm_sheet_checks() -> list[Check]:
    """HV Fig 8-3: minimum-curvature positions (1 m) and raw field triads (B 50 uT, dip 80 deg)."""
    pub = published_numbers()["hv_mcm_sheet"]
    traj = hv_mcm_sheet()
    pos = np.vstack([np.zeros(3), np.cumsum(displacements(traj.md_m, traj.inc_deg * DEG, traj.azi_deg * DEG), axis=0)])
    rows = np.array(pub["positions"], dtype=float)
    k = np.searchsorted(traj.md_m, rows[:, 0])
    src = f"{HV} Fig 8-3 (MCM sheet), digest 13.2"
    raw = np.array(pub["raw"], dtype=float)
    _, b = tool_readings(raw[:, 1], raw[:, 2], raw[:, 3], FieldReference(pub["b_total_ut"], pub["dip_deg"]))
    return [
        _worst("HV MCM sheet: N, E, TVD [m]", src, pos[k], rows[:, 1:], 0.5),
        _worst("HV MCM sheet: raw field triads [uT]", src, b, raw[:, 4:], 0.005),
    ]


def _hv_mc(name: str, scenario: int, n_starts: int = 1):
    base = HV_SCENARIOS[scenario]
    cfg = MonteCarloConfig(**{**base.__dict__, "replications": VALIDATE_REPLICATIONS, "n_starts": n_starts, "seed": 9})
    return run_monte_carlo(trajectory(name), HV_REFERENCE, HV_TRUTH, cfg, progress=False)


def monte_carlo_checks() -> list[Check]:
    """HV Table 9 (scenario 1) N/E 1.96-sigma for surveys 1, 2, 4, 5, 6; survey 1 parameters; S3/S7 documented."""
    pub = published_numbers()
    tol = mc_tolerance(VALIDATE_REPLICATIONS, pub["hv_table9"]["replications"])
    src = f"{HV} Table 9 (scenario 1, noise 3.3 nT)"
    note = f"M = {VALIDATE_REPLICATIONS}; tol = 3 x RSS of the two sample-std standard errors"
    out = []
    for name in MC_SURVEYS:
        res = _hv_mc(name, 1)
        published = pub["hv_table9"][name]["position"]
        for axis, idx in (("N", 0), ("E", 1)):
            out.append(within_rel(f"HV MC S{name[-1]}: 1.96 sigma {axis} [m]", src, res.position_spread_m[idx], published[idx], tol, note))
        if name == "hv1":
            labels = ("bias x", "bias y", "bias z", "scale x", "scale y", "scale z")
            values = pub["hv_table9"][name]["bias"] + pub["hv_table9"][name]["scale"]
            for label, ours, published_v in zip(labels, res.theta_spread, values):
                out.append(within_rel(f"HV MC S1: 1.96 sigma {label}", src, ours, published_v, tol, note))
    u_cache = {}
    for name in ILL_CONDITIONED:
        traj = trajectory(name)
        g, b = tool_readings(traj.toolface_deg, traj.inc_deg, traj.azi_deg, HV_REFERENCE)
        u_cache[name] = condition_numbers(HV_TRUTH[None], g / np.linalg.norm(g, axis=1, keepdims=True), apply_errors(b, HV_TRUTH), HV_REFERENCE.bh_ut, HV_REFERENCE.bv_ut)[0][0]
        res = _hv_mc(name, 1, n_starts=4)
        published = pub["hv_table9"][name]["position"][0]
        out.append(
            within_rel(
                f"HV MC S{name[-1]} (ill-conditioned): 1.96 sigma N [m]",
                src,
                res.position_spread_m[0],
                published,
                tol,
                f"cond(J^T J) = {u_cache[name]:.3g} at the truth (S1: 2.67e5); 4 starts, lowest L. HV's Excel GRG "
                "(rel. convergence 1e-4) stops early on this nearly singular problem (HV Ch 6, digest 14): not a strict target",
            )
        )
    src3 = f"{HV} Table 11 (scenario 3, HDGM errors)"
    for name in ("hv1", "hv4"):
        res = _hv_mc(name, 3)
        published = pub["hv_table11"][name]
        for axis, idx in (("N", 0), ("E", 1)):
            out.append(within_rel(f"HV MC scenario 3 S{name[-1]}: 1.96 sigma {axis} [m]", src3, res.position_spread_m[idx], published[idx], tol, note))
    return out


def sv_monte_carlo_checks() -> list[Check]:
    """SV Tables 5 and 8: 3-sigma of the final N/E and of b_z, s_z from the MSA Monte Carlo (noise 70 nT + HDGM).

    SV does not state its replication count; the tolerance assumes at least HV's 300 (stated in each note)."""
    pub = published_numbers()["sv_mc_table5_table8"]
    tol = mc_tolerance(VALIDATE_REPLICATIONS, 300)
    note = f"M = {VALIDATE_REPLICATIONS}, 2 starts; SV's M not stated (tolerance assumes 300)"
    out = []
    for name in ("sv1", "sv2"):
        p = pub[name]
        cfg = MonteCarloConfig(noise_nt=70.0, sigma_b_nt=107.0, sigma_dip_deg=0.16, replications=VALIDATE_REPLICATIONS, n_starts=2, seed=9, k_sigma=3.0)
        res = run_monte_carlo(trajectory(name), HV_REFERENCE, params_array(p["truth_scale"], p["truth_bias_ut"]), cfg, progress=False)
        t = name[-1]
        for label, ours, theirs, table in (
            ("N [m]", res.position_spread_m[0], p["three_sigma_ne_m"][0], "8"),
            ("E [m]", res.position_spread_m[1], p["three_sigma_ne_m"][1], "8"),
            ("bias z [uT]", res.theta_spread[2], p["three_sigma_theta"][2], "5"),
            ("scale z", res.theta_spread[5], p["three_sigma_theta"][5], "5"),
        ):
            extra = ""
            if name == "sv1":
                extra = (
                    "; T1 (near-horizontal, A = 75) is heavy-tailed (excess kurtosis ~3, so the normal-theory "
                    "tolerance is optimistic); ours 360-420 m N over seeds, the digest's re-implementation 392 m"
                )
            out.append(within_rel(f"SV MC T{t}: 3 sigma {label}", f"{SV} Table {table}", ours, theirs, tol, note + extra))
    return out


def wls_checks() -> list[Check]:
    """SV Table 7: WLS estimates and 3 sqrt(diag U) of tests 2 and 3 (4 decimals); test 4 3-sigma; T1, T4 gaps."""
    pub = published_numbers()["sv_wls_table7"]
    out = []
    src = f"{SV} Table 7 (WLS), digest 10"
    for name in ("sv1", "sv2", "sv3", "sv4"):
        traj = trajectory(name)
        _, b = tool_readings(traj.toolface_deg, traj.inc_deg, traj.azi_deg, HV_REFERENCE)
        p = pub[name]
        truth = params_array(p["truth_scale"], p["truth_bias_ut"]) if "truth_scale" in p else params_array([1, 1, 1], [0, 0, 0])
        res = wls_estimate(b, apply_errors(b, truth))
        est = np.concatenate([res.bias_ut, res.scale])
        three = 3.0 * res.sigma
        pe = np.array([np.nan if v is None else v for v in p["estimate"]])
        ps = np.array([np.nan if v is None else v for v in p["three_sigma"]])
        keep = np.isfinite(pe)
        t = name[-1]
        if name == "sv4":
            out.append(_worst(f"SV WLS T{t}: 3 sigma", src, three, ps, 0.00005))
            out.append(
                within_abs(f"SV WLS T{t}: estimate b_x [uT]", src, est[0], pe[0], 0.00005,
                           "not reproducible: T4 is real data and its measured triads are not published (shown: noise-free, no error)")
            )
            continue
        note = "" if name != "sv1" else "SV evidently used other T1 inputs for WLS (digest 14, 15 #9)"
        out.append(_worst(f"SV WLS T{t}: estimate", src, est[keep], pe[keep], 0.00005, note))
        out.append(_worst(f"SV WLS T{t}: 3 sigma", src, three[np.isfinite(ps)], ps[np.isfinite(ps)], 0.00005, note))
    return out


def covariance_checks() -> list[Check]:
    """SV Tables 10/11: covariance-method 3-sigma N/E (random, systematic) and the systematic/random ratio."""
    pub = published_numbers()["sv_covariance"]
    out = []
    gap = "SV's magnitudes exceed ours by 1.10-1.32 with the same geometry (ratios match); cause unknown (digest 14)"
    for name in ("sv1", "sv2", "sv3", "sv4"):
        traj = trajectory(name)
        p = pub[name]
        sig = np.array(p["table5_three_sigma"]) / 3.0
        three = {}
        for mode, key in (("R", "random"), ("S", "systematic")):
            c = covariance_position(traj.md_m, traj.inc_deg, traj.azi_deg, sig, HV_REFERENCE, mode)[-1]
            three[mode] = 3.0 * np.sqrt(np.diag(c))[:2]
            table = "10" if mode == "R" else "11"
            out.append(within_rel(f"SV covariance T{name[-1]} {key}: 3 sigma N [m]", f"{SV} Table {table}", three[mode][0], p[key][0], 0.05, gap))
        ratio = three["S"][0] / three["R"][0]
        out.append(
            within_rel(
                f"SV covariance T{name[-1]}: systematic / random N",
                f"{SV} Tables 10-11",
                ratio,
                p["systematic"][0] / p["random"][0],
                0.05,
            )
        )
    return out


CHECKS = [spreadsheet_checks, mcm_sheet_checks, monte_carlo_checks, sv_monte_carlo_checks, wls_checks, covariance_checks]
