"""How much memory a chain run will take, estimated from the scenario before it starts, and the guard that refuses a
run that would exhaust the machine.

A run keeps per-tick records of every node (what the tables and metrics are made from), so its peak resident
memory grows with the node-ticks sum_n (K_n + 1) (K_n = (duration - the node's insertion) x firmware rate, the
whole run on the lab profile) and, for the records that exist per realization, with R sum_n (K_n + 1):

    peak ~ BASE + R sum_n (K_n + 1) b_rt + sum_n (K_n + 1) (b_t + b_event [SimPy engine])

BASE is the process with nodesim, numpy, scipy and numba loaded; b_rt the per-realization bytes of a node-tick
(the sensor counts and their SI forms, the filter's records, the fixed firmware's words and frames; larger with
``filter.implementation = "fixed"``); b_t the per-node-tick tables (``timeseries``, ``[output] timeseries = "all"``)
built and written as Parquet after the run; b_event what the SimPy engine holds per node-tick (its event records).
The constants are measured peak RSS of whole ``nodesim run`` processes (``os.wait4``) on this project's 2-core machine
on 2026-12-03, a least-squares fit over ten perf-chain sizes (1-400 nodes, 60-3600 s, 1-1000 realizations, both
filter implementations; every size within 3 % of the fit) and the SimPy engine's drilling run
(``scenarios/field/drilling_10_tubes.toml``).

A streamed run (``nodesim run`` on the compiled engine, :mod:`nodesim.chain.streaming`) holds the tick-time table
and phase 1's records (which estimate reaches which tick: 6 bytes per node-tick and realization) for the whole run,
padded to the longest node's ticks K_max, the per-sample sensor truth (~34 samples a tick of the run), and a few nodes'
full records at a time:

    peak ~ BASE_S + N s_n + N K_max (s_t + R s_rt) + K_max s_k + W R K_max b_rt

with s_rt = 6 bytes (the records' int8 source offset, int32 source tick and bool flag), BASE_S a small run's 310 MB,
and s_n, s_t, s_k and the window W (in nodes) fitted on 2026-12-03 to eleven streamed runs (10-20000 nodes, 60-7200 s,
1-300 realizations, both implementations, the drilling day's first one and two hours and the whole day: 146.5 M
node-ticks, 3.86 GB); every run within 10 % of the fit (the day 1.3 % under).
Where those whole-run tables would take more than 64 MB they are kept on disk instead (:mod:`nodesim.chain.scratch`:
a memory-mapped file whose pages the engine drops as it is done with them), and the N K_max terms give way to what
of them is mapped at a time, ``SPILLED_RUN_TICK_BYTES`` per tick of the longest node:

    peak ~ BASE_S + N s_n + K_max (s_k + s_spilled) + W R K_max b_rt

(the drilling day 1.27 GB estimated against 1.12-1.17 GB measured, its first one and two hours 0.39 / 0.43 against
0.41 / 0.45 GB).  Where phase 2 runs in windows of time (:mod:`nodesim.chain.compiled.time_windows`: the fixed
2-state firmware), what it holds of the longest node, its shared truth and its mapped tables are a window's: the
K_max of these terms becomes the ticks of one window, K_w = min(K_max, window x rate + 1) (the drilling day in two
windows: 0.71 GB estimated against 0.76-0.80 GB measured, 2026-12-06).  Such a run also needs disk: the tables (:func:`nodesim.chain.scratch.whole_run_table_bytes`) in
the temporary directory and its streamed timeseries table (``TABLE_ROW_BYTES`` a row) in the run directory;
:func:`check_run_memory` refuses it at once when either file system has less free (:func:`disk_needs`).
tests/nodesim/chain/test_memory_budget.py checks both estimates against the measured peak
on other sizes (within a factor of 1.5, the goal).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

from nodesim.chain.scratch import free_disk_bytes, scratch_directory, spills, whole_run_table_bytes
from nodesim.errors import NodesimError
from nodesim.scenario.schema import Scenario

BASE_BYTES = 331 * 2**20
"""A ``nodesim run`` process before its run (imports, compiled code, pyarrow)."""
REALIZATION_TICK_BYTES = {"fixed": 211, "float": 166}
"""Per realization and node-tick, by ``filter.implementation``."""
TICK_BYTES = 411
"""Per node-tick, independent of R: the run's tables (``timeseries``) built and written (Parquet)."""
EVENT_ENGINE_TICK_BYTES = 2300
"""Per node-tick on the SimPy engine (drilling), beyond the compiled engine's."""
STREAMED_BASE_BYTES = 310 * 2**20
STREAMED_TICK_BYTES = 10.5
"""A streamed run, per node-tick (N K_max): the tick-time table, the tick plan (the running flags, 1 byte more, until
2026-12-05)."""
STREAMED_REALIZATION_TICK_BYTES = 6
"""A streamed run, per realization and node-tick (N K_max): phase 1's records."""
STREAMED_RUN_TICK_BYTES = 1632
"""A streamed run, per tick of its longest node (K_max): the shared per-sample sensor truth (its prefix sums, 32
bytes a sample, ~34 samples a tick: 1095 bytes fewer than the 2727 fitted on 2026-12-03, when it kept its readings
too), the table writer's."""
STREAMED_WINDOW_NODES = 3.63
"""A streamed run holds about this many nodes' full records (R K_max b_rt each) at its peak."""
SPILLED_RUN_TICK_BYTES = 2000
"""A streamed run whose whole-run tables are on disk (:mod:`nodesim.chain.scratch`), per tick of its longest node
(K_max), in their place: what of them is mapped at a time (a chunk of phase 1, the rows phase 2 reads), fitted on
the drilling day and its first one and two hours (2026-12-03)."""
STREAMED_NODE_BYTES = 38_800
"""A streamed run, per node: its objects (node, links, channels), its summary and its keys in the run summary."""


