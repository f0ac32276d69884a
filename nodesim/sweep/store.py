"""Campaign store: one Parquet results table plus a manifest, written incrementally and atomically.

Layout of a campaign directory::

    campaign.json          manifest: sweep (resolved), hashes, planned run ids count, executor, counts, times
    results.parquet        the consolidated table, one row per (point, seed), sorted by run_id
    parts/part-*.parquet   finished runs not yet consolidated (one file per flushed batch)
    runs/<run_id>/         run directories, only with ``keep_runs = true``

Columns: ``run_id``, ``point``, ``seed_index``, ``seed``, one column per swept key (named by the dotted key,
e.g. ``schedule.timeout_s``), one float column per kept metric, ``status`` ("ok" or "failed"), ``error``
(null when ok), ``attempts``, ``wall_s`` (run wall time) and ``worker`` (host:pid).  ``wall_s`` and ``worker``
are timing/placement, outside the determinism guarantee; every other column is identical whichever executor
ran the campaign.

Every file is written to a temporary name and renamed into place (:func:`nodesim.io.rundir.write_parquet`),
so a campaign killed at any moment leaves only complete part files.  Each finished run is flushed at once
(one part file per batch of runs finished together), so a kill loses at most the runs in flight.  Part files
are merged into ``results.parquet`` every ``CONSOLIDATE_EVERY`` parts and at the end.  ``--resume`` reads
both, skips every ``ok`` run, and runs the failed and missing ones again; a later row for the same run_id
replaces the earlier one, so no row is duplicated.

Load the table back with one call: ``pandas.read_parquet("DIR/results.parquet")``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Iterable

import pandas as pd
import pyarrow as pa

from nodesim.errors import NodesimError
from nodesim.io.rundir import write_parquet
from nodesim.sweep.tasks import RunRecord

RESULTS = "results.parquet"
PARTS = "parts"
CONSOLIDATE_EVERY = 256
ID_COLUMNS = ["run_id", "point", "seed_index", "seed"]
STATUS_COLUMNS = ["status", "error", "attempts", "wall_s", "worker"]
TIMING_COLUMNS = ["wall_s", "worker"]


def records_frame(records: Iterable[RunRecord], param_keys: list[str]) -> pd.DataFrame:
    """Rows of the results table for ``records`` (metrics as float64, parameters as given)."""
    rows = []
    for r in records:
        row = {"run_id": r.run_id, "point": r.point, "seed_index": r.seed_index, "seed": r.seed}
        row.update(dict(r.params))
        row.update({f"metric:{k}": float(v) for k, v in r.metrics.items()})
        row.update(status=r.status, error=r.error, attempts=r.attempts, wall_s=r.wall_s, worker=r.worker)
        rows.append(row)
    df = pd.DataFrame(rows)
    metric_cols = sorted(c for c in df.columns if c.startswith("metric:"))
    df = df.rename(columns={c: c[len("metric:"):] for c in metric_cols})
    metrics = [c[len("metric:"):] for c in metric_cols]
    for c in ID_COLUMNS[1:] + ["attempts"]:
        df[c] = df[c].astype("int64")
    df["error"] = df["error"].astype("string")
    for m in metrics:
        df[m] = df[m].astype("float64")
    return df[ID_COLUMNS + [k for k in param_keys if k in df.columns] + metrics + STATUS_COLUMNS]


class CampaignStore:
    """Append finished runs as part files; consolidate into ``results.parquet``."""

    def __init__(self, directory: Path, param_keys: list[str]):
        self.dir = Path(directory)
        self.param_keys = list(param_keys)
        self.parts_dir = self.dir / PARTS
        self._next = self._next_part_number()

    def _part_files(self) -> list[Path]:
        # a killed write leaves only ".part-*.tmp"-style hidden temporaries: they are ignored
        return sorted(p for p in self.parts_dir.glob("part-*.parquet")) if self.parts_dir.is_dir() else []

    def _next_part_number(self) -> int:
        nums = [int(p.stem.split("-")[1]) for p in self._part_files()]
        return max(nums, default=0) + 1

    def append(self, records: list[RunRecord]) -> None:
        """Write ``records`` as one new part file (atomic); consolidate when parts pile up."""
        if not records:
            return
        write_parquet(self.parts_dir / f"part-{self._next:07d}.parquet", records_frame(records, self.param_keys))
        self._next += 1
        if len(self._part_files()) >= CONSOLIDATE_EVERY:
            self.consolidate()

    def load(self) -> pd.DataFrame:
        """Every stored row (consolidated table, then part files in order); a later row for a run_id wins."""
        frames = []
        results = self.dir / RESULTS
        try:
            if results.exists():
                frames.append(pd.read_parquet(results))
            frames.extend(pd.read_parquet(p) for p in self._part_files())
        except (OSError, pa.ArrowException) as err:
            raise NodesimError(f"{self.dir}: cannot read the campaign table ({err})") from None
        if not frames:
            return pd.DataFrame(columns=ID_COLUMNS + STATUS_COLUMNS)
        df = pd.concat([f for f in frames if len(f)], ignore_index=True) if any(len(f) for f in frames) else frames[0]
        df = df.drop_duplicates(subset="run_id", keep="last")
        return _ordered(df, self.param_keys)

    def done_ids(self) -> set[str]:
        df = self.load()
        return set(df.loc[df["status"] == "ok", "run_id"]) if len(df) else set()

    def consolidate(self) -> pd.DataFrame:
        """Merge part files into ``results.parquet`` (atomic), then delete the merged parts."""
        parts = self._part_files()
        df = self.load()
        if len(df) or not (self.dir / RESULTS).exists():
            write_parquet(self.dir / RESULTS, df)
        for p in parts:
            p.unlink()
        return df


def _ordered(df: pd.DataFrame, param_keys: list[str]) -> pd.DataFrame:
    """Rows sorted by run_id; columns: ids, parameters, metrics (sorted), status and timing."""
    fixed = set(ID_COLUMNS) | set(STATUS_COLUMNS) | set(param_keys)
    metrics = sorted(c for c in df.columns if c not in fixed)
    cols = ID_COLUMNS + [k for k in param_keys if k in df.columns] + metrics + STATUS_COLUMNS
    return df.sort_values("run_id", kind="stable").reset_index(drop=True)[[c for c in cols if c in df.columns]]
