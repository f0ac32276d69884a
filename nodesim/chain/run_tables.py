"""The tables of a chain run, as columns (the CSV files of its run directory; :class:`nodesim.api.Run`).

- ``timeseries.parquet`` (or ``.csv``, ``[output] format``): long (columnar) table, one row per node and tick of
  realization 0 (the nodes and ticks ``[output] timeseries`` keeps);
- ``surveys.csv``: the survey table the ground station received, one row per realization, station and
  surveying node (the bottom node; every node present with ``motion.survey_nodes = "all"``) (values are the
  surveying node's moving-averaged inclination/azimuth at the survey tick, thesis eqs 1.1-1.3;
  sigma_A^2 = P_psipsi + sigma_f^2 / (M (g sin I)^2), sigma_I^2 = sigma_f^2 / (M g^2) with
  sigma_f the per-tick accelerometer noise and M the moving-average length,
  :func:`nodesim.chain.packets.survey_sigmas_rad`; the fixed firmware's as decoded from the survey frames the
  ground station received, sigmas in their 2^-20-turn words);
- ``ground_survey.csv``: the bottom node's surveys (one per station) of realization 0 that reached the ground
  station, in the CSV form of ``nodesim uncertainty``
  (``md_m,inc_deg,azi_deg,time_s,sigma_inc_deg,sigma_azi_deg``);
- ``hops.csv``: one row per hop: medium, mean path loss and margin, frames, delivery ratio, retransmissions,
  latency, queue drops (means over realizations; :func:`nodesim.chain.linkmetrics.hop_table`);
- ``realizations.csv``: one row per realization with the per-realization metrics.
The yaw plot is :mod:`nodesim.chain.yaw_plot`.
"""

from __future__ import annotations

import numpy as np

from nodesim.chain.linkmetrics import hop_table
from firmware_model import node_survey as survey
from nodesim.chain.network import ChainRun
from nodesim.chain.packets import decode_survey, survey_sigmas_rad
from nodesim.scenario.output_section import OutputSection
from nodesim.units import rad_to_deg, wrap_pi

TIMESERIES_COLUMNS = ("node", "t_s", "running", "update", "update_age_s", "true_yaw_deg", "true_inclination_deg",
                      "true_azimuth_deg", "yaw_est_deg", "yaw_error_deg", "yaw_sigma_deg", "bias_true_deg_s",
                      "bias_est_deg_s", "inclination_deg", "azimuth_deg")


def timeseries_columns(run: ChainRun, r: int = 0, output: OutputSection = OutputSection()) -> dict[str, np.ndarray]:
    """Realization ``r``'s per-tick records of the nodes and ticks ``output.timeseries`` keeps (one row each)."""
    cols: dict[str, list[np.ndarray]] = {}
    step = output.tick_step
    for n in run.nodes:
        if not output.keeps_node(n.node_id, len(run.nodes)):
            continue
        part = {
            "node": np.full(n.t_s.size, n.node_id),
            "t_s": n.t_s,
            "running": n.running.astype(int),
            "update": n.update_mask[r].astype(int),
            "update_age_s": n.update_age_s[r],
            "true_yaw_deg": rad_to_deg(n.true_yaw_rad),
            "true_inclination_deg": rad_to_deg(n.true_inclination_rad),
            "true_azimuth_deg": rad_to_deg(n.true_azimuth_rad),
            "yaw_est_deg": rad_to_deg(n.yaw_est_rad[r]),
            "yaw_error_deg": rad_to_deg(wrap_pi(n.yaw_est_rad[r] - n.true_yaw_rad)),
            "yaw_sigma_deg": rad_to_deg(np.sqrt(n.yaw_var_rad2[r])),
            "bias_true_deg_s": rad_to_deg(n.true_bias_rad_s[r]),
            "bias_est_deg_s": rad_to_deg(n.bias_est_rad_s[r]),
            "inclination_deg": rad_to_deg(n.inclination_rad[r]),
            "azimuth_deg": rad_to_deg(n.azimuth_rad[r]),
        }
        for key, value in part.items():
            cols.setdefault(key, []).append(np.asarray(value)[::step])
    if not cols:  # output.timeseries = "none": the columns, no rows
        return {k: np.zeros(0) for k in TIMESERIES_COLUMNS}
    return {k: np.concatenate(v) for k, v in cols.items()}


