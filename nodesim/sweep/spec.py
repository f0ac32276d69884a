"""Sweep files: a base scenario, axes over scenario keys, seeds per point, the metrics to keep.

A sweep file is TOML::

    name = "timeout-x-chain"
    base = "../lab/continuous.toml"      # scenario file, relative to the sweep file
    combine = "cross"                     # "cross" (every combination) or "zip" (axes advance together)
    seeds = 4                             # seeds per point (or an explicit list, e.g. [1, 2, 7])
    metrics = ["rms_azimuth_error_deg"]   # summary keys to keep (fnmatch patterns); default: every number
    keep_runs = false                     # keep each run directory under DIR/runs/<run_id>
    retries = 2                           # extra attempts of a crashing run before it is recorded as failed

    [overrides]                           # fixed dotted-key overrides applied to the base first
    "schedule.mode" = "windowed"

    [[axis]]
    key = "schedule.timeout_s"
    values = [10.0, 30.0, 60.0]           # or: range = [start, stop, num] (linear, both ends included)
                                          # or: logrange = [start, stop, num] (geometric, both ends included)

Seeds: with ``seeds = N`` the run seeds are ``base seed + 0 .. N-1`` for *every* point (common random
numbers: points differ only by their parameters, which sharpens comparisons between points).  A range whose
start and stop are TOML integers and whose values are all whole numbers gives integers (e.g. chain lengths).

Errors a user can cause are reported at load time, naming the file and the key: unknown top-level keys,
an axis key that is not a scenario key, an axis with no values or more than one way of giving them, zipped
axes of different lengths.  A *value* the scenario schema rejects (out of range) does not stop the campaign:
that point is planned as failed with the schema's message, and the other points run.
"""

from __future__ import annotations

import fnmatch
import hashlib
import itertools
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from nodesim.errors import NodesimError
from nodesim.io.rundir import dumps_json
from nodesim.scenario.schema import Scenario, load_scenario

TOP_KEYS = {"name", "description", "base", "combine", "seeds", "metrics", "keep_runs", "retries", "overrides", "axis"}
AXIS_KEYS = {"key", "values", "range", "logrange"}
MAX_RUNS = 10_000_000
# columns of the results table that are not metrics (a summary key of the same name is not kept as a metric)
RESERVED_COLUMNS = {"run_id", "point", "seed_index", "seed", "status", "error", "attempts", "wall_s", "worker"}


@dataclass(frozen=True)
class Axis:
    key: str
    values: tuple


@dataclass(frozen=True)
class RunTask:
    """One (point, seed) run: everything a worker needs, picklable, no open files."""

    run_id: str
    point: int
    seed_index: int
    seed: int
    params: tuple  # ((dotted key, value), ...) in axis order
    scenario: dict | None  # resolved, validated scenario (model_dump); None when the point is invalid
    invalid: str | None = None  # the schema's message for a point whose values it rejects
    metrics: tuple = ()
    keep_dir: str | None = None
    max_attempts: int = 3
    payload: dict = field(default_factory=dict)  # free data for synthetic run functions (benchmarks, tests)


@dataclass(frozen=True)
class SweepSpec:
    name: str
    description: str
    source: str
    base: Scenario
    base_hash: str
    combine: str
    seeds: tuple
    metrics: tuple
    keep_runs: bool
    retries: int
    overrides: tuple
    axes: tuple
    spec_hash: str

    def points(self) -> list[tuple]:
        """Parameter tuples ((key, value), ...) of every point, in a fixed order."""
        if not self.axes:
            return [()]
        if self.combine == "zip":
            return [tuple((a.key, v[i]) for i, a in enumerate(self.axes)) for v in zip(*(a.values for a in self.axes))]
        return [tuple(zip((a.key for a in self.axes), combo)) for combo in itertools.product(*(a.values for a in self.axes))]

    def plan(self, campaign_dir: Path | None = None) -> list[RunTask]:
        """Every run of the campaign, in (point, seed) order; invalid points carry the schema's message."""
        from nodesim.errors import ScenarioError

        tasks = []
        fixed = dict(self.overrides)
        for p, params in enumerate(self.points()):
            for s, seed in enumerate(self.seeds):
                run_id = f"p{p:05d}-s{s:03d}"
                try:
                    sc = self.base.with_overrides(**fixed, **dict(params), seed=int(seed)).model_dump()
                    invalid = None
                except ScenarioError as err:
                    sc, invalid = None, str(err).replace("<overrides>: ", "")
                keep = str(Path(campaign_dir) / "runs" / run_id) if (self.keep_runs and campaign_dir) else None
                tasks.append(
                    RunTask(run_id, p, s, int(seed), params, sc, invalid, self.metrics, keep, self.retries + 1)
                )
        return tasks

    def param_keys(self) -> list[str]:
        return [a.key for a in self.axes]

    def describe(self) -> dict:
        """JSON-able description stored in the campaign manifest."""
        return {
            "name": self.name,
            "description": self.description,
            "source": self.source,
            "base_scenario_sha256": self.base_hash,
            "combine": self.combine,
            "seeds": list(self.seeds),
            "metrics": list(self.metrics),
            "keep_runs": self.keep_runs,
            "retries": self.retries,
            "overrides": dict(self.overrides),
            "axes": [{"key": a.key, "values": list(a.values)} for a in self.axes],
            "spec_sha256": self.spec_hash,
        }


