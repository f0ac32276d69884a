"""The Python API: a scenario in, a :class:`Run` out; a run directory written or read back.

    >>> import nodesim
    >>> run = nodesim.simulate("scenarios/lab/continuous.toml", seed=7, **{"chain.nodes": 2})
    >>> run.summary["rms_azimuth_error_deg"]          # the summary.json dict
    >>> run.timeseries.head()                          # pandas DataFrames, the CSV files' columns
    >>> fig = run.plot_yaw()                           # a matplotlib Figure
    >>> run.save("runs/two-nodes")                     # the run directory `nodesim run` writes
    >>> nodesim.load_run("runs/two-nodes") == run      # True

``simulate`` writes nothing; :meth:`Run.save` writes every file atomically (temp file + rename) and refuses a
directory that already holds a run.  ``nodesim run`` is ``simulate`` followed by ``save``.
"""

from __future__ import annotations

import json
import os
import time
from datetime import datetime, timezone
from pathlib import Path
from typing import Any, Callable

import numpy as np

from nodesim.errors import NodesimError
from nodesim.io.rundir import (
    atomic_write_with,
    check_empty_dir,
    default_run_dir,
    git_commit,
    host_info,
    package_version,
    replace_dir,
    write_csv,
    read_parquet,
    write_json,
    write_parquet,
    write_png,
)
from nodesim.scenario.schema import Scenario, parse_scenario, read_scenario

TABLES = ("realizations", "timeseries", "hops", "surveys", "ground_survey")  # <name>.csv, in writing order
TIMESERIES_FILES = {"parquet": "timeseries.parquet", "csv": "timeseries.csv"}  # by [output] format
PLOT_FILE = "yaw_error.png"
RUN_FILES = ("summary.json", "manifest.json", PLOT_FILE, "timeseries.parquet") + tuple(f"{t}.csv" for t in TABLES)


def simulate(
    scenario: "str | Path | dict | Scenario",
    *,
    seed: int | None = None,
    realizations: int | None = None,
    progress: Callable[[float], None] | None = None,
    **overrides: Any,
) -> "Run":
    """Simulate ``scenario`` (a path, a TOML string, a dict or a :class:`Scenario`) and return its :class:`Run`.

    ``seed`` and ``realizations`` override the scenario's root seed and ``simulation.realizations``;
    ``overrides`` take dotted keys (``**{"chain.nodes": 20}``), validated like the TOML (an unknown key or a
    value out of range raises :class:`nodesim.NodesimError` naming it).  ``progress(fraction)`` is called as
    simulated time advances.  Nothing is written to disk.
    """
    parsed, digest = read_scenario(scenario)
    changes = dict(overrides)
    if seed is not None:
        changes["seed"] = seed
    if realizations is not None:
        changes["simulation.realizations"] = realizations
    if changes:
        parsed = parsed.with_overrides(**changes)
    return simulate_scenario(parsed, digest, progress)