def survey_columns(run: ChainRun) -> dict[str, np.ndarray]:
    """One row per realization and received-or-lost survey."""
    rows: dict[str, list] = {k: [] for k in (
        "realization", "station", "md_m", "node", "t_survey_s", "arrival_s", "received", "inclination_deg",
        "azimuth_deg", "sigma_inclination_deg", "sigma_azimuth_deg", "true_inclination_deg", "true_azimuth_deg")}
    by_id = {n.node_id: n for n in run.nodes}
    for g in run.surveys:
        p = g.packet
        n = by_id[p.node_id]
        true_inc, true_azi = n.true_inclination_rad[p.tick], n.true_azimuth_rad[p.tick]
        if g.frame is not None:  # the fixed firmware: what the ground station decoded from the survey frames
            got = decode_survey(g.frame)
            inc, azi = survey.inclination_rad(got["inc_raw"]), survey.azimuth_rad(got["azi_raw"])
            sigma_i, sigma_a = got["sigma_i_rad"], got["sigma_a_rad"]
        else:
            inc, azi = n.inclination_rad[:, p.tick], n.azimuth_rad[:, p.tick]
            sigma_i, sigma_a = survey_sigmas_rad(n.accel_sigma_m_s2, run.moving_average_points, true_inc,
                                                 n.yaw_var_rad2[:, p.tick])
        sigma_i = np.broadcast_to(sigma_i, inc.shape)
        for r in range(p.valid.shape[0]):
            for key, value in (
                ("realization", r), ("station", p.station), ("md_m", p.md_m), ("node", p.node_id),
                ("t_survey_s", p.t_s), ("arrival_s", g.arrival_s[r]), ("received", int(p.valid[r])),
                ("inclination_deg", rad_to_deg(inc[r])), ("azimuth_deg", rad_to_deg(azi[r])),
                ("sigma_inclination_deg", rad_to_deg(sigma_i[r])), ("sigma_azimuth_deg", rad_to_deg(sigma_a[r])),
                ("true_inclination_deg", rad_to_deg(true_inc)),
                ("true_azimuth_deg", rad_to_deg(true_azi)),
            ):
                rows[key].append(value)
    order = np.lexsort((np.asarray(rows["node"]), np.asarray(rows["station"]), np.asarray(rows["realization"]))) \
        if rows["station"] else []
    return {k: np.asarray(v)[order] for k, v in rows.items()}


def ground_survey_columns(table: dict[str, np.ndarray], r: int = 0) -> dict[str, np.ndarray]:
    """Realization ``r``'s received surveys in the ``nodesim uncertainty`` CSV columns: one per station, the
    bottom node's (the station's largest node id; the other nodes' surveys of ``motion.survey_nodes = "all"``
    stay in the survey table only)."""
    station, node = np.asarray(table["station"], dtype=np.int64), np.asarray(table["node"], dtype=np.int64)
    bottom = np.full(int(station.max(initial=0)) + 1, -1, dtype=np.int64)
    np.maximum.at(bottom, station, node)
    sel = (table["realization"] == r) & (table["received"] == 1) & (node == bottom[station])
    return {
        "md_m": table["md_m"][sel],
        "inc_deg": table["inclination_deg"][sel],
        "azi_deg": table["azimuth_deg"][sel],
        "time_s": table["arrival_s"][sel],
        "sigma_inc_deg": table["sigma_inclination_deg"][sel],
        "sigma_azi_deg": table["sigma_azimuth_deg"][sel],
    }


def run_tables(run: ChainRun, per_realization: dict[str, np.ndarray],
               output: OutputSection = OutputSection()) -> dict[str, dict[str, np.ndarray]]:
    """Every table of a run directory, by name (the file's stem), in the order they are written; the timeseries
    as ``output`` chooses."""
    R = next(iter(per_realization.values())).size
    tables = {
        "realizations": {"realization": np.arange(R), **per_realization},
        "timeseries": timeseries_columns(run, output=output),
        "hops": hop_table(run),
    }
    if run.motion.stops:
        tables["surveys"] = survey_columns(run)
        tables["ground_survey"] = ground_survey_columns(tables["surveys"])
    return tables
