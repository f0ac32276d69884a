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

from nodesim.chain import timeseries_rows
from nodesim.chain.linkmetrics import hop_table
from firmware_model import node_survey as survey
from nodesim.chain.records import ChainRun
from nodesim.chain.packets import decode_survey, survey_sigmas_rad
from nodesim.scenario.output_section import OutputSection
from nodesim.units import rad_to_deg

TIMESERIES_COLUMNS = ("node", "t_s", "running", "update", "update_age_s", "true_yaw_deg", "true_inclination_deg",
                      "true_azimuth_deg", "yaw_est_deg", "yaw_error_deg", "yaw_sigma_deg", "bias_true_deg_s",
                      "bias_est_deg_s", "inclination_deg", "azimuth_deg")


def node_timeseries(node, r: int = 0, step: int = 1, first_tick: int = 0) -> dict[str, np.ndarray]:
    """Realization ``r``'s per-tick records of one node (:class:`~nodesim.chain.records.NodeRun`, or a window of them
    from its tick ``first_tick``), every ``step``-th tick of the node's: its rows of the timeseries table
    (:mod:`nodesim.chain.timeseries_rows`: degrees, the yaw error wrapped into (-180, 180], the yaw sigma NaN where
    a diverged filter's variance is negative)."""
    part = timeseries_rows.rows(node, r, step, first_tick)
    return {k: part[k] for k in TIMESERIES_COLUMNS}


def empty_timeseries() -> dict[str, np.ndarray]:
    """The timeseries columns with no rows (``output.timeseries = "none"``)."""
    return {k: np.zeros(0) for k in TIMESERIES_COLUMNS}


def timeseries_columns(run: ChainRun, r: int = 0, output: OutputSection = OutputSection()) -> dict[str, np.ndarray]:
    """Realization ``r``'s per-tick records of the nodes and ticks ``output.timeseries`` keeps (one row each)."""
    parts = [node_timeseries(n, r, output.tick_step) for n in run.nodes if output.keeps_node(n.node_id, len(run.nodes))]
    if not parts:  # output.timeseries = "none": the columns, no rows
        return empty_timeseries()
    return {k: np.concatenate([p[k] for p in parts]) for k in TIMESERIES_COLUMNS}


SURVEY_COLUMNS = ("realization", "station", "md_m", "node", "t_survey_s", "arrival_s", "received", "inclination_deg",
                  "azimuth_deg", "sigma_inclination_deg", "sigma_azimuth_deg", "true_inclination_deg",
                  "true_azimuth_deg")


def node_survey_rows(node, surveys, moving_average_points: int) -> dict[str, np.ndarray]:
    """The survey-table rows of one node's ``surveys`` (the :class:`~nodesim.chain.records.GroundSurvey` it sent),
    one per realization and survey, from its records (:class:`~nodesim.chain.records.NodeRun`) at the survey tick,
    or as the ground station decoded them from the survey frames (the fixed firmware)."""
    rows: dict[str, list] = {k: [] for k in SURVEY_COLUMNS}
    for g in surveys:
        p = g.packet
        true_inc, true_azi = node.true_inclination_rad[p.tick], node.true_azimuth_rad[p.tick]
        if g.frame is not None:  # the fixed firmware: what the ground station decoded from the survey frames
            got = decode_survey(g.frame)
            inc, azi = survey.inclination_rad(got["inc_raw"]), survey.azimuth_rad(got["azi_raw"])
            sigma_i, sigma_a = got["sigma_i_rad"], got["sigma_a_rad"]
        else:
            inc, azi = node.inclination_rad[:, p.tick], node.azimuth_rad[:, p.tick]
            sigma_i, sigma_a = survey_sigmas_rad(node.accel_sigma_m_s2, moving_average_points, true_inc,
                                                 node.yaw_var_rad2[:, p.tick])
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
    return {k: np.asarray(v) for k, v in rows.items()}


def survey_columns(run: ChainRun) -> dict[str, np.ndarray]:
    """One row per realization and received-or-lost survey (sorted by realization, station, node)."""
    if run.nodes:
        by_node: dict[int, list] = {}
        for g in run.surveys:
            by_node.setdefault(g.packet.node_id, []).append(g)
        nodes = {n.node_id: n for n in run.nodes}
        parts = [node_survey_rows(nodes[i], by_node[i], run.moving_average_points) for i in sorted(by_node)]
    else:  # a streamed run: each node's rows were made before its records were dropped
        parts = [s.survey_rows for s in run.summaries]
    parts = [p for p in parts if p["station"].size]
    if not parts:
        return {k: np.asarray([]) for k in SURVEY_COLUMNS}
    rows = {k: np.concatenate([p[k] for p in parts]) for k in SURVEY_COLUMNS}
    order = np.lexsort((rows["node"], rows["station"], rows["realization"]))
    return {k: v[order] for k, v in rows.items()}


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
    as ``output`` chooses (None in a streamed run: its rows were written as the nodes finished,
    :mod:`nodesim.chain.streaming`)."""
    R = next(iter(per_realization.values())).size
    tables = {
        "realizations": {"realization": np.arange(R), **per_realization},
        "timeseries": timeseries_columns(run, output=output) if run.nodes or not run.summaries else None,
        "hops": hop_table(run),
    }
    if run.motion.stops:
        tables["surveys"] = survey_columns(run)
        tables["ground_survey"] = ground_survey_columns(tables["surveys"])
    return tables