def simulate_scenario(scenario: Scenario, scenario_sha256: str | None,
                      progress: Callable[[float], None] | None = None, stream_to: str | Path | None = None) -> "Run":
    """:func:`simulate` for a validated scenario whose source hash the caller knows (``nodesim run``, sweeps).

    ``stream_to``: a directory (``nodesim run`` uses a private one beside the run directory) where the run writes
    its timeseries table node by node while it simulates (:mod:`nodesim.chain.streaming`): the run then never holds
    every node's per-tick records, and :meth:`Run.save` moves the table into the run directory.  The run's files
    are the same as without it."""
    from nodesim.chain.compiled.engine import choose_engine
    from nodesim.chain.estimator import require_engine_filter
    from nodesim.chain.memory_budget import available_memory_bytes, check_run_memory
    from nodesim.chain.metrics import per_realization_metrics, summarize
    from nodesim.chain.network import simulate_chain
    from nodesim.chain.run_tables import run_tables

    require_engine_filter(scenario)  # filter.states = 6: its tuning checked before any work (issue 24)
    engine = choose_engine(scenario)
    check_run_memory(scenario, engine, available_memory_bytes(), streamed=stream_to is not None,
                     out_dir=stream_to)  # before any work: memory, and the disk a streamed run writes to
    started = datetime.now(timezone.utc)
    t0 = time.perf_counter()
    stream = table = None
    if stream_to is not None:
        from nodesim.chain.streaming import NodeStream, TimeseriesFile
        from nodesim.motion.chain_motion import build_motion

        table = TimeseriesFile(Path(stream_to) / TIMESERIES_FILES[scenario.output.format], scenario.output.format)
        stream = NodeStream(scenario, build_motion(scenario), table)
    try:
        chain = simulate_chain(scenario, progress, on_node=stream)
        if table is not None:
            table.close()
    except BaseException:
        if table is not None:
            table.abort()
        raise
    t_sim = time.perf_counter() - t0
    per_real = per_realization_metrics(chain, scenario.metrics)
    summary = summarize(per_real)
    summary["scenario"] = scenario.name
    summary["seed"] = scenario.seed
    summary["simpy_events"] = chain.simpy_events
    summary["engine"] = chain.engine
    summary["nodes"] = chain.node_count
    summary["firmware_saturations"] = sum(sum(n.firmware_overflows.values()) for n in chain.node_results)
    tables = run_tables(chain, per_real, scenario.output)
    summary["timing"] = {"simulation_s": t_sim, "wall_s": time.perf_counter() - t0}
    manifest = {
        "nodesim_version": package_version(),
        "git_commit": git_commit(),
        "scenario_sha256": scenario_sha256,
        "scenario": scenario.model_dump(),
        "root_seed": scenario.seed,
        "started_utc": started.isoformat(),
        "wall_time_s": None,  # set by Run.save: simulation and writing
        "host": host_info(),
    }
    run = Run(scenario, summary, manifest, tables, chain.rotation_end_s, chain)
    if stream is not None:
        run._streamed = (table.path, stream.plot)
    return run