@dataclass(frozen=True)
class RunMemory:
    """A run's estimated peak memory [bytes] and the parts it is made of."""

    base_bytes: int
    per_realization_bytes: int  # R sum_n (K_n + 1) b_rt
    per_tick_bytes: int  # (the rows output.timeseries keeps) b_t + sum_n (K_n + 1) b_event
    node_ticks: int
    realizations: int

    @property
    def total_bytes(self) -> int:
        return self.base_bytes + self.per_realization_bytes + self.per_tick_bytes

    def __repr__(self) -> str:
        return (f"RunMemory({self.total_bytes / 1e9:.3g} GB: {self.node_ticks:,} node-ticks x {self.realizations} "
                f"realizations {self.per_realization_bytes / 1e9:.3g} GB + per node-tick {self.per_tick_bytes / 1e9:.3g} GB "
                f"+ base {self.base_bytes / 1e9:.3g} GB)")


def node_tick_counts(scenario: Scenario) -> list[int]:
    """Ticks of every node, node 1 first: (duration - its insertion) x the firmware rate (+ 1); a node ticks only
    once it is in its tube (every node from t = 0 on the lab profile)."""
    duration, rate, n = scenario.simulation.duration_s, scenario.chain.firmware_rate_hz, scenario.chain.nodes
    if scenario.motion.kind != "drilling":
        return [int(duration * rate) + 1] * n
    from nodesim.motion.chain_motion import build_motion

    return [int(max(duration - tl.present_from_s, 0.0) * rate) + 1 for tl in build_motion(scenario).timelines]


