"""Optimisation files: a base scenario, decision variables, objectives and constraints.

An optimisation file is TOML::

    name = "lab-0p3deg"
    base = "../lab/continuous.toml"   # scenario file, relative to this file (or an inline [scenario] table)
    realizations = 8                   # realizations of every trial's batched Monte Carlo run
    seed = 20260101                    # root seed of every trial (default: the base scenario's seed)
    trials = 48                        # default trial budget (--trials overrides it)
    batch = 8                          # trials asked and run together (NSGA-II: the population size)
    sampler = "nsga2"                  # "nsga2" | "tpe" | "random"; default nsga2 (>= 2 objectives) or tpe
    sampler_seed = 1                   # seed of the sampler (default 0)
    recommend = "radio_energy_j"       # objective the recommendation minimises/maximises (default: the first)
    validation_seed = 777              # fresh root seed of the validation run of the recommendation
    validation_realizations = 16       # its realizations (default: realizations)
    record = ["delivery_ratio"]        # further summary keys kept in trials.parquet

    [overrides]                        # fixed dotted-key overrides applied to the base first
    "radio.soil.vwc" = 0.275

    [baseline]                         # optional reference schedule, run with the validation seed
    "schedule.mode" = "continuous"

    [[variable]]
    key = "schedule.mode"
    choices = ["continuous", "windowed", "single"]

    [[variable]]
    key = "schedule.timeout_s"
    low = 5.0                          # bounds, both included
    high = 120.0
    step = 5.0                         # optional grid step; log = true for a log-uniform range
    type = "float"                     # "float" (default) or "int" (default when low and high are integers)
    when = { "schedule.mode" = "windowed" }   # optional: suggested only when these variables take these values

    [[objective]]
    key = "radio_energy_j"
    direction = "minimize"             # or "maximize"

    [[constraint]]
    key = "rms_azimuth_error_deg_p95"
    max = 0.3                          # and/or min = ...

Common random numbers: every trial runs with the same root seed and realizations, so trials differ only by
their decision variables.  Keys are validated like a sweep's (:func:`nodesim.sweep.spec.scenario_keys`): an
unknown key, an empty or reversed range, a variable given twice, an objective also used as a constraint with
no bound, are errors naming the file and the key.  Whether an objective or constraint key is produced by a
run (e.g. ``*_p95`` keys need ``realizations`` > 1) is known only after the first runs: the search stops with
an error naming the key and the closest produced keys (:mod:`nodesim.optimization.search`).
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from nodesim.errors import NodesimError, ScenarioError
from nodesim.io.rundir import dumps_json
from nodesim.scenario.schema import Scenario, load_scenario, parse_scenario
from nodesim.sweep.spec import RunTask, read_toml_file, scenario_keys

TOP_KEYS = {
    "name", "description", "base", "scenario", "realizations", "seed", "trials", "batch", "sampler", "sampler_seed",
    "recommend", "validation_seed", "validation_realizations", "record", "overrides", "baseline", "variable",
    "objective", "constraint",
}
VARIABLE_KEYS = {"key", "choices", "low", "high", "step", "log", "type", "when"}
SAMPLERS = ("nsga2", "tpe", "random")
MAX_TRIALS = 100_000


@dataclass(frozen=True)
class Variable:
    """One decision variable: categorical ``choices`` or a numeric ``[low, high]`` range (optional step/log)."""

    key: str
    choices: tuple | None = None
    low: float | None = None
    high: float | None = None
    step: float | None = None
    log: bool = False
    kind: str = "float"  # "float" | "int" | "categorical"
    when: tuple = ()  # ((variable key, required value), ...)

    def active(self, params: dict) -> bool:
        return all(params.get(k) == v for k, v in self.when)

    def suggest(self, trial) -> Any:
        """The Optuna suggestion for this variable (the parameter is named by the dotted key)."""
        if self.kind == "categorical":
            return trial.suggest_categorical(self.key, list(self.choices))
        if self.kind == "int":
            return trial.suggest_int(self.key, int(self.low), int(self.high), step=int(self.step or 1), log=self.log)
        return trial.suggest_float(self.key, self.low, self.high, step=self.step, log=self.log)

    def grid(self) -> list:
        """Every value of a categorical, stepped or integer variable (for exhaustive comparisons; an int steps by 1
        unless given a step)."""
        if self.kind == "categorical":
            return list(self.choices)
        step = self.step if self.step is not None else (1.0 if self.kind == "int" else None)  # as suggest_int
        if step is None:
            raise NodesimError(f"variable {self.key}: a grid needs a step")
        n = int(math.floor((self.high - self.low) / step + 1e-9))
        values = [self.low + i * step for i in range(n + 1)]
        return [int(v) for v in values] if self.kind == "int" else [float(v) for v in values]

    def describe(self) -> dict:
        d = {"key": self.key, "type": self.kind}
        if self.kind == "categorical":
            d["choices"] = list(self.choices)
        else:
            d.update(low=self.low, high=self.high, step=self.step, log=self.log)
        if self.when:
            d["when"] = dict(self.when)
        return d


@dataclass(frozen=True)
class Objective:
    key: str
    direction: str  # "minimize" | "maximize"

    def sign(self) -> float:
        """+1 for minimise, -1 for maximise: ``sign * value`` is always minimised."""
        return 1.0 if self.direction == "minimize" else -1.0


@dataclass(frozen=True)
class Constraint:
    """``min <= value <= max``; violation v = max(value - max, min - value), feasible when v <= 0."""

    key: str
    max: float | None = None
    min: float | None = None

    def violation(self, value: float) -> float:
        """v = max(value - max, min - value) (a NaN value - the metric undefined - counts as violated: +inf)."""
        if value is None or not math.isfinite(value):
            return math.inf
        parts = []
        if self.max is not None:
            parts.append(value - self.max)
        if self.min is not None:
            parts.append(self.min - value)
        return max(parts)

    def text(self) -> str:
        if self.min is not None and self.max is not None:
            return f"{self.min} <= {self.key} <= {self.max}"
        return f"{self.key} <= {self.max}" if self.max is not None else f"{self.key} >= {self.min}"


@dataclass(frozen=True)
class Problem:
    name: str
    description: str
    source: str
    base: Scenario  # the base scenario with the fixed overrides, realizations and seed applied
    realizations: int
    seed: int
    trials: int
    batch: int
    sampler: str
    sampler_seed: int
    recommend: str
    validation_seed: int
    validation_realizations: int
    record: tuple
    overrides: tuple
    baseline: tuple
    variables: tuple
    objectives: tuple
    constraints: tuple
    spec_hash: str

    def metric_keys(self) -> tuple:
        """Summary keys every trial keeps: objectives, constraints, then ``record`` (no repeats)."""
        keys = [o.key for o in self.objectives] + [c.key for c in self.constraints] + list(self.record)
        return tuple(dict.fromkeys(keys))

    def variable_keys(self) -> list[str]:
        return [v.key for v in self.variables]

    def suggest(self, trial) -> dict:
        """Decision values of an Optuna trial, in variable order (conditional variables only when active)."""
        params: dict = {}
        for v in self.variables:
            if v.active(params):
                params[v.key] = v.suggest(trial)
        return params

    def task(self, number: int, params: dict, seed: int | None = None, realizations: int | None = None,
             payload: dict | None = None) -> RunTask:
        """The run of one trial: the base scenario with ``params``, the common root seed and realizations."""
        changes = dict(params)
        changes["seed"] = int(self.seed if seed is None else seed)
        if realizations is not None:
            changes["simulation.realizations"] = int(realizations)
        try:
            scenario, invalid = self.base.with_overrides(**changes).model_dump(), None
        except ScenarioError as err:
            scenario, invalid = None, str(err).replace("<overrides>: ", "")
        return RunTask(f"t{number:05d}", number, 0, changes["seed"], tuple(params.items()), scenario, invalid,
                       self.metric_keys(), None, 1, payload or {})

    def describe(self) -> dict:
        return {
            "name": self.name, "description": self.description, "source": self.source,
            "realizations": self.realizations, "seed": self.seed, "trials": self.trials, "batch": self.batch,
            "sampler": self.sampler, "sampler_seed": self.sampler_seed, "recommend": self.recommend,
            "validation_seed": self.validation_seed, "validation_realizations": self.validation_realizations,
            "record": list(self.record), "overrides": dict(self.overrides), "baseline": dict(self.baseline),
            "variables": [v.describe() for v in self.variables],
            "objectives": [{"key": o.key, "direction": o.direction} for o in self.objectives],
            "constraints": [{"key": c.key, "min": c.min, "max": c.max} for c in self.constraints],
            "spec_sha256": self.spec_hash,
        }


def _err(source: str, msg: str) -> NodesimError:
    return NodesimError(f"{source}: {msg}")


def where_of(i: int, key: str) -> str:
    return f"variable[{i}] ({key})"


def _number(x: Any) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def _int_in(source: str, data: dict, key: str, default: int, lo: int, hi: int) -> int:
    value = data.get(key, default)
    if isinstance(value, bool) or not isinstance(value, int) or not lo <= value <= hi:
        raise _err(source, f"{key}: an integer in [{lo}, {hi}] (got {value!r})")
    return value


def _variable(source: str, i: int, raw: Any, keys: set, earlier: dict) -> Variable:
    if not isinstance(raw, dict):
        raise _err(source, f"variable[{i}]: use [[variable]] tables")
    key = raw.get("key")
    where = where_of(i, key)
    unknown = set(raw) - VARIABLE_KEYS
    if unknown:
        raise _err(source, f"{where}: unknown key(s) {sorted(unknown)}; allowed: {sorted(VARIABLE_KEYS)}")
    if not isinstance(key, str) or key not in keys:
        raise _err(source, f"variable[{i}].key: {key!r} is not a scenario key (see `nodesim run BASE --dry-run`)")
    if key in ("seed", "simulation.realizations"):
        raise _err(source, f"variable[{i}].key: '{key}' is fixed by the optimisation (common random numbers)")
    when_raw = raw.get("when", {})
    if not isinstance(when_raw, dict):
        raise _err(source, f"{where}.when: a table {{variable key = value}}")
    for k, v in when_raw.items():
        if k not in earlier:
            raise _err(source, f"{where}.when: '{k}' is not an earlier variable")
        if earlier[k].kind == "categorical" and v not in earlier[k].choices:
            raise _err(source, f"{where}.when: {k} = {v!r} is not one of its choices {list(earlier[k].choices)}")
    when = tuple(when_raw.items())
    if "choices" in raw:
        if set(raw) & {"low", "high", "step", "log"}:
            raise _err(source, f"{where}: give either choices or low/high, not both")
        choices = raw["choices"]
        if not isinstance(choices, list) or not choices:
            raise _err(source, f"{where}.choices: must be a non-empty list")
        if len(set(map(repr, choices))) != len(choices):
            raise _err(source, f"{where}.choices: repeated values in {choices!r}")
        if raw.get("type", "categorical") != "categorical":
            raise _err(source, f"{where}.type: choices make a categorical variable")
        return Variable(key, tuple(choices), kind="categorical", when=when)
    low, high = raw.get("low"), raw.get("high")
    if not (_number(low) and _number(high)):
        raise _err(source, f"{where}: give choices = [...] or numeric low and high (got low={low!r}, high={high!r})")
    if not low < high:
        raise _err(source, f"{where}: empty range, low must be < high (got [{low}, {high}])")
    kind = raw.get("type", "int" if isinstance(low, int) and isinstance(high, int) else "float")
    if kind not in ("int", "float"):
        raise _err(source, f"{where}.type: 'int' or 'float' (got {kind!r})")
    step, log = raw.get("step"), raw.get("log", False)
    if not isinstance(log, bool):
        raise _err(source, f"{where}.log: true or false (got {log!r})")
    if step is not None and (not _number(step) or step <= 0 or step > high - low):
        raise _err(source, f"{where}.step: a number in (0, high - low] (got {step!r})")
    if log and (low <= 0 or step not in (None, 1)):
        raise _err(source, f"{where}.log: needs low > 0 and no step")
    if kind == "int" and (low != int(low) or high != int(high) or (step is not None and step != int(step))):
        raise _err(source, f"{where}: an int variable needs integer low, high and step")
    return Variable(key, None, float(low), float(high), None if step is None else float(step), log, kind, when)


def _bounded_keys(source: str, name: str, raw: Any) -> list[dict]:
    if not isinstance(raw, list) or not all(isinstance(r, dict) for r in raw):
        raise _err(source, f"{name}: use [[{name}]] tables")
    for i, r in enumerate(raw):
        if not isinstance(r.get("key"), str) or not r["key"]:
            raise _err(source, f"{name}[{i}].key: a summary key, e.g. 'rms_azimuth_error_deg_p95'")
    return raw


def parse_problem(data: dict, source: str, base_dir: Path) -> Problem:
    """Validate a parsed optimisation TOML; ``base`` paths resolve against ``base_dir``."""
    unknown = set(data) - TOP_KEYS
    if unknown:
        raise _err(source, f"unknown key(s) {sorted(unknown)}; allowed: {sorted(TOP_KEYS)}")
    if ("base" in data) == ("scenario" in data):
        raise _err(source, "give exactly one of base = 'path/to/scenario.toml' or an inline [scenario] table")
    if "base" in data:
        if not isinstance(data["base"], str):
            raise _err(source, "base: the path of the base scenario TOML (relative to the optimisation file)")
        base, _ = load_scenario(base_dir / data["base"])
    else:
        if not isinstance(data["scenario"], dict):
            raise _err(source, "scenario: an inline scenario table ([scenario], [scenario.chain], ...)")
        base = parse_scenario(data["scenario"], source=f"{source}: scenario")
    keys = scenario_keys(base)
    realizations = _int_in(source, data, "realizations", base.simulation.realizations, 1, 100_000)
    seed = _int_in(source, data, "seed", base.seed, 0, 2**63 - 1)
    trials = _int_in(source, data, "trials", 32, 1, MAX_TRIALS)
    batch = _int_in(source, data, "batch", 8, 1, 4096)
    sampler_seed = _int_in(source, data, "sampler_seed", 0, 0, 2**32 - 1)
    validation_seed = _int_in(source, data, "validation_seed", seed + 1_000_003, 0, 2**63 - 1)
    if validation_seed == seed:
        raise _err(source, "validation_seed: must differ from seed (the validation run uses fresh random streams)")
    validation_realizations = _int_in(source, data, "validation_realizations", realizations, 1, 100_000)
    tables = {}
    for name in ("overrides", "baseline"):
        table = data.get(name, {})
        if not isinstance(table, dict):
            raise _err(source, f"{name}: a table of dotted scenario keys")
        for k in table:
            if k not in keys:
                raise _err(source, f"{name}: '{k}' is not a scenario key (see `nodesim run BASE --dry-run`)")
        tables[name] = table
    try:
        fixed = base.with_overrides(**tables["overrides"], seed=seed, **{"simulation.realizations": realizations})
    except ScenarioError as err:
        raise _err(source, f"overrides: {str(err).replace('<overrides>: ', '')}") from None
    vars_raw = data.get("variable", [])
    if not isinstance(vars_raw, list) or not vars_raw:
        raise _err(source, "variable: at least one [[variable]] table (key and choices or low/high)")
    variables: dict[str, Variable] = {}
    for i, raw in enumerate(vars_raw):
        v = _variable(source, i, raw, keys, variables)
        if v.key in variables or v.key in tables["overrides"]:
            raise _err(source, f"variable[{i}].key: '{v.key}' is given twice (variables and overrides)")
        for value in (v.choices if v.kind == "categorical" else (v.low, v.high)):
            value = int(value) if v.kind == "int" else value
            try:
                fixed.with_overrides(**{v.key: value})
            except ScenarioError as err:
                raise _err(source, f"{where_of(i, v.key)}: the scenario rejects {value!r}: "
                                   f"{str(err).replace('<overrides>: ', '')}") from None
        variables[v.key] = v
    objectives = []
    for i, r in enumerate(_bounded_keys(source, "objective", data.get("objective", []))):
        if set(r) - {"key", "direction"}:
            raise _err(source, f"objective[{i}]: unknown key(s) {sorted(set(r) - {'key', 'direction'})}")
        direction = r.get("direction", "minimize")
        if direction not in ("minimize", "maximize"):
            raise _err(source, f"objective[{i}].direction: 'minimize' or 'maximize' (got {direction!r})")
        if r["key"] in (o.key for o in objectives):
            raise _err(source, f"objective[{i}].key: '{r['key']}' is given twice")
        objectives.append(Objective(r["key"], direction))
    if not objectives:
        raise _err(source, "objective: at least one [[objective]] table, e.g. key = 'radio_energy_j'")
    constraints = []
    for i, r in enumerate(_bounded_keys(source, "constraint", data.get("constraint", []))):
        if set(r) - {"key", "min", "max"}:
            raise _err(source, f"constraint[{i}]: unknown key(s) {sorted(set(r) - {'key', 'min', 'max'})}")
        lo, hi = r.get("min"), r.get("max")
        if lo is None and hi is None:
            raise _err(source, f"constraint[{i}] ({r['key']}): give max and/or min")
        if any(x is not None and not _number(x) for x in (lo, hi)):
            raise _err(source, f"constraint[{i}] ({r['key']}): min and max must be numbers")
        if lo is not None and hi is not None and lo > hi:
            raise _err(source, f"constraint[{i}] ({r['key']}): empty range, min {lo} > max {hi}")
        constraints.append(Constraint(r["key"], None if hi is None else float(hi), None if lo is None else float(lo)))
    sampler = data.get("sampler", "nsga2" if len(objectives) > 1 else "tpe")
    if sampler not in SAMPLERS:
        raise _err(source, f"sampler: one of {list(SAMPLERS)} (got {sampler!r})")
    recommend = data.get("recommend", objectives[0].key)
    if recommend not in (o.key for o in objectives):
        raise _err(source, f"recommend: '{recommend}' is not an objective key ({[o.key for o in objectives]})")
    record = data.get("record", [])
    if not isinstance(record, list) or not all(isinstance(k, str) and k for k in record):
        raise _err(source, "record: a list of summary keys")
    described = {k: data.get(k) for k in sorted(TOP_KEYS - {"base", "scenario", "trials"})}
    spec_hash = hashlib.sha256(dumps_json({"optimize": described, "base": fixed.model_dump()})).hexdigest()
    return Problem(
        name=str(data.get("name", Path(source).stem)), description=str(data.get("description", "")), source=source,
        base=fixed, realizations=realizations, seed=seed, trials=trials, batch=batch, sampler=sampler,
        sampler_seed=sampler_seed, recommend=recommend, validation_seed=validation_seed,
        validation_realizations=validation_realizations, record=tuple(record),
        overrides=tuple(tables["overrides"].items()), baseline=tuple(tables["baseline"].items()),
        variables=tuple(variables.values()), objectives=tuple(objectives), constraints=tuple(constraints),
        spec_hash=spec_hash,
    )


def load_problem(path: str | Path) -> Problem:
    """Read and validate an optimisation TOML file."""
    path = Path(path)
    return parse_problem(read_toml_file(path, "optimisation"), str(path), path.parent)


def read_problem(opt: "str | Path | dict | Problem", base_dir: Path | None = None) -> Problem:
    """A :class:`Problem` from a path, a parsed dict (paths relative to ``base_dir``, default cwd) or itself."""
    if isinstance(opt, Problem):
        return opt
    if isinstance(opt, dict):
        return parse_problem(opt, "<optimize>", Path(base_dir or "."))
    return load_problem(opt)


def read_problem_description(manifest: dict) -> Problem:
    """The :class:`Problem` a study manifest describes (variables, objectives, constraints; base scenario)."""
    opt = manifest["optimize"]
    variables = tuple(
        Variable(v["key"], tuple(v["choices"]) if v["type"] == "categorical" else None, v.get("low"), v.get("high"),
                 v.get("step"), v.get("log", False), v["type"], tuple((v.get("when") or {}).items()))
        for v in opt["variables"]
    )
    return Problem(
        name=opt["name"], description=opt["description"], source=opt["source"],
        base=parse_scenario(manifest["base_scenario"], source=opt["source"]), realizations=opt["realizations"],
        seed=opt["seed"], trials=opt["trials"], batch=opt["batch"], sampler=opt["sampler"],
        sampler_seed=opt["sampler_seed"], recommend=opt["recommend"], validation_seed=opt["validation_seed"],
        validation_realizations=opt["validation_realizations"], record=tuple(opt["record"]),
        overrides=tuple(opt["overrides"].items()), baseline=tuple(opt["baseline"].items()), variables=variables,
        objectives=tuple(Objective(o["key"], o["direction"]) for o in opt["objectives"]),
        constraints=tuple(Constraint(c["key"], c["max"], c["min"]) for c in opt["constraints"]),
        spec_hash=opt["spec_sha256"],
    )