class Run:
    """One simulated run: its scenario, summary, tables and plots (what a run directory holds).

    Tables are pandas DataFrames with the columns of the run directory's files: ``timeseries``
    (realization 0, one row per node and tick that ``[output] timeseries`` keeps; ``timeseries.parquet``, or
    ``timeseries.csv`` with ``[output] format = "csv"``), ``realizations`` (per-realization metrics), ``hops`` (one
    row per hop), ``surveys`` and ``ground_survey`` (drilling runs; None otherwise).  ``chain`` is the
    simulation's :class:`nodesim.chain.network.ChainRun` (every per-tick array of every realization) for a
    run made here, None for a run loaded from a directory.
    """

    def __init__(self, scenario: Scenario, summary: dict, manifest: dict, tables: dict[str, dict[str, np.ndarray]],
                 rotation_end_s: float, chain=None):
        self.scenario = scenario
        self.summary = summary
        self.manifest = manifest
        self._tables = tables
        self._frames: dict = {}
        self.rotation_end_s = float(rotation_end_s)
        self.chain = chain
        self._streamed: tuple[Path, Any] | None = None  # a streamed run: (its timeseries file, its YawPlotData)

    def __repr__(self) -> str:
        s = self.summary
        azi = s.get("rms_azimuth_error_deg")
        shown = "n/a" if azi is None else f"{azi:.4g} deg"
        return (f"Run(scenario={self.scenario.name!r}, engine={s.get('engine')!r}, nodes={s.get('nodes')}, "
                f"realizations={s.get('realizations')}, seed={s.get('seed')}, rms_azimuth_error={shown}, "
                f"tables={list(self._tables)})")

    def __eq__(self, other: object) -> bool:
        """Same scenario, summary (timing included) and tables, value for value (NaN equals NaN)."""
        if not isinstance(other, Run):
            return NotImplemented
        return (self.scenario == other.scenario and self.summary == other.summary
                and list(self._tables) == list(other._tables)
                and all(_same_table(self._columns(k), other._columns(k)) for k in self._tables))

    def _columns(self, name: str) -> dict[str, np.ndarray]:
        """Table ``name``'s columns; a streamed run's timeseries read back from its file (on first use)."""
        if self._tables[name] is None:  # the timeseries of a streamed run
            frame = _read_table(self._streamed[0])
            self._tables[name] = {k: frame[k].to_numpy() for k in frame.columns}
        return self._tables[name]

    __hash__ = None  # mutable summary timing: not hashable

    # -- tables ---------------------------------------------------------------------------------------------
    def table(self, name: str):
        """The table ``name`` (one of :data:`TABLES`) as a DataFrame, or None if this run has none."""
        if name not in TABLES:
            raise NodesimError(f"table {name!r}: unknown (allowed: {', '.join(TABLES)})")
        if name not in self._tables:
            return None
        if name not in self._frames:
            import pandas as pd

            self._frames[name] = pd.DataFrame({k: np.asarray(v) for k, v in self._columns(name).items()})
        return self._frames[name]

    @property
    def timeseries(self):
        return self.table("timeseries")

    @property
    def realizations(self):
        return self.table("realizations")

    @property
    def hops(self):
        return self.table("hops")

    @property
    def surveys(self):
        return self.table("surveys")

    @property
    def ground_survey(self):
        return self.table("ground_survey")

    # -- plots ----------------------------------------------------------------------------------------------
    def plot_yaw(self):
        """Yaw error and bias estimate of every node against time (realization 0) as a matplotlib Figure."""
        from nodesim.chain.yaw_plot import YawPlotData, yaw_figure

        data = self._streamed[1] if self._streamed else YawPlotData.from_table(
            self._tables["timeseries"], self.scenario.simulation.duration_s)
        return yaw_figure(data, self.rotation_end_s, f"{self.scenario.name}: realization 0")

    def plot_wellpath(self, tool: str = "mpu6500_filtered", sigma: str = "2", propagation: str = "iscwsa"):
        """The received surveys' wellpath (realization 0, plan view) with its uncertainty ellipses for
        ``tool`` at ``sigma`` ("1", "2" or "95") as a matplotlib Figure; drilling runs only.  ``propagation``:
        "iscwsa" (standard, default) or "thesis" (the thesis-replica propagation, per-axis, no cross terms)."""
        from nodesim.ground import load_tool, make_survey, position_uncertainty
        from nodesim.ground.ellipsoid import confidence_scale
        from nodesim.ground.wellpath_plot import uncertainty_figure

        g = self._tables.get("ground_survey")
        if g is None:
            raise NodesimError(f"{self.scenario.name}: no surveys to plot (motion.kind = "
                               f"{self.scenario.motion.kind!r}; wellpaths come from drilling runs)")
        survey = make_survey(g["md_m"], g["inc_deg"], g["azi_deg"], g["time_s"], where="ground_survey",
                             sigma_inc_deg=g["sigma_inc_deg"], sigma_azi_deg=g["sigma_azi_deg"])
        u = position_uncertainty(survey, load_tool(tool), propagation=propagation)
        return uncertainty_figure(u, confidence_scale(sigma, dof=1),
                                  f"{self.scenario.name}: realization 0, tool {u.model.name}")

    # -- files ----------------------------------------------------------------------------------------------
    def save(self, directory: str | Path | None = None, *, plots: bool = True, force: bool = False) -> Path:
        """Write the run directory (what ``nodesim run`` writes; default ``runs/<name>-<UTC timestamp>``).

        Tables first, then the plot, then ``summary.json`` and ``manifest.json`` (a directory with a summary
        is a finished run).  A non-empty directory is refused, so runs never mix; with ``force=True`` the run
        is written into a fresh sibling directory that then replaces it (:func:`nodesim.io.rundir.replace_dir`),
        so it holds only this run.
        """
        t0 = time.perf_counter()
        out = Path(directory) if directory is not None else default_run_dir(
            self.scenario.name, datetime.fromisoformat(self.manifest["started_utc"]))
        if force:
            with replace_dir(out) as stage:
                self._write(stage, plots, t0)
        else:
            check_unused(out)
            self._write(out, plots, t0)
        return out

    def _write(self, out: Path, plots: bool, t0: float) -> None:
        from nodesim.chain.streaming import PARQUET_OPTIONS, timeseries_table

        for name, columns in self._tables.items():
            if name == "timeseries" and self._streamed is not None:
                self._place_streamed(out)
            elif name == "timeseries" and self.scenario.output.format == "parquet":
                write_parquet(out / "timeseries.parquet", timeseries_table(columns), **PARQUET_OPTIONS)
            else:
                write_csv(out / f"{name}.csv", columns)
        rows = bool(self._streamed[1].node_ids) if self._streamed else self._tables["timeseries"]["node"].size > 0
        if plots and rows:  # output.timeseries = "none": nothing to plot
            write_png(out / PLOT_FILE, self.plot_yaw())
        timing = self.summary["timing"]
        timing["save_s"] = time.perf_counter() - t0
        self.manifest["wall_time_s"] = timing["wall_s"] + timing["save_s"]
        write_json(out / "summary.json", self.summary)
        write_json(out / "manifest.json", self.manifest)


    def _place_streamed(self, out: Path) -> None:
        """Move a streamed run's timeseries file into ``out`` (a rename beside it, else a copy), where it then is."""
        import shutil

        src = self._streamed[0]
        dst = Path(out) / src.name
        if src.resolve() == dst.resolve():
            return
        try:
            os.replace(src, dst)
        except OSError:  # another file system: copy through a temporary file
            atomic_write_with(dst, lambda p: shutil.copyfile(src, p))
        self._streamed = (dst, self._streamed[1])


