"""Strict reader of replay logs (:mod:`nodesim.replay.logformat`), with documented repairs.

Checks, in this order, each naming the file, the line (CSV) or row (Parquet) of the first problem:
  1. header present and valid (known units, scales for counts), every required column present, no unknown
     column (user columns start with ``x_``), every cell numeric;
  2. no NaN/empty cell in ``t_s``, ``gyro_*``, ``accel_*``, ``node`` (``encoder`` may be empty: the replay
     holds the latest reading; the firmware outputs and the truth are empty on rows without one);
  3. raw counts are integers inside the ``adc_bits`` range (int16 by default);
  4. per node, time strictly increases (no step back, no duplicated time);
  5. per node, no gap between samples longer than ``max_gap_s``;
  6. ``tick``/``ref_update`` are 0 or 1 and every ``ref_update`` row has a finite ``ref_yaw`` and ``ref_var``;
     a ``frame`` cell is empty or 54 hex digits of an estimate frame whose CRC-16 holds.
Without ``repair`` the first problem (lowest line among all checks) raises :class:`NodesimError` and nothing
is returned.  With ``repair`` the fixes below are applied and counted in :attr:`ReplayLog.repairs`; what
cannot be repaired (1, 6) still raises:
  - ``dropped_nan_rows``: rows with a NaN in a required column are dropped;
  - ``clipped_counts`` / ``rounded_counts``: counts outside the range saturate at its ends, as the ADC
    would; non-integer counts round half to even;
  - ``dropped_duplicate_time`` / ``dropped_backward_time``: a row whose time is not later than the last
    kept row of its node is dropped (the first of duplicated times is kept);
  - ``gaps``: gaps are kept; a firmware tick inside a gap holds the previous tick's average (what an MCU
    whose sensor read fails reuses), counted again by the replay as ``held_ticks``.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.csv as pcsv
import pyarrow.parquet as pq

from firmware_model import frames as fr
from nodesim.errors import NodesimError
from nodesim.replay import logformat as lf

DEFAULT_MAX_GAP_S = 1.0


@dataclass(frozen=True)
class NodeLog:
    """The samples of one node, SI units (rad, rad/s, m/s^2); optional columns in ``extra`` (angles in rad,
    ``tick``/``ref_update`` as bool); ``rows``: the file line (CSV) or row (Parquet) of each sample."""

    node_id: int
    t_s: np.ndarray
    gyro_rad_s: np.ndarray  # (N, 3)
    accel_m_s2: np.ndarray  # (N, 3)
    encoder_rad: np.ndarray | None  # (N,), NaN where no reading; None without an encoder
    extra: dict = field(default_factory=dict)
    rows: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))

    def has(self, name: str) -> bool:
        return name in self.extra


@dataclass(frozen=True)
class ReplayLog:
    path: Path
    meta: lf.LogMeta
    nodes: tuple[NodeLog, ...]
    row_kind: str  # "line" (CSV) or "row" (Parquet)
    repairs: dict
    max_gap_s: float
    hold_gaps: bool  # repaired gaps: ticks without samples hold the previous average


def _sidecar(path: Path) -> dict | None:
    side = path.with_name(path.name + ".meta.json")
    if not side.exists():
        side = path.with_suffix(".meta.json")
    if not side.exists():
        return None
    try:
        return json.loads(side.read_text())
    except (OSError, json.JSONDecodeError) as err:
        raise NodesimError(f"{side}: unreadable sidecar header ({err})") from None


def _read_csv(path: Path) -> tuple[lf.LogMeta, pa.Table, int]:
    header: list[str] = []
    try:
        with open(path, encoding="utf-8") as fh:
            for line in fh:
                if not line.startswith("#"):
                    names_line = line
                    break
                header.append(line)
            else:
                names_line = ""
    except (OSError, UnicodeDecodeError) as err:
        raise NodesimError(f"{path}: cannot read the log ({err})") from None
    if header and header[0].split()[1:] == [lf.FORMAT_NAME, str(lf.FORMAT_VERSION)]:
        meta = lf.parse_csv_header(header[1:], str(path))
    elif header:
        raise NodesimError(f"{path}, line 1: first line {header[0].strip()!r}; allowed '# {lf.FORMAT_NAME} {lf.FORMAT_VERSION}'")
    else:
        side = _sidecar(path)
        if side is None:
            raise NodesimError(f"{path}: no header: start the file with '# {lf.FORMAT_NAME} {lf.FORMAT_VERSION}' and "
                               "'# key = value' lines, or put them in a sidecar <log>.meta.json")
        meta = lf.meta_from_dict(side, f"{path} (sidecar)")
    names = [n.strip().strip('"') for n in names_line.strip().split(",")] if names_line.strip() else []
    if not names:
        raise NodesimError(f"{path}, line {len(header) + 1}: no column names; required {list(lf.REQUIRED)}")
    _check_columns(names, meta, path)
    types = {n: pa.string() if n in lf.TEXT else pa.float64() for n in names}
    skip = len(header)
    try:
        table = pcsv.read_csv(path, read_options=pcsv.ReadOptions(skip_rows=skip),
                              convert_options=pcsv.ConvertOptions(column_types=types, strings_can_be_null=True))
    except pa.ArrowInvalid as err:
        raise NodesimError(_locate_csv_error(path, skip, names, str(err))) from None
    return meta, table, skip + 2


def _locate_csv_error(path: Path, skip: int, names: list[str], message: str) -> str:
    """Turn a pyarrow conversion error into 'file, line L, column C: ...'."""
    m = re.search(r"column #(\d+)", message)
    if m is None:
        return f"{path}: not a valid CSV log ({message})"
    col = names[int(m.group(1))]
    text = pcsv.read_csv(path, read_options=pcsv.ReadOptions(skip_rows=skip),
                         convert_options=pcsv.ConvertOptions(column_types={n: pa.string() for n in names},
                                                             include_columns=[col])).column(0).to_pylist()
    for i, value in enumerate(text):
        try:
            float(value) if value not in (None, "") else None
        except ValueError:
            return f"{path}, line {skip + 2 + i}, column {col}: {value!r} is not a number"
    return f"{path}, column {col}: {message}"


def _read_parquet(path: Path) -> tuple[lf.LogMeta, pa.Table, int]:
    try:
        table = pq.read_table(path)
    except (OSError, pa.ArrowException) as err:
        raise NodesimError(f"{path}: cannot read the Parquet log ({err})") from None
    raw = (table.schema.metadata or {}).get(lf.FORMAT_NAME.encode())
    if raw is not None:
        info = json.loads(raw)
        version = info.pop("version", None)
        if version != lf.FORMAT_VERSION:
            raise NodesimError(f"{path}: log format version {version!r}; allowed {lf.FORMAT_VERSION}")
    else:
        info = _sidecar(path)
        if info is None:
            raise NodesimError(f"{path}: no '{lf.FORMAT_NAME}' schema metadata and no sidecar <log>.meta.json")
    meta = lf.meta_from_dict(info, str(path))
    _check_columns(table.column_names, meta, path)
    cols = {}
    for name in table.column_names:
        want, what = (pa.string(), "text") if name in lf.TEXT else (pa.float64(), "numeric")
        try:
            cols[name] = table.column(name).cast(want)
        except pa.ArrowException:
            raise NodesimError(f"{path}, column {name}: type {table.column(name).type} is not {what}") from None
    return meta, pa.table(cols), 1


def _check_columns(names: list[str], meta: lf.LogMeta, path: Path) -> None:
    required = [c for c in lf.REQUIRED if c != "encoder" or meta.has_encoder]
    missing = [c for c in required if c not in names]
    if missing:
        raise NodesimError(f"{path}: missing required column(s) {missing}; found {names}")
    known = set(lf.REQUIRED) | set(lf.OPTIONAL)
    unknown = [c for c in names if c not in known and not c.startswith(lf.USER_PREFIX)]
    if unknown:
        raise NodesimError(f"{path}: unknown column(s) {unknown}; allowed {list(lf.REQUIRED) + list(lf.OPTIONAL)} "
                           f"and user columns starting with {lf.USER_PREFIX!r}")
    dup = sorted({c for c in names if names.count(c) > 1})
    if dup:
        raise NodesimError(f"{path}: duplicated column(s) {dup}")
    if "encoder" in names and not meta.has_encoder:
        raise NodesimError(f"{path}: column 'encoder' present but the header says encoder_unit = absent")


class _Problems:
    """First problem (lowest row) among the checks, or repairs counted when ``repair``."""

    def __init__(self, where: str, row_kind: str, rows: np.ndarray, repair: bool):
        self.where, self.row_kind, self.rows, self.repair = where, row_kind, rows, repair
        self.first: tuple[int, str] | None = None
        self.counts: dict[str, int] = {}

    def found(self, index: int, message: str) -> None:
        if self.first is None or index < self.first[0]:
            self.first = (index, message)

    def count(self, key: str, n: int) -> None:
        if n:
            self.counts[key] = self.counts.get(key, 0) + int(n)

    def raise_first(self) -> None:
        if self.first is not None:
            i, msg = self.first
            raise NodesimError(f"{self.where}, {self.row_kind} {int(self.rows[i])}: {msg}")


_HEX = re.compile(r"[0-9a-fA-F]*")


def _frames(cells: list, path: Path, row_kind: str, rows: np.ndarray) -> np.ndarray:
    """The ``frame`` column as (N, 27) uint8 estimate frames, zero rows where empty; a cell that is not 54 hex
    digits of a frame whose CRC-16 and type byte hold is an error naming its line/row (not repairable)."""
    n = fr.ESTIMATE_BYTES
    out = np.zeros((len(cells), n), dtype=np.uint8)
    for i, cell in enumerate(cells):
        if cell is None or cell == "":
            continue
        if len(cell) != 2 * n or not _HEX.fullmatch(cell):
            raise NodesimError(f"{path}, {row_kind} {rows[i]}: frame = {cell[:60]!r}; allowed {2 * n} hex digits "
                               f"(the {n}-byte estimate frame) or empty")
        out[i] = np.frombuffer(bytes.fromhex(cell), dtype=np.uint8)
    sent = out[:, 0] != 0
    if sent.any():
        ok = fr.decode(fr.ESTIMATE, out[sent])[1]
        if not ok.all():
            i = int(np.flatnonzero(sent)[np.argmin(ok)])
            raise NodesimError(f"{path}, {row_kind} {rows[i]}: frame = {cells[i]!r} fails its CRC-16 or is not an "
                               f"estimate frame (type byte {fr.ESTIMATE}); allowed the bytes the node sent")
    return out


def read_log(path, repair: bool = False, max_gap_s: float = DEFAULT_MAX_GAP_S) -> ReplayLog:
    """Read and check a CSV or Parquet log (see the module docstring for the checks and the repairs)."""
    path = Path(path)
    if not (np.isfinite(max_gap_s) and max_gap_s > 0):
        raise NodesimError(f"max_gap_s = {max_gap_s}: allowed finite values > 0")
    if not path.is_file():
        raise NodesimError(f"{path}: no such log file")
    if path.suffix.lower() in (".parquet", ".pq"):
        meta, table, first_row, row_kind = *_read_parquet(path), "row"
    else:
        meta, table, first_row, row_kind = *_read_csv(path), "line"
    data = {n: table.column(n).to_numpy(zero_copy_only=False).astype(float) for n in table.column_names
            if not n.startswith(lf.USER_PREFIX) and n not in lf.TEXT}
    n_rows = table.num_rows
    if n_rows == 0:
        raise NodesimError(f"{path}: the log has no samples")
    rows = np.arange(n_rows, dtype=np.int64) + first_row
    probs = _Problems(str(path), row_kind, rows, repair)
    if "frame" in table.column_names:
        data["frame"] = _frames(table.column("frame").to_pylist(), path, row_kind, rows)
    keep = np.ones(n_rows, dtype=bool)

    required = ["t_s", *lf.GYRO, *lf.ACCEL] + (["node"] if "node" in data else [])
    nan_rows = np.zeros(n_rows, dtype=bool)
    for name in required:
        bad = ~np.isfinite(data[name])
        if bad.any():
            probs.found(int(np.argmax(bad)), f"column {name} is empty or not finite; allowed finite numbers")
        nan_rows |= bad
    probs.count("dropped_nan_rows", nan_rows.sum())
    keep &= ~nan_rows

    lo, hi = lf.ADC_RANGES[meta.adc_bits]
    for name in meta.counts_columns():
        x = data[name]
        out = keep & ((x < lo) | (x > hi))
        frac = keep & ~out & (x != np.round(x))
        if out.any():
            i = int(np.argmax(out))
            probs.found(i, f"column {name} = {x[i]:g} counts is outside the int{meta.adc_bits} range [{lo}, {hi}]")
        if frac.any():
            i = int(np.argmax(frac))
            probs.found(i, f"column {name} = {float(x[i])!r} is not an integer count")
        probs.count("clipped_counts", out.sum())
        probs.count("rounded_counts", frac.sum())
        data[name] = np.where(keep, np.clip(np.round(x), lo, hi), x)

    node_ids = data["node"] if "node" in data else np.ones(n_rows)
    bad_node = keep & ((node_ids < 1) | (node_ids != np.round(node_ids)))
    if bad_node.any():
        i = int(np.argmax(bad_node))
        raise NodesimError(f"{path}, {row_kind} {rows[i]}: node = {node_ids[i]:g}; allowed integers >= 1")

    for flag in lf.FLAGS:
        if flag in data:
            bad = keep & ~np.isin(data[flag], (0.0, 1.0)) & np.isfinite(data[flag])
            if bad.any():
                i = int(np.argmax(bad))
                raise NodesimError(f"{path}, {row_kind} {rows[i]}: {flag} = {data[flag][i]:g}; allowed 0 or 1 (or empty)")
    if "ref_update" in data:
        upd = keep & (data["ref_update"] == 1.0)
        for name in ("ref_yaw", "ref_var"):
            vals = data.get(name, np.full(n_rows, np.nan))
            bad = upd & ~np.isfinite(vals)
            if bad.any():
                i = int(np.argmax(bad))
                raise NodesimError(f"{path}, {row_kind} {rows[i]}: ref_update = 1 needs a finite {name}")

    t = data["t_s"]
    gap_rows: list[int] = []
    for nid in np.unique(node_ids[keep]):
        idx = np.flatnonzero(keep & (node_ids == nid))
        tn = t[idx]
        running = np.maximum.accumulate(tn)
        back = np.zeros(idx.size, dtype=bool)
        back[1:] = tn[1:] < running[:-1]
        dup = np.zeros(idx.size, dtype=bool)
        dup[1:] = tn[1:] == running[:-1]
        for mask, key, what in ((back, "dropped_backward_time", "time goes back"), (dup, "dropped_duplicate_time", "duplicated time")):
            if mask.any():
                j = int(np.argmax(mask))
                probs.found(int(idx[j]), f"{what} on node {int(nid)}: t_s = {float(tn[j])!r} after {float(running[j - 1])!r}; "
                                         "allowed strictly increasing times per node")
            probs.count(key, mask.sum())
        keep[idx[back | dup]] = False
        kept = idx[~(back | dup)]
        step = np.diff(t[kept])
        gaps = np.flatnonzero(step > max_gap_s)
        if gaps.size:
            j = int(gaps[0]) + 1
            probs.found(int(kept[j]), f"gap of {step[j - 1]:.6g} s on node {int(nid)} (t_s {float(t[kept[j - 1]])!r} -> "
                                      f"{float(t[kept[j]])!r}); allowed <= max_gap_s = {max_gap_s:g} s")
            gap_rows.extend(kept[gaps + 1].tolist())
        probs.count("gaps", gaps.size)
    if not repair:
        probs.raise_first()

    nodes = []
    for nid in np.unique(node_ids[keep]):
        sel = keep & (node_ids == nid)
        extra = {}
        for name in lf.OPTIONAL:
            if name in data and name != "node":
                v = data[name][sel]
                if name in lf.FLAGS:
                    v = v == 1.0
                elif name in ("ref_yaw", "fw_yaw", "fw_inclination", "fw_azimuth", *lf.TRUTH):
                    v = v * meta.angle_to_rad
                elif name in ("ref_var", "fw_yaw_var"):
                    v = v * meta.angle_to_rad**2
                elif name == "fw_bias":
                    v = v * meta.angle_to_rad
                extra[name] = v
        nodes.append(NodeLog(
            node_id=int(nid),
            t_s=t[sel],
            gyro_rad_s=np.stack([data[c][sel] for c in lf.GYRO], -1) * meta.gyro_to_rad_s,
            accel_m_s2=np.stack([data[c][sel] for c in lf.ACCEL], -1) * meta.accel_to_m_s2,
            encoder_rad=data["encoder"][sel] * meta.encoder_to_rad if meta.has_encoder else None,
            extra=extra,
            rows=rows[sel],
        ))
    if not nodes:
        raise NodesimError(f"{path}: no sample left after the repairs")
    return ReplayLog(path, meta, tuple(nodes), row_kind, probs.counts, max_gap_s, hold_gaps=repair and bool(gap_rows))


__all__ = ["NodeLog", "ReplayLog", "read_log", "DEFAULT_MAX_GAP_S"]