def _err(source: str, msg: str) -> NodesimError:
    return NodesimError(f"{source}: {msg}")


def scenario_keys(base: Scenario) -> set[str]:
    """Every dotted key of ``base`` (tables and leaves), e.g. ``schedule.timeout_s``: what an axis may vary."""
    keys: set[str] = set()

    def walk(prefix: str, obj: Any) -> None:
        if isinstance(obj, dict):
            for k, v in obj.items():
                walk(f"{prefix}{k}.", v)
        keys.add(prefix[:-1])

    walk("", base.model_dump())
    keys.discard("")
    return keys


def _axis_values(source: str, i: int, raw: dict) -> tuple:
    where = f"axis[{i}] ({raw.get('key', '?')})"
    unknown = set(raw) - AXIS_KEYS
    if unknown:
        raise _err(source, f"{where}: unknown key(s) {sorted(unknown)}; allowed: {sorted(AXIS_KEYS)}")
    given = [k for k in ("values", "range", "logrange") if k in raw]
    if len(given) != 1:
        raise _err(source, f"{where}: give exactly one of values, range = [start, stop, num], logrange = [start, stop, num]")
    kind = given[0]
    if kind == "values":
        values = raw["values"]
        if not isinstance(values, list) or not values:
            raise _err(source, f"{where}.values: must be a non-empty list")
        return tuple(values)
    spec = raw[kind]
    if (
        not isinstance(spec, list)
        or len(spec) != 3
        or not all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in spec)
        or not isinstance(spec[2], int)
        or spec[2] < 1
    ):
        raise _err(source, f"{where}.{kind}: must be [start, stop, num] with num an integer >= 1 (got {spec!r})")
    start, stop, num = spec
    if kind == "logrange":
        if start <= 0 or stop <= 0:
            raise _err(source, f"{where}.logrange: start and stop must be > 0 (got {start}, {stop})")
        return tuple(float(v) for v in np.geomspace(start, stop, num))
    values = np.linspace(start, stop, num)
    if isinstance(start, int) and isinstance(stop, int) and np.all(values == np.round(values)):
        return tuple(int(v) for v in values)
    return tuple(float(v) for v in values)


