"""Per-node metrics of a chain run (flat keys, degrees at the edge; documented in README).

For every node, over its metric ticks (inside the metrics windows: the lab's RMS window, or the settled
part of each drilling survey stop; only where the node's filter runs):
- ``rms_azimuth_error_deg``: RMS of wrap(A_reported - A_true), A_reported being the moving-averaged
  azimuth the firmware reports (thesis table 4.22: 32-point MAF);
  (with ``metrics.output_moving_average_points`` > 1 a further moving average is applied to the reported
  I and A first: thesis figs 4.16/4.20 plot and read them through a 100-point MAF);
- ``rms_inclination_error_deg``: the same for inclination;
  (both against the run's reference attitude: the exact geometry, or with ``metrics.reference_accuracy_pct`` > 0 on
  the lab profile the truth as the thesis's rig has it, measured once per run and node after the initial
  calibration, :func:`reference_attitude`);
- ``rms_yaw_error_deg``: RMS of wrap(psi_hat - psi_true) (unsmoothed filter output);
- ``max_timeout_yaw_error_deg``: the yaw-error envelope in timeouts: max |yaw error| over metric ticks
  without a reference update (NaN when every tick had one);
- ``bias_convergence_time_s``: time from the end of the last rotation until |b_hat - b| <= tolerance for
  ``bias_hold_s`` (thesis digest 5.4 criterion); NaN if never;
- ``bias_converged_fraction``: share of realizations whose bias converged;
- ``update_fraction``: share of metric ticks that applied a reference update;
- ``mean_update_age_s``: mean age of the reference at use (encoder read or forwarded estimate);
- ``max_time_since_update_s``: the longest time over the metric ticks since the node last applied a
  reference update (from the node's filter start; how stale its estimate got).
Chain-wide: ``adc_clipped_samples``, the IMU axis readings (gyro and accelerometer) clipped at full scale, summed
over every node (mean over realizations; no p95); with ``filter.states = 6``, ``singular_ticks``, the node-ticks
whose 6-state filter was inside its singularity margin (pitch near +/-90 deg; summed over the nodes, mean over
realizations, no p95; a run prints :func:`singularity_warning` when it is > 0).
Each is computed per realization; the summary gives the mean over realizations and, for R > 1, the 95th
percentile under ``*_p95``.  The headline keys are those of the bottom node (the last in the chain, the
one whose survey the ground station uses); every node also appears as ``node<id>_<key>``.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
from numba import njit

from firmware_model.survey_resolution import CircularAverage, TrailingAverage
from nodesim.chain.linkmetrics import link_metrics
from nodesim.chain.records import ChainRun, NodeRun
from nodesim.motion.timelines import ChainMotion
from nodesim.scenario.schema import MetricsSection
from nodesim.units import rad_to_deg, wrap_pi

PER_NODE_KEYS = (
    "rms_azimuth_error_deg",
    "rms_inclination_error_deg",
    "rms_yaw_error_deg",
    "max_timeout_yaw_error_deg",
    "bias_convergence_time_s",
    "bias_converged_fraction",
    "update_fraction",
    "mean_update_age_s",
    "max_time_since_update_s",
)


def metric_ticks(node: NodeRun, windows) -> np.ndarray:
    """(K,) bool: the node's ticks inside any metrics window [a, b] where its filter runs.  The tick times
    increase (:func:`nodesim.chain.faults.stepped_ticks`), so a window is the index range
    [searchsorted(t, a, left), searchsorted(t, b, right)): O(K + W log K) for W windows (a drilling day has one
    per survey stop, ~200, over ~160 k ticks a node; comparing every tick with every window took ~13 ms a node),
    in one compiled pass (:func:`_mark_windows`: a Python loop over the windows' slices took ~0.2 ms a node's
    window of a drilling day, ~0.6 % of its CPU)."""
    sel = np.zeros(node.t_s.shape, dtype=bool)
    if windows:
        a, b = np.asarray(windows, dtype=float).T
        _mark_windows(np.ascontiguousarray(node.t_s, dtype=float), np.ascontiguousarray(a), np.ascontiguousarray(b),
                      sel)
    return sel & node.running


@njit(cache=True, _nrt=False, nogil=True)
def _mark_windows(t, a, b, sel) -> None:
    """``sel[searchsorted(t, a_i, left) : searchsorted(t, b_i, right)] = True`` for every window i (``t``
    increasing)."""
    for i in range(a.size):
        lo, hi = np.searchsorted(t, a[i], side="left"), np.searchsorted(t, b[i], side="right")
        for k in range(lo, hi):
            sel[k] = True


def bias_convergence_time_s(node: NodeRun, after_s: float, tolerance_rad_s: float, hold_s: float) -> np.ndarray:
    """Per realization: first time after ``after_s`` from which |b_hat - b| <= tol for ``hold_s`` (h =
    ceil(hold_s / dt) ticks in a row, dt the node's first tick step: the start of the first run of h running ticks
    after ``after_s`` inside the band, :func:`_hold_runs`); NaN if none."""
    band = _new_band(node.bias_est_rad_s.shape[0])
    _band_runs(node, after_s, tolerance_rad_s, bias_hold_ticks(node.t_s, hold_s), band)
    return band[2] - after_s


def _new_band(R: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`_hold_runs`' carry before any tick: (run length, its first tick's time, the time found: NaN)."""
    return np.zeros(R, np.int64), np.full(R, np.nan), np.full(R, np.nan)


