"""A streamed run: each node's per-tick records turned into its outputs as soon as the engine has finished the node,
then dropped, so a run holds a few nodes' records instead of the chain's (issue 20).

The engines call a :class:`NodeStream` with each node's :class:`~nodesim.chain.records.NodeRun` (top node first) and
the surveys it sent (:func:`nodesim.chain.network.simulate_chain` ``on_node``).  It

  - writes the node's rows of the timeseries table (those ``[output] timeseries`` keeps) to the file, one Parquet
    row group (zstd) or a block of CSV rows per node (:class:`TimeseriesFile`): the same table, row for row, as
    the whole-run :func:`nodesim.chain.run_tables.timeseries_columns`;
  - feeds the yaw figure's data (:class:`nodesim.chain.yaw_plot.YawPlotData`);
  - returns what the node leaves (:class:`~nodesim.chain.records.NodeSummary`): its metrics
    (:func:`nodesim.chain.metrics.node_metrics`, the accumulators that need its per-tick data) and its survey rows
    (:func:`nodesim.chain.run_tables.node_survey_rows`).
The compiled engine's whole-run tables (tick times, tick plan, phase 1's records: which estimate reaches which tick)
scale with the run's node-ticks; a large run keeps them on disk (:mod:`nodesim.chain.scratch`).  What still grows
with the duration in memory is the shared per-sample sensor truth (~1.1 kB a tick) and the few nodes' whole-run
arrays phase 2 and the outputs hold at a time (a node's readings, records and table rows).
"""

from __future__ import annotations

import os
import queue
import tempfile
import threading
from pathlib import Path

import numpy as np

from nodesim import threads
from nodesim.chain.metrics import NodeMetricSums, bias_hold_ticks
from nodesim.chain.records import GroundSurvey, NodeRun, NodeSummary
from nodesim.chain.run_tables import (SURVEY_COLUMNS, TIMESERIES_COLUMNS, empty_timeseries, node_survey_rows,
                                      node_timeseries)
from nodesim.chain.yaw_plot import YawPlotData, import_matplotlib
from nodesim.io.rundir import csv_text, file_mode
from nodesim.io.write_behind import WriteBehind
from nodesim.motion.timelines import ChainMotion
from nodesim.scenario.schema import Scenario


INTEGER_COLUMNS = ("node", "running", "update")
"""The timeseries columns that hold integers (one value per node's row group, or 0/1 flags)."""

DICTIONARY_COLUMNS = ("node", "running")
"""The timeseries columns dictionary-encoded: the node's id (one value a row group's block) and the 0/1
filter-running flag (runs of one value a node): one dictionary entry or two, and runs of its index."""

PLAIN_COLUMNS = ("update_age_s", "yaw_sigma_deg")
"""The timeseries columns written plain, left to zstd: the ages of the few frames in flight and the fixed-point
filter's P_yy (a handful of words once settled)."""

FAST_ZSTD_COLUMNS = ("true_yaw_deg", "yaw_est_deg", "yaw_error_deg", "bias_true_deg_s", "bias_est_deg_s",
                     "inclination_deg", "azimuth_deg")
"""The noisy float columns (zstd packs them to 4-6 bytes a value at best), compressed at zstd's level
:data:`FAST_ZSTD_LEVEL`, the others at -1."""

FAST_ZSTD_LEVEL = -5


def _encoding(column: str) -> str:
    return ("PLAIN" if column in PLAIN_COLUMNS else "DELTA_BINARY_PACKED" if column in INTEGER_COLUMNS else
            "BYTE_STREAM_SPLIT")


PARQUET_OPTIONS = {
    "compression": "zstd", "use_dictionary": list(DICTIONARY_COLUMNS),
    "compression_level": {k: FAST_ZSTD_LEVEL if k in FAST_ZSTD_COLUMNS else -1 for k in TIMESERIES_COLUMNS},
    "write_statistics": ["node", "t_s"],
    "column_encoding": {k: _encoding(k) for k in TIMESERIES_COLUMNS if k not in DICTIONARY_COLUMNS}}
