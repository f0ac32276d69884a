"""Headline metrics of a lab run (flat keys, degrees at the edge; documented in README).

- ``rms_azimuth_error_deg``: RMS over the metrics window of wrap(A_reported - A_true), A_reported being
  the moving-averaged azimuth the firmware reports (thesis table 4.22 uses 350-550 s and a 32-point MAF).
- ``rms_inclination_error_deg``: the same for inclination.
- ``rms_yaw_error_deg``: RMS of wrap(psi_hat - psi_true) over the window (unsmoothed filter output).
- ``bias_convergence_time_s``: time from the end of the last rotation until the estimated gyro bias stays
  within +/- tolerance of the true bias for ``bias_hold_s`` (thesis digest 5.4 criterion); NaN if never.
Each is computed per realization; the summary reports the mean over realizations and, for R > 1, the
95th percentile under ``*_p95``.
- ``bias_converged_fraction``: share of realizations whose bias converged (the time is averaged over those).
- ``update_fraction``: share of ticks in the window that applied a reference update.
"""

from __future__ import annotations

import math

import numpy as np

from nodesim.scenario import MetricsSection
from nodesim.simulation import LabRun
from nodesim.units import rad_to_deg, wrap_pi


def _rms(x: np.ndarray, axis: int = -1) -> np.ndarray:
    return np.sqrt(np.mean(np.square(x), axis=axis))


def bias_convergence_time_s(run: LabRun, tolerance_rad_s: float, hold_s: float) -> np.ndarray:
    """Per realization: first time after ``run.rotation_end_s`` from which |b_hat - b| <= tol for ``hold_s``."""
    t = run.t_s
    after = t >= run.rotation_end_s
    inside = np.abs(run.bias_est_rad_s - run.true_bias_rad_s) <= tolerance_rad_s
    dt = t[1] - t[0]
    hold_ticks = max(int(math.ceil(hold_s / dt)), 1)
    out = np.full(inside.shape[0], np.nan)
    idx_after = np.flatnonzero(after)
    for r in range(inside.shape[0]):
        ok = inside[r, idx_after].astype(int)
        if ok.size < hold_ticks:
            continue
        run_len = np.convolve(ok, np.ones(hold_ticks, dtype=int), mode="valid")
        hits = np.flatnonzero(run_len == hold_ticks)
        if hits.size:
            out[r] = t[idx_after[hits[0]]] - run.rotation_end_s
    return out


def per_realization_metrics(run: LabRun, window: MetricsSection) -> dict[str, np.ndarray]:
    """Metric arrays of shape (R,), in edge units (deg, s)."""
    sel = (run.t_s >= window.window_start_s) & (run.t_s <= window.window_end_s)
    azi_err = wrap_pi(run.azimuth_rad[:, sel] - run.true_azimuth_rad)
    inc_err = run.inclination_rad[:, sel] - run.true_inclination_rad
    yaw_err = wrap_pi(run.yaw_est_rad[:, sel] - run.true_yaw_rad[sel])
    convergence = bias_convergence_time_s(run, math.radians(window.bias_tolerance_deg_s), window.bias_hold_s)
    return {
        "rms_azimuth_error_deg": rad_to_deg(_rms(azi_err)),
        "rms_inclination_error_deg": rad_to_deg(_rms(inc_err)),
        "rms_yaw_error_deg": rad_to_deg(_rms(yaw_err)),
        "bias_convergence_time_s": convergence,
        "bias_converged_fraction": np.isfinite(convergence).astype(float),
        "update_fraction": run.update_mask[:, sel].mean(axis=1),
    }


def summarize(per_realization: dict[str, np.ndarray]) -> dict[str, float | None]:
    """Flat summary: mean over realizations (NaN -> None in JSON), plus p95 when R > 1."""
    out: dict[str, float | None] = {}
    for key, values in per_realization.items():
        finite = values[np.isfinite(values)]
        out[key] = float(np.mean(finite)) if finite.size else None
        if values.size > 1 and not key.endswith("_fraction"):
            out[f"{key}_p95"] = float(np.percentile(finite, 95)) if finite.size else None
    out["realizations"] = int(next(iter(per_realization.values())).size)
    return out