def _band_runs(node: NodeRun, after_s: float, tolerance_rad_s: float, hold_ticks: int, band: tuple) -> None:
    """:func:`_hold_runs` over the node's running ticks at or after ``after_s`` (only those: a drilling day's last
    rotation ends late), inside the band |b_hat - b| <= tol, carrying ``band``."""
    after = np.flatnonzero((node.t_s >= after_s) & node.running)
    inside = np.abs(node.bias_est_rad_s[:, after] - node.true_bias_rad_s[:, after]) <= tolerance_rad_s
    _hold_runs(inside, node.t_s[after], hold_ticks, *band)


def bias_hold_ticks(t_s: np.ndarray, hold_s: float) -> int:
    """ceil(hold_s / dt) (at least 1), dt = t_1 - t_0 (1 s for a node of one tick)."""
    dt = t_s[1] - t_s[0] if t_s.size > 1 else 1.0
    return max(int(math.ceil(hold_s / dt)), 1)


@njit(cache=True, _nrt=False, nogil=True)
def _hold_runs(inside, t, hold, length, start, found) -> None:
    """Per realization r not yet ``found``: the runs of consecutive True in ``inside[r]`` (ticks at ``t``), going on
    from the run carried in (``length[r]`` ticks from ``start[r]``); ``found[r]`` = the first tick of the first run
    that reaches ``hold`` ticks.  The run is carried out, so ticks given window by window find what they find at
    once (the same first tick, the same time)."""
    for r in range(inside.shape[0]):
        if not np.isnan(found[r]):
            continue
        n, t0 = length[r], start[r]
        for i in range(inside.shape[1]):
            if not inside[r, i]:
                n = 0
                continue
            if n == 0:
                t0 = t[i]
            n += 1
            if n >= hold:
                found[r] = t0
                break
        length[r], start[r] = n, t0