"""How timeseries Parquet files are written (streamed or whole, :func:`nodesim.io.rundir.write_parquet`), with the
schema of :func:`timeseries_table`: zstd, at level -1 (its fastest positive-ratio setting after 1, pyarrow's
default) and -5 for the :data:`FAST_ZSTD_COLUMNS`; the :data:`DICTIONARY_COLUMNS` dictionary-encoded, the
:data:`PLAIN_COLUMNS` plain, the other integer columns delta-encoded (the 0/1 update flag packs to a few bits a
row), the other float columns byte-stream split (the k-th bytes of all values side by side, which zstd packs
better); min/max statistics for ``node`` and ``t_s`` only (what a reader filters row groups on).  The writer is the
run's largest single consumer of CPU (~25 % of the drilling day's).  Measured on 16 of the drilling day's row
groups (its first 8 hours, one node's window each, 1.3 M rows, 2026-12-06, thread time, 9 rounds interleaved, min /
median): the whole table 154.3 / 157.5 ns and 29.41 bytes a row, against 173.1 / 178.2 ns and 31.41 bytes with
``node`` plain (zstd took ~20 ns a row over its constant 8 bytes, the dictionary's run of one index next to
nothing); a dictionary on ``yaw_sigma_deg`` (155.1 / 160.5 ns), ``update_age_s`` (155.5 / 163.2), ``update``
(152.8 / 157.9) or the true inclination and azimuth (155.3 / 161.0) gained nothing beyond noise; neither did larger
data pages (8 MB) or write batches (64 k rows).  Column by column (1.3 M rows, 2026-12-06, min of 5):
``running`` 5.4 ns a row dictionary against 6.9 delta; ``update_age_s`` 15.0 plain against 17.2 dictionary and
21.5 byte-stream split; ``yaw_sigma_deg`` 19.2 plain against 20.5 dictionary and 30.3 byte-stream split;
``yaw_est_deg`` 15.2 at level -5 against 18.6 at -1 (4.54 against 4.12 bytes), ``yaw_error_deg`` 9.9 against
13.7.  The whole table before (interleaved, min / median of 5): 172 / 179 ns and 30.4 bytes a row against 201 / 207
ns and 28.5 bytes with dictionaries on ``update_age_s`` and ``yaw_sigma_deg``, delta on all integer columns and
level -1 throughout, 167 / 169 ns and 31.9 bytes at level -10 on the noisy columns.  Earlier (2026-12-03/05): the
filter's estimates and the true yaw 3-10x slower with a dictionary; nullable columns and statistics on all cost ~50
ns a row; plain zstd without byte-stream split 37.4 bytes a row."""


def timeseries_table(columns: dict[str, np.ndarray]):
    """The timeseries columns (:data:`~nodesim.chain.run_tables.TIMESERIES_COLUMNS`) as a pyarrow Table whose
    fields are not nullable (the table has no nulls; a nullable column costs a definition level per value), the
    :data:`INTEGER_COLUMNS` int64 (also in a table without rows, whose columns come as float), the others float64.
    Each column is the numpy array's memory (no copy); its type is given: pyarrow then skips inferring it, which
    took ~11 ns a value (~20 ns with NaNs in the column) for the same array (pyarrow 26, 2026-12-05)."""
    import pyarrow as pa

    arrays = [pa.array(np.asarray(columns[k], dtype=np.int64), type=pa.int64()) if k in INTEGER_COLUMNS else
              pa.array(np.asarray(columns[k], dtype=np.float64), type=pa.float64()) for k in TIMESERIES_COLUMNS]
    return pa.Table.from_arrays(arrays, schema=pa.schema([pa.field(k, a.type, nullable=False)
                                                          for k, a in zip(TIMESERIES_COLUMNS, arrays)]))