def _kept_rows(scenario: Scenario, ticks: list[int]) -> int:
    """The timeseries rows ``[output] timeseries`` keeps of a run whose nodes tick ``ticks`` times (node 1 first)."""
    out, n = scenario.output, len(ticks)
    return sum((k + out.tick_step - 1) // out.tick_step for i, k in enumerate(ticks, 1) if out.keeps_node(i, n))


def estimate_run_memory(scenario: Scenario, engine: str, streamed: bool = False) -> RunMemory:
    """The peak memory of running ``scenario`` on ``engine`` ('compiled' or 'event'), streamed (``nodesim run``; the
    SimPy engine streams only after its run, so it holds every record anyway) or not, module docstring."""
    ticks = node_tick_counts(scenario)
    node_ticks = sum(ticks)
    R = scenario.simulation.realizations
    b_rt = REALIZATION_TICK_BYTES[scenario.filter.implementation]
    if streamed and engine == "compiled":
        padded, k_max = len(ticks) * max(ticks), max(ticks)
        k_held = min(k_max, _window_ticks(scenario))  # the ticks of the longest node phase 2 holds at a time
        window = int(STREAMED_WINDOW_NODES * R * k_held * b_rt)
        base = STREAMED_BASE_BYTES + len(ticks) * STREAMED_NODE_BYTES
        if spills(len(ticks), k_max, R, scenario.mac.bit_errors):  # the whole-run tables on disk
            return RunMemory(base, window, int(k_held * (STREAMED_RUN_TICK_BYTES + SPILLED_RUN_TICK_BYTES)),
                             node_ticks, R)
        return RunMemory(base, R * padded * STREAMED_REALIZATION_TICK_BYTES + window,
                         int(padded * STREAMED_TICK_BYTES + k_held * STREAMED_RUN_TICK_BYTES), node_ticks, R)
    kept = _kept_rows(scenario, ticks)
    tables = kept * TICK_BYTES + (node_ticks * EVENT_ENGINE_TICK_BYTES if engine == "event" else 0)
    return RunMemory(BASE_BYTES, R * node_ticks * b_rt, tables, node_ticks, R)


def _window_ticks(scenario: Scenario) -> int:
    """A streamed run's ticks of one window of time (:mod:`nodesim.chain.compiled.time_windows`: its records, shared
    truth and mapped tables are a window's, not the run's) where phase 2 runs in windows, else of the whole run."""
    from nodesim.chain.compiled.time_windows import covers, window_s

    s = scenario.simulation
    seconds = window_s(s.duration_s) if covers(scenario) else s.duration_s
    return int(seconds * scenario.chain.firmware_rate_hz) + 1


def check_run_memory(scenario: Scenario, engine: str, available_bytes: int | None,
                     streamed: bool = False, out_dir=None) -> RunMemory:
    """The estimate, or a :class:`NodesimError` (one line: the estimate, what is available, the keys that bring it
    down, the largest part first) when it exceeds ``available_bytes`` (None: not known, not checked), or when the
    disk it needs (:func:`disk_needs`: its whole-run tables on disk, its table streamed into ``out_dir``) exceeds
    what is free there."""
    need = estimate_run_memory(scenario, engine, streamed)
    for need_bytes, where, free in disk_needs(scenario, engine, streamed, out_dir):
        if need_bytes > free:  # refused before any work, as for memory
            raise NodesimError(
                f"this run would need about {_gb(need.total_bytes)} GB of memory and {_gb(need_bytes)} GB of disk in "
                f"{where} ({need.node_ticks:,} node-ticks x {need.realizations} realization"
                f"{'' if need.realizations == 1 else 's'}), more than the {_gb(free)} GB free there: lower chain.nodes, "
                f"simulation.duration_s" + (", output.timeseries" if engine == "compiled" and streamed else ""))
    if available_bytes is None or need.total_bytes <= available_bytes:
        return need
    held = scenario.output.timeseries != "none" and not (streamed and engine == "compiled")  # a table in memory
    keys = ["chain.nodes", "simulation.duration_s"] + (["output.timeseries"] if held else [])
    if need.realizations > 1 and need.per_realization_bytes > need.per_tick_bytes:
        keys.insert(0, "simulation.realizations")
    raise NodesimError(
        f"this run would need about {_gb(need.total_bytes)} GB of memory ({need.node_ticks:,} node-ticks x "
        f"{need.realizations} realization{'' if need.realizations == 1 else 's'}), more than the {available_bytes / 1e9:.3g} GB available: lower "
        f"{', '.join(keys)}")


TABLE_ROW_BYTES = {"parquet": 31, "csv": 210}
"""Bytes on disk a row of the timeseries table takes, by ``output.format`` (the drilling day: 4.4 GB for 146.5 M rows
of Parquet; ``chain100_1h``: 143 MB for 684 k rows of CSV)."""


def disk_needs(scenario: Scenario, engine: str, streamed: bool, out_dir=None) -> list[tuple[int, str, float]]:
    """(bytes, where, free bytes there) for each file system a streamed compiled run writes to before it ends: its
    whole-run tables where they go to disk (:mod:`nodesim.chain.scratch`) and its timeseries table streamed into
    ``out_dir`` (:data:`TABLE_ROW_BYTES` a row it keeps); summed where both are on one file system."""
    if not (streamed and engine == "compiled"):
        return []
    ticks = node_tick_counts(scenario)
    n, k_max, R, bits = len(ticks), max(ticks), scenario.simulation.realizations, scenario.mac.bit_errors
    parts = []
    if spills(n, k_max, R, bits):
        parts.append((whole_run_table_bytes(n, k_max, R, bits), scratch_directory()))
    out = scenario.output
    if out_dir is not None and out.timeseries != "none":
        kept = _kept_rows(scenario, ticks)
        # realization 0's rows, in out_dir (nodesim run: a private directory beside the run directory: named by its parent)
        parts.append((kept * TABLE_ROW_BYTES[out.format], Path(out_dir).resolve().parent))
    needs: dict = {}
    for size, where in parts:
        free, device = free_disk_bytes(where)
        key = device if device is not None else str(where)
        old = needs.get(key)
        needs[key] = (size + (old[0] if old else 0), str(where) if old is None else f"{old[1]} and {where}", free)
    return list(needs.values())


def _gb(n_bytes: float) -> str:
    gb = n_bytes / 1e9
    return f"{gb:.3g}" if gb < 1000 else f"{gb:,.0f}"


def available_memory_bytes() -> int | None:
    """Memory the run can use now: the kernel's MemAvailable (Linux), else the physical memory, else None."""
    try:
        with open("/proc/meminfo", encoding="ascii") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    try:
        return os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return None