class _OutputAverage:
    """:func:`output_average` window by window: from the node's first finite sample on, the ``points``-point
    trailing average of the inclination and the circular one of the azimuth
    (:class:`~firmware_model.survey_resolution.TrailingAverage`, :class:`~firmware_model.survey_resolution.CircularAverage`)."""

    def __init__(self, points: int):
        self.averages = (TrailingAverage(points), CircularAverage(points)) if points > 1 else None
        self.started = False

    def add(self, inclination_rad: np.ndarray, azimuth_rad: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        if self.averages is None:
            return inclination_rad, azimuth_rad
        inc, azi = inclination_rad.copy(), azimuth_rad.copy()
        a = 0
        if not self.started:
            finite = np.flatnonzero(np.isfinite(inc[0]))
            if not finite.size:
                return inc, azi
            a, self.started = int(finite[0]), True
        inc[:, a:] = self.averages[0].add(inc[:, a:])
        azi[:, a:] = self.averages[1].add(azi[:, a:])
        return inc, azi


def output_average(node: NodeRun, points: int) -> tuple[np.ndarray, np.ndarray]:
    """Reported (inclination, azimuth) after a further ``points``-point moving average from the node's first
    finite sample (``points`` = 1: unchanged)."""
    return _OutputAverage(points).add(node.inclination_rad, node.azimuth_rad)


def reference_attitude(true_inclination_rad: np.ndarray, true_azimuth_rad: np.ndarray,
                       error_rad: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """(inclination, azimuth) the errors are measured against: the truth ``(K,)`` itself (``error_rad`` None), or,
    for ``error_rad`` (R, 2) = (along, across the tilt) [rad], the tube axis u = (sin I cos A, sin I sin A, cos I)
    moved by along * dU/dI + across * dU/dA / sin I and normalised, (R, K) each: the reference inclination is off
    by ``along``, the reference azimuth by ``across / sin I`` (to first order)."""
    if error_rad is None:
        return true_inclination_rad, true_azimuth_rad
    inc, azi = true_inclination_rad[None, :], true_azimuth_rad[None, :]
    along, across = error_rad[:, 0:1], error_rad[:, 1:2]
    si, ci, sa, ca = np.sin(inc), np.cos(inc), np.sin(azi), np.cos(azi)
    x = si * ca + along * ci * ca - across * sa
    y = si * sa + along * ci * sa + across * ca
    z = ci - along * si
    return np.arctan2(np.hypot(x, y), z), np.arctan2(y, x)


def node_metrics(motion: ChainMotion, node: NodeRun, window: MetricsSection) -> dict[str, np.ndarray]:
    """Metric arrays of shape (R,) for one node, in edge units (deg, s) (``motion``: the run's metric windows and
    the end of its last rotation): :class:`NodeMetricSums` of all its ticks at once."""
    sums = NodeMetricSums(motion, window, node.yaw_est_rad.shape[0], bias_hold_ticks(node.t_s, window.bias_hold_s))
    sums.add(node)
    return sums.metrics()


class NodeMetricSums:
    """The sums and carried states behind :func:`node_metrics`, fed a node's records window by window of its ticks
    (:meth:`add`: consecutive :class:`NodeRun` pieces, :meth:`NodeRun.ticks`), so that a run need not hold them
    whole.  Per realization: the sums of the squared azimuth, inclination and yaw errors over the metric ticks and
    their count, the timeout envelope (a max), the updates and the sum and count of their ages, the output average's
    running averages (:class:`_OutputAverage`), the bias band's run (:func:`_hold_runs`) and the last update and longest
    time since one (:func:`_max_time_since_update`).  All ticks in one window: the values of the whole-run
    definitions, bit for bit; in several windows the same, except the RMS errors and the mean age, whose window
    sums are added (numpy sums each window pairwise): equal to rounding (~1e-15 relative; tested)."""

    def __init__(self, motion: ChainMotion, window: MetricsSection, R: int, hold_ticks: int):
        self.motion, self.window, self.R, self.hold_ticks = motion, window, R, hold_ticks
        self.ticks = 0  # metric ticks
        self.squares = np.zeros((3, R))  # azimuth, inclination, yaw errors [rad^2]
        self.envelope = np.full(R, -np.inf)
        self.updates = np.zeros(R)
        self.age_sum, self.age_count = np.zeros(R), np.zeros(R, np.int64)
        self.average = _OutputAverage(window.output_moving_average_points)
        self.band = _new_band(R)
        self.since = (np.full(R, -np.inf), np.full(R, -np.inf), np.zeros(R, np.bool_))  # last update, max, NaN seen

    def add(self, node: NodeRun) -> None:
        """The records of the node's next ticks."""
        motion = self.motion
        sel = metric_ticks(node, motion.metric_windows)
        idx = np.flatnonzero(sel)  # the same elements in the same order as the mask, found once: a drilling day's
        # node selects ~5 % of its ~160 k ticks, and each boolean index over (R, K) counted and found them again
        inc, azi = self.average.add(node.inclination_rad, node.azimuth_rad)
        if idx.size:
            ref_inc, ref_azi = reference_attitude(node.true_inclination_rad[idx], node.true_azimuth_rad[idx],
                                                  node.reference_error_rad)
            yaw_err = wrap_pi(node.yaw_est_rad[:, idx] - node.true_yaw_rad[idx])
            for i, err in enumerate((wrap_pi(azi[:, idx] - ref_azi), inc[:, idx] - ref_inc, yaw_err)):
                self.squares[i] += np.add.reduce(np.square(err), axis=-1)
            update = node.update_mask[:, idx]
            np.maximum(self.envelope, np.where(~update, np.abs(yaw_err), -np.inf).max(axis=1), out=self.envelope)
            self.updates += np.add.reduce(update, axis=1, dtype=float)
            ages = np.where(update, node.update_age_s[:, idx], np.nan)
            known = ~np.isnan(ages)
            self.age_sum += np.add.reduce(np.where(known, ages, 0.0), axis=1)
            self.age_count += known.sum(axis=1)
            self.ticks += idx.size
        _max_time_since_update(np.ascontiguousarray(node.t_s, dtype=float), np.ascontiguousarray(node.update_mask),
                               sel, float(node.filter_start_s), *self.since)  # (updates move it on in any window)
        _band_runs(node, motion.rotation_end_s, math.radians(self.window.bias_tolerance_deg_s), self.hold_ticks,
                   self.band)

    def metrics(self) -> dict[str, np.ndarray]:
        """The node's metrics (:func:`node_metrics`) from the ticks added."""
        nan, n = np.full(self.R, np.nan), self.ticks
        convergence = self.band[2] - self.motion.rotation_end_s
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # no update: NaN on purpose (0 / 0)
            age = self.age_sum / self.age_count
        return {
            "rms_azimuth_error_deg": rad_to_deg(np.sqrt(self.squares[0] / n)) if n else nan,
            "rms_inclination_error_deg": rad_to_deg(np.sqrt(self.squares[1] / n)) if n else nan,
            "rms_yaw_error_deg": rad_to_deg(np.sqrt(self.squares[2] / n)) if n else nan,
            "max_timeout_yaw_error_deg": np.where(np.isfinite(self.envelope), rad_to_deg(self.envelope), np.nan),
            "bias_convergence_time_s": convergence,
            "bias_converged_fraction": np.isfinite(convergence).astype(float),
            "update_fraction": self.updates / n if n else nan,
            "mean_update_age_s": age,
            "max_time_since_update_s": np.where(self.since[2], np.nan, self.since[1]) if n else nan,
        }


def max_time_since_update_s(node: NodeRun, sel: np.ndarray) -> np.ndarray:
    """(R,) the longest time since the last applied update (or since the filter start, when later) over the ticks
    ``sel``: max over k in sel of t_k - max(t_last update <= k, t_start), NaN where a tick of ``sel`` lies before
    the start (or ``sel`` is empty).  One compiled pass (:func:`_max_time_since_update`) instead of four (R, K)
    arrays: the same values (a max of the same differences)."""
    R = node.update_mask.shape[0]
    if not sel.any():
        return np.full(R, np.nan)
    since = (np.full(R, -np.inf), np.full(R, -np.inf), np.zeros(R, np.bool_))
    _max_time_since_update(np.ascontiguousarray(node.t_s, dtype=float), np.ascontiguousarray(node.update_mask),
                           np.ascontiguousarray(sel), float(node.filter_start_s), *since)
    return np.where(since[2], np.nan, since[1])


@njit(cache=True, _nrt=False, nogil=True)
def _max_time_since_update(t, update, sel, start, last, best, seen_nan) -> None:
    """Per realization r, over ticks k: ``last[r]`` the latest update's time, ``best[r]`` the max over the ``sel``
    ticks of t_k - max(last, start), ``seen_nan[r]`` whether a ``sel`` tick lay before the start (numpy's max:
    NaN then); carried in and out, so ticks given window by window give what they give at once."""
    for r in range(update.shape[0]):
        for k in range(t.size):
            if update[r, k]:
                last[r] = max(last[r], t[k])
            if sel[k]:
                v = t[k] - max(last[r], start) if t[k] >= start else np.nan
                if np.isnan(v):
                    seen_nan[r] = True
                elif v > best[r]:
                    best[r] = v


def per_realization_metrics(run: ChainRun, window: MetricsSection) -> dict[str, np.ndarray]:
    """All metric arrays (R,): the headline keys (bottom node), ``node<id>_*`` per node, packet counts."""
    out: dict[str, np.ndarray] = {}
    nodes = run.node_results  # a streamed run's summaries carry the metrics computed node by node
    per_node = [node_metrics(run.motion, n, window) for n in run.nodes] if run.nodes else [s.metrics for s in nodes]
    out.update(per_node[-1])
    for node, m in zip(nodes, per_node):
        out.update({f"node{node.node_id}_{k}": v for k, v in m.items()})
    out["stale_packets"] = sum(n.stale_packets for n in nodes).astype(float)
    out["duplicate_packets"] = sum(n.duplicate_packets for n in nodes).astype(float)
    out["lost_packets"] = run.lost_packets.astype(float)
    # ADC readings (gyro and accelerometer, per axis) clipped at full scale, summed over the nodes
    # (nodesim.sensors.chain_imu); the summary gives the mean over realizations
    R = run.lost_packets.shape[0]
    out["adc_clipped_samples"] = sum((n.adc_clipped_samples if n.adc_clipped_samples is not None else np.zeros(R))
                                     for n in nodes).astype(float)
    singular = [n.singular_ticks for n in nodes if n.singular_ticks is not None]
    if singular:  # filter.states = 6: node-ticks whose Euler-rate terms fell inside the singularity margin
        out["singular_ticks"] = sum(singular).astype(float)
    out.update(link_metrics(run))
    if run.motion.stops:
        received = np.zeros(R)
        for g in run.surveys:
            received += g.packet.valid
        out["surveys_received"] = received
    return out


def singularity_warning(summary: dict) -> str | None:
    """The warning a run prints when its 6-state filters spent node-ticks inside the singularity margin
    (``singular_ticks`` > 0: the Euler-rate terms 1/cos(pitch) were held or decoupled there,
    firmware_model.six_state_filter), None otherwise."""
    n = summary.get("singular_ticks")
    if not n:
        return None
    return (f"warning: singular_ticks = {n:.6g} (mean over realizations, all nodes): the 6-state filter's pitch came "
            "within filter.singularity_margin_deg of +/-90 deg and its Euler-rate terms were "
            "held/decoupled there (filter.singularity); its yaw is approximate in those ticks")


def summarize(per_realization: dict[str, np.ndarray]) -> dict[str, float | None]:
    """Flat summary: mean over realizations (NaN -> None in JSON), plus p95 when R > 1 (not for counts
    and fractions)."""
    out: dict[str, float | None] = {}
    no_p95 = ("_fraction", "_packets", "surveys_received", "_ratio", "_retransmissions", "_latency_s",
              "_radio_energy_j", "queue_drops", "fallback_frames", "_clipped_samples",
              "crc_rejected_frames", "undetected_frame_errors", "singular_ticks")
    for key, values in per_realization.items():
        finite = values[np.isfinite(values)]
        out[key] = float(np.mean(finite)) if finite.size else None
        if values.size > 1 and not key.endswith(no_p95):
            out[f"{key}_p95"] = float(np.percentile(finite, 95)) if finite.size else None
    out["realizations"] = int(next(iter(per_realization.values())).size)
    return out