class TimeseriesFile:
    """The timeseries table written block by block to ``path`` (``fmt`` "parquet": row groups of whole blocks,
    :attr:`ROW_GROUP_ROWS` rows or more, :data:`PARQUET_OPTIONS`; "csv": :func:`nodesim.io.rundir.csv_text`, as ``write_csv`` writes it), through a
    temporary file in the same directory that :meth:`close` renames into place (:meth:`abort` deletes it: a failed
    run leaves no partial table).  Parquet blocks are encoded on a writer thread (pyarrow releases the GIL) while
    the run goes on, at most :data:`QUEUED_BLOCKS` waiting; with ``NODESIM_THREADS = 1`` in the calling thread.  The
    file is the same either way: blocks are written in the order they come.  Its pages leave the page cache once
    they are on disk (:mod:`nodesim.io.write_behind`): nothing reads them back during the run."""

    QUEUED_BLOCKS = 4
    ROW_GROUP_ROWS = 1 << 16
    """Blocks are gathered into row groups of at least this many rows: a run in windows of time
    (:mod:`nodesim.chain.compiled.time_windows`) gives a block per node and window, ~6,800 rows for an hour."""

    def __init__(self, path: Path, fmt: str):
        self.path, self.fmt = Path(path), fmt
        self.path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{self.path.name}.", suffix=".tmp", dir=self.path.parent)
        os.close(fd)
        self._tmp = Path(tmp)
        self._behind = WriteBehind(self._tmp)
        self._writer = None
        self._csv = None
        self._queue: queue.Queue | None = None
        self._thread: threading.Thread | None = None
        self._error: BaseException | None = None
        self.rows = 0
        self._blocks: list[dict] = []  # blocks not yet in a row group, and their rows
        self._buffered = 0
        if fmt == "parquet" and threads.thread_count() > 1:
            self._queue = queue.Queue(maxsize=self.QUEUED_BLOCKS)
            self._thread = threading.Thread(target=self._drain, name="nodesim-timeseries", daemon=True)
            self._thread.start()

    def write(self, columns: dict[str, np.ndarray]) -> None:
        """Append one block of rows (the columns of :data:`~nodesim.chain.run_tables.TIMESERIES_COLUMNS`)."""
        self._raise()
        if self.fmt == "parquet":
            self._blocks.append({k: np.asarray(columns[k]) for k in TIMESERIES_COLUMNS})
            self._buffered += len(columns["node"])
            if self._buffered >= self.ROW_GROUP_ROWS:
                self._flush()
        else:
            header = self._csv is None
            if header:
                self._csv = open(self._tmp, "w", newline="")
            self._csv.write(csv_text({k: columns[k] for k in TIMESERIES_COLUMNS}, header=header))
            self._behind.advance()
        self.rows += len(columns["node"])

    def _flush(self) -> None:
        """The blocks written since the last row group as one (on the writer thread where there is one)."""
        if not self._blocks:
            return
        blocks, self._blocks, self._buffered = self._blocks, [], 0
        if self._queue is not None:
            self._queue.put(blocks)
        else:
            self._write_parquet(blocks)

    def _write_parquet(self, blocks: list[dict[str, np.ndarray]]) -> None:
        """One row group of ``blocks``: a table whose columns are the blocks' arrays as chunks (no copy: the
        writer reads chunk after chunk; the same file, byte for byte, as from the blocks concatenated, which
        copied every value once more)."""
        import pyarrow as pa
        import pyarrow.parquet as pq

        table = pa.concat_tables([timeseries_table(block) for block in blocks])
        if self._writer is None:
            self._writer = pq.ParquetWriter(self._tmp, table.schema, **PARQUET_OPTIONS)
        self._writer.write_table(table, row_group_size=max(1, table.num_rows))
        self._behind.advance()

    def _drain(self) -> None:
        while True:
            blocks = self._queue.get()
            if blocks is None:
                return
            if self._error is None:
                try:
                    self._write_parquet(blocks)
                except BaseException as err:  # noqa: BLE001 - raised in the caller's thread
                    self._error = err

    def _raise(self) -> None:
        if self._error is not None:
            raise self._error

    def _join(self) -> None:
        if self._thread is not None:
            self._queue.put(None)
            self._thread.join()
            self._thread = None

    def close(self) -> Path:
        """Finish the file and rename it into place (a table without rows when no block was written)."""
        if self.fmt == "parquet":
            self._flush()
            self._join()
            self._raise()
            if self._writer is None:
                self._write_parquet([empty_timeseries()])
            self._writer.close()
        else:
            if self._csv is None:
                self.write(empty_timeseries())
            self._csv.flush()
            os.fsync(self._csv.fileno())
            self._csv.close()
        self._behind.close()
        os.chmod(self._tmp, file_mode())
        os.replace(self._tmp, self.path)
        return self.path

    def abort(self) -> None:
        self._join()
        for handle in (self._writer, self._csv):
            try:
                if handle is not None:
                    handle.close()
            except Exception:  # noqa: BLE001 - the file is deleted anyway
                pass
        self._behind.close()
        if self._tmp.exists():
            self._tmp.unlink()