def check_unused(directory: str | Path) -> None:
    """Refuse an existing non-empty directory (runs never mix; nothing is overwritten without ``force``)."""
    check_empty_dir(directory, "run", RUN_FILES)


def load_run(directory: str | Path) -> Run:
    """Read a run directory written by :meth:`Run.save` (or ``nodesim run``) back into a :class:`Run`."""
    from nodesim.motion.chain_motion import build_motion

    d = Path(directory)
    files = {name: d / name for name in ("summary.json", "manifest.json")}
    missing = [name for name, path in files.items() if not path.is_file()]
    if missing:
        raise NodesimError(f"{d}: not a run directory (no {', '.join(missing)})")
    try:
        summary = json.loads(files["summary.json"].read_text())
        manifest = json.loads(files["manifest.json"].read_text())
    except (OSError, json.JSONDecodeError) as err:
        raise NodesimError(f"{d}: unreadable run file ({err})") from None
    scenario = parse_scenario(manifest.get("scenario", {}), source=f"{files['manifest.json']}: scenario")
    tables = {}
    for name in TABLES:
        path = d / f"{name}.csv"
        if name == "timeseries" and (d / "timeseries.parquet").is_file():
            frame = _read_table(d / "timeseries.parquet")
        elif path.is_file():
            frame = _read_table(path)
        else:
            continue
        tables[name] = {k: frame[k].to_numpy() for k in frame.columns}
    if "timeseries" not in tables:
        raise NodesimError(f"{d}: not a run directory (no timeseries.parquet or timeseries.csv)")
    return Run(scenario, summary, manifest, tables, build_motion(scenario).rotation_end_s)


def _read_table(path: Path):
    """A table file of a run directory as a DataFrame: Parquet, or CSV with its floats parsed exactly ("nan" the
    only missing value)."""
    if path.suffix == ".parquet":
        return read_parquet(path)
    import pandas as pd

    # pandas >= 3 parses floats exactly by default (and deprecates the option); older pandas needs asking
    exact = {} if int(pd.__version__.split(".")[0]) >= 3 else {"float_precision": "round_trip"}
    return pd.read_csv(path, keep_default_na=False, na_values=["nan"], **exact)


def _same_table(a: dict[str, np.ndarray], b: dict[str, np.ndarray]) -> bool:
    return list(a) == list(b) and all(_same_column(np.asarray(a[k]), np.asarray(b[k])) for k in a)


def _same_column(a: np.ndarray, b: np.ndarray) -> bool:
    if a.shape != b.shape:
        return False
    if a.dtype.kind in "biuf" and b.dtype.kind in "biuf":
        return bool(np.array_equal(a.astype(float), b.astype(float), equal_nan=True))
    return a.astype(str).tolist() == b.astype(str).tolist()