def parse_sweep(data: dict, source: str, base_dir: Path) -> SweepSpec:
    """Validate a parsed sweep TOML; ``base`` paths resolve against ``base_dir``."""
    unknown = set(data) - TOP_KEYS
    if unknown:
        raise _err(source, f"unknown key(s) {sorted(unknown)}; allowed: {sorted(TOP_KEYS)}")
    if "base" not in data or not isinstance(data["base"], str):
        raise _err(source, "base: required, the path of the base scenario TOML (relative to the sweep file)")
    base, base_hash = load_scenario(base_dir / data["base"])
    name = data.get("name", Path(source).stem)
    combine = data.get("combine", "cross")
    if combine not in ("cross", "zip"):
        raise _err(source, f"combine: must be 'cross' or 'zip' (got {combine!r})")
    seeds_raw = data.get("seeds", 1)
    if isinstance(seeds_raw, bool) or not isinstance(seeds_raw, (int, list)):
        raise _err(source, f"seeds: an integer count >= 1 or a list of seeds (got {seeds_raw!r})")
    if isinstance(seeds_raw, int):
        if not 1 <= seeds_raw <= 1_000_000:
            raise _err(source, f"seeds: count must be in [1, 1000000] (got {seeds_raw})")
        seeds = tuple(base.seed + i for i in range(seeds_raw))
    else:
        if not seeds_raw or not all(isinstance(s, int) and not isinstance(s, bool) and s >= 0 for s in seeds_raw):
            raise _err(source, f"seeds: a list must hold integers >= 0 (got {seeds_raw!r})")
        if len(set(seeds_raw)) != len(seeds_raw):
            raise _err(source, f"seeds: duplicated seeds in {seeds_raw!r}")
        seeds = tuple(seeds_raw)
    metrics = data.get("metrics", [])
    if not isinstance(metrics, list) or not all(isinstance(m, str) and m for m in metrics):
        raise _err(source, "metrics: a list of summary keys (fnmatch patterns allowed), e.g. ['rms_azimuth_error_deg']")
    keep_runs = data.get("keep_runs", False)
    retries = data.get("retries", 2)
    if not isinstance(keep_runs, bool):
        raise _err(source, f"keep_runs: true or false (got {keep_runs!r})")
    if isinstance(retries, bool) or not isinstance(retries, int) or not 0 <= retries <= 10:
        raise _err(source, f"retries: an integer in [0, 10] (got {retries!r})")
    keys = scenario_keys(base)
    overrides = data.get("overrides", {})
    if not isinstance(overrides, dict):
        raise _err(source, "overrides: a table of dotted scenario keys")
    for k in overrides:
        if k not in keys:
            raise _err(source, f"overrides: '{k}' is not a scenario key (see `nodesim run BASE --dry-run`)")
    axes_raw = data.get("axis", [])
    if not isinstance(axes_raw, list):
        raise _err(source, "axis: use [[axis]] tables")
    axes = []
    for i, raw in enumerate(axes_raw):
        key = raw.get("key")
        if not isinstance(key, str) or key not in keys:
            raise _err(source, f"axis[{i}].key: {key!r} is not a scenario key (see `nodesim run BASE --dry-run`)")
        if key == "seed":
            raise _err(source, f"axis[{i}].key: 'seed' is set by `seeds`, not by an axis")
        if key in overrides or key in (a.key for a in axes):
            raise _err(source, f"axis[{i}].key: '{key}' is given twice")
        axes.append(Axis(key, _axis_values(source, i, raw)))
    if combine == "zip" and len({len(a.values) for a in axes}) > 1:
        lengths = {a.key: len(a.values) for a in axes}
        raise _err(source, f"combine = 'zip' needs axes of equal length (got {lengths})")
    n_points = 1
    for a in axes:
        n_points = len(a.values) if combine == "zip" else n_points * len(a.values)
    if n_points * len(seeds) > MAX_RUNS:
        raise _err(source, f"{n_points} points x {len(seeds)} seeds exceeds {MAX_RUNS} runs")
    described = {k: data.get(k) for k in sorted(TOP_KEYS - {"base"})}
    spec_hash = hashlib.sha256(dumps_json({"sweep": described, "base": base.model_dump()})).hexdigest()
    return SweepSpec(
        name=str(name),
        description=str(data.get("description", "")),
        source=source,
        base=base,
        base_hash=base_hash,
        combine=combine,
        seeds=seeds,
        metrics=tuple(metrics),
        keep_runs=keep_runs,
        retries=retries,
        overrides=tuple(overrides.items()),
        axes=tuple(axes),
        spec_hash=spec_hash,
    )


def read_toml_file(path: Path, what: str) -> dict:
    """The tables of a TOML file; an unreadable or invalid file is a NodesimError naming it (``what``: "sweep",
    "optimisation")."""
    try:
        return tomllib.loads(path.read_bytes().decode("utf-8"))
    except OSError as err:
        raise NodesimError(f"{path}: cannot read {what} file ({err.strerror})") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as err:
        raise NodesimError(f"{path}: not valid TOML ({err})") from None


def load_sweep(path: str | Path) -> SweepSpec:
    """Read and validate a sweep TOML file."""
    path = Path(path)
    return parse_sweep(read_toml_file(path, "sweep"), str(path), path.parent)


def select_metrics(summary: dict, patterns: tuple) -> dict[str, float]:
    """Flatten ``summary`` (nested dicts -> dotted keys, timing dropped) and keep the numeric metrics.

    With no patterns every number (bools excluded) is kept.  A pattern that matches no numeric key raises
    NodesimError listing the available keys (the run is then recorded as failed with that message).
    """
    flat: dict[str, Any] = {}

    def walk(prefix: str, obj: Any) -> None:
        for k, v in obj.items():
            if isinstance(v, dict):
                walk(f"{prefix}{k}.", v)
            else:
                flat[f"{prefix}{k}"] = v

    walk("", {k: v for k, v in summary.items() if k != "timing"})
    numeric = {
        k: (float("nan") if v is None else float(v))
        for k, v in flat.items()
        if k not in RESERVED_COLUMNS
        and (v is None or (isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool)))
    }
    if not patterns:
        return numeric
    kept: dict[str, float] = {}
    for pat in patterns:
        hits = [k for k in numeric if fnmatch.fnmatchcase(k, pat)]
        if not hits:
            raise NodesimError(f"metric '{pat}' matches no numeric summary key; available: {sorted(numeric)}")
        kept.update({k: numeric[k] for k in hits})
    return kept