class NodeStream:
    """The ``on_node`` of a streamed run (module docstring): writes each node's timeseries rows to ``table``
    (None: none written), feeds the yaw figure's :attr:`plot`, returns its summary."""

    def __init__(self, scenario: Scenario, motion: ChainMotion, table: TimeseriesFile | None):
        self.scenario, self.motion, self.table = scenario, motion, table
        n, output = scenario.chain.nodes, scenario.output
        self.plot = YawPlotData([i for i in range(1, n + 1) if output.keeps_node(i, n)], scenario.simulation.duration_s)

    def node_windows(self, node_id: int, t_s: np.ndarray, realizations: int) -> "NodeWindows":
        """Node ``node_id``'s outputs fed window by window of its ticks ``t_s`` (a run in windows of time,
        :mod:`nodesim.chain.compiled.time_windows`)."""
        return NodeWindows(self, node_id, t_s, realizations)

    def __call__(self, run: NodeRun, surveys: list[GroundSurvey]) -> NodeSummary:
        """All of a node's records at once: its outputs as one window of :class:`NodeWindows`."""
        windows = self.node_windows(run.node_id, run.t_s, run.yaw_est_rad.shape[0])
        windows.add(run, 0, surveys)
        return windows.finish(run.stale_packets, run.duplicate_packets, run.firmware_overflows,
                              run.adc_clipped_samples, run.singular_ticks)


class NodeWindows:
    """One node's outputs (:class:`NodeStream`) fed window by window of its ticks (:meth:`add`, in order): its rows
    of the timeseries table and of the yaw figure as they come, its metrics' sums
    (:class:`nodesim.chain.metrics.NodeMetricSums`) and survey rows until :meth:`finish` makes its summary."""

    def __init__(self, stream: NodeStream, node_id: int, t_s: np.ndarray, realizations: int):
        s = stream.scenario
        self.stream, self.node_id = stream, node_id
        self.keeps = s.output.keeps_node(node_id, s.chain.nodes)
        self.rows = len(range(0, t_s.size, s.output.tick_step))  # its rows of the table (the yaw figure's trace)
        self.sums = NodeMetricSums(stream.motion, s.metrics, realizations, bias_hold_ticks(t_s, s.metrics.bias_hold_s))
        self.survey_parts: list[dict] = []

    def add(self, run: NodeRun, first_tick: int, surveys: list[GroundSurvey]) -> None:
        """The records of the node's ticks from ``first_tick`` on (``run``), and the surveys it sent at them (their
        packets' ticks counted from ``first_tick``)."""
        s = self.stream.scenario
        if self.keeps:
            rows = node_timeseries(run, 0, s.output.tick_step, first_tick)
            if self.stream.table is not None:
                self.stream.table.write(rows)
            import_matplotlib()
            self.stream.plot.add(rows, self.rows)
        self.sums.add(run)
        if surveys:
            self.survey_parts.append(node_survey_rows(run, surveys, s.filter.moving_average_points))

    def finish(self, stale, duplicate, overflows: dict, clipped: np.ndarray, singular) -> NodeSummary:
        """The node's summary after its last window (what :meth:`NodeStream.__call__` returns for all its ticks)."""
        parts = self.survey_parts
        rows = ({k: np.concatenate([p[k] for p in parts]) for k in SURVEY_COLUMNS} if parts else
                node_survey_rows(None, [], 0))
        return NodeSummary(node_id=self.node_id, metrics=self.sums.metrics(), survey_rows=rows, stale_packets=stale,
                           duplicate_packets=duplicate, firmware_overflows=overflows, adc_clipped_samples=clipped,
                           singular_ticks=singular)
