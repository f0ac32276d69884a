"""Write logs in the replay format: from simulated runs (``nodesim run --record``) or converted recordings.

A simulated node is recorded at its firmware ticks (one row per tick, ``tick`` = 1): the tick-averaged gyro
and specific force the firmware used (SI units: rad/s, m/s^2, rad), the encoder reading at the tick, the
reference each update used (``ref_update``, ``ref_yaw``, ``ref_var``), the firmware outputs (``fw_*``) and
the truth.  Floats are written with the shortest representation that reads back to the same double
(pyarrow's CSV writer; Parquet stores the doubles), so record -> read is exact and a replay with the same
firmware configuration reproduces the outputs bit for bit.
"""

from __future__ import annotations

import io
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.csv as pcsv
import pyarrow.parquet as pq

from nodesim.errors import NodesimError
from nodesim.replay import logformat as lf
from nodesim.io.rundir import atomic_write_bytes


@dataclass(frozen=True)
class NodeRecording:
    """One node's rows (N,): ``columns`` maps log column names to arrays, in the header's units."""

    node_id: int
    columns: dict = field(default_factory=dict)


def log_table(nodes: list[NodeRecording] | tuple[NodeRecording, ...]) -> dict[str, np.ndarray]:
    """Rows of every node, node by node, columns in the canonical order."""
    if not nodes:
        raise NodesimError("record: no node to write")
    names = set().union(*(n.columns for n in nodes))
    missing = [c for c in ("t_s", *lf.GYRO, *lf.ACCEL) if c not in names]
    if missing:
        raise NodesimError(f"record: missing required column(s) {missing}")
    order = ["node"] + [c for c in (*lf.REQUIRED, *lf.OPTIONAL) if c in names and c != "node"]
    order += sorted(c for c in names if c not in order)
    out: dict[str, list] = {c: [] for c in order}
    for n in nodes:
        size = np.asarray(n.columns["t_s"]).size
        for c in order:
            if c == "node":
                out[c].append(np.full(size, n.node_id, dtype=np.int64))
            elif c in n.columns:
                v = np.asarray(n.columns[c])
                out[c].append(v.astype(object) if c in lf.TEXT else v.astype(np.int64) if c in lf.FLAGS
                              else v.astype(float))
            else:
                out[c].append(np.full(size, None, dtype=object) if c in lf.TEXT else np.full(size, np.nan))
    return {c: np.concatenate(v) for c, v in out.items()}


def write_log(path, nodes, meta: lf.LogMeta) -> Path:
    """Write a CSV (header lines + columns) or, for ``.parquet``, a Parquet log, atomically."""
    path = Path(path)
    cols = log_table(nodes)
    if "encoder" in cols and not meta.has_encoder:
        raise NodesimError("record: an encoder column needs encoder_unit != absent")
    table = pa.table({c: pa.array(v, from_pandas=True) for c, v in cols.items()})
    buf = io.BytesIO()
    if path.suffix.lower() in (".parquet", ".pq"):
        pq.write_table(table.replace_schema_metadata(lf.parquet_metadata(meta)), buf)
        atomic_write_bytes(path, buf.getvalue())
    else:
        pcsv.write_csv(table, buf, pcsv.WriteOptions(include_header=False, quoting_style="none"))
        names = ",".join(table.column_names) + "\n"
        atomic_write_bytes(path, (lf.format_csv_header(meta) + names).encode() + buf.getvalue())
    return path


__all__ = ["NodeRecording", "log_table", "write_log"]
