"""``nodesim run --record LOG``: a chain run (one realization) written in the replay log format.

One row per node and firmware tick from the node's power-up (``tick`` = 1), SI units:
  - ``gyro_z``: the tick-averaged z-gyro rate the node's filter used (``gyro_x``/``gyro_y`` are 0: the chain
    simulates the z axis only); ``accel_*``: the tick-averaged sensor-frame specific force;
  - ``gyro_sum_*``, ``accel_sum_*``, ``samples``: the integer sums of the int16 counts the node read per tick
    and their number (what the fixed-point firmware consumes);
  - ``encoder``: the encoder reading at the tick (the lab setup starts every node from it);
  - ``static``, ``hold``: the node's static bias window and its tube-insertion holds;
  - ``ref_update``, ``ref_yaw``, ``ref_var``: the reference each applied update used (encoder for the top node,
    the forwarded estimate advanced by eq 3.29 for the others) - the recorded schedule;
  - ``fw_yaw``, ``fw_yaw_var``, ``fw_bias``, ``fw_inclination``, ``fw_azimuth``: the node's outputs (the
    static window has yaw only, like the firmware);
  - ``true_yaw``, ``true_inclination``, ``true_azimuth``: the truth;
  - ``frame``: the estimate frame the node sent at the tick (fixed firmware), 54 hex digits.
Replaying the log with the scenario as firmware configuration reproduces the outputs and the frames bit for bit on lab
and drilling runs (``tests/nodesim/replay/test_round_trip.py``).
"""

from __future__ import annotations

import numpy as np

from nodesim.motion.timelines import ChainMotion
from nodesim.chain.sensing import EncoderReader
from nodesim.errors import NodesimError
from nodesim.replay.logformat import LogMeta
from nodesim.replay.recorder import NodeRecording, write_log
from nodesim.scenario.schema import Scenario


def chain_recordings(run, scenario: Scenario, realization: int = 0) -> list[NodeRecording]:
    """Per-node recordings of realization ``realization`` of a ChainRun."""
    motion: ChainMotion = run.motion
    timelines = {tl.node_id: tl for tl in motion.timelines}
    encoder = EncoderReader.from_scenario(scenario, motion)
    r = realization
    out = []
    for n in run.nodes:
        if n.gyro_rad_s is None:
            raise NodesimError("record: this chain run does not carry its sensor inputs")
        present = n.t_s >= n.present_from_s
        t = n.t_s[present]
        size = t.size
        force = n.specific_force[r][present]
        applied = n.update_mask[r][present]
        tl = timelines[n.node_id]
        cols = {
            "t_s": t,
            "tick": np.ones(size, dtype=bool),
            "static": t < n.filter_start_s,
            "hold": np.array([tl.holding(tk) for tk in t], dtype=bool),
            "gyro_x": np.zeros(size),
            "gyro_y": np.zeros(size),
            "gyro_z": n.gyro_rad_s[r][present],
            "accel_x": force[:, 0],
            "accel_y": force[:, 1],
            "accel_z": force[:, 2],
            "encoder": np.array([encoder.read(tk)[0] for tk in t]),
            "ref_update": applied,
            "ref_yaw": np.where(applied, n.ref_yaw_rad[r][present], np.nan),
            "ref_var": np.where(applied, n.ref_var_rad2[r][present], np.nan),
            "fw_yaw": n.yaw_est_rad[r][present],
            "fw_yaw_var": n.yaw_var_rad2[r][present],
            "fw_bias": n.bias_est_rad_s[r][present],
            "fw_inclination": n.inclination_rad[r][present],
            "fw_azimuth": n.azimuth_rad[r][present],
            "true_yaw": n.true_yaw_rad[present],
            "true_inclination": n.true_inclination_rad[present],
            "true_azimuth": n.true_azimuth_rad[present],
        }
        if n.gyro_counts is not None:  # what the fixed-point firmware read: integer count sums per tick
            for i, axis in enumerate("xyz"):
                cols[f"gyro_sum_{axis}"] = n.gyro_counts[r][present][:, i]
                cols[f"accel_sum_{axis}"] = n.accel_counts[r][present][:, i]
            cols["samples"] = n.samples[present]
        if n.estimate_frames is not None:  # the estimate frames the node sent (fixed firmware), hex
            sent = n.estimate_frames[r][present]
            cols["frame"] = np.array([f.tobytes().hex() if f[0] else None for f in sent], dtype=object)
        out.append(NodeRecording(n.node_id, cols))
    return out


def record_chain_run(path, run, scenario: Scenario, realization: int = 0):
    """Write realization ``realization`` of ``run`` as a replay log (CSV, or Parquet for ``.parquet``)."""
    if not 0 <= realization < run.nodes[0].yaw_est_rad.shape[0]:
        raise NodesimError(f"record: realization {realization} out of range")
    meta = LogMeta(source=f"nodesim run of scenario {scenario.name!r}, seed {scenario.seed}, realization {realization}",
                   description="simulated: tick-averaged inputs at the firmware ticks, SI units")
    return write_log(path, chain_recordings(run, scenario, realization), meta)


__all__ = ["chain_recordings", "record_chain_run"]
