"""What a study yields: the trial and Pareto tables, the recommended schedule, its validation, sensitivities.

Files written into the study directory by :func:`finish`:

- ``trials.parquet``: one row per trial: ``trial``, ``state`` (COMPLETE, FAIL, RUNNING), one column per
  decision variable (dotted key; null where a conditional variable was inactive), one float column per kept
  summary key (objectives, constraints, ``record``), ``violation:<key>`` per constraint (v = max(value - max,
  min - value), +inf when the value is undefined), ``feasible`` (complete and every v <= 0), ``reused_from``
  (the earlier trial with the same decision values whose run result was reused: no new evaluation), ``status``,
  ``error``, ``wall_s``, ``worker`` (the run's; timing and placement, outside the determinism guarantee);
- ``pareto.parquet``: the feasible, non-dominated trials, each point once (objectives of all feasible complete trials, each
  turned into a minimisation by its sign), sorted by the first objective;
- ``recommendation.json``: the recommended trial (feasible, best ``recommend`` objective; ties by the other
  objectives, then the trial number), its ready-to-paste TOML, its validation run with a fresh seed, the
  baseline run and the saving against it; or, when no trial is feasible, the closest trials.

Sensitivity (:func:`sensitivity`): for a numeric variable, Spearman's rank correlation rho between its value
and the metric over the complete trials where it is active; for a categorical one, the correlation ratio
eta^2 = sum_g n_g (mean_g - mean)^2 / sum_i (y_i - mean)^2 (share of the metric's variance explained by the
choice).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from nodesim.errors import NodesimError
from nodesim.io.rundir import write_json, write_parquet
from nodesim.optimization.problem import Problem

TRIALS = "trials.parquet"
PARETO = "pareto.parquet"
RECOMMENDATION = "recommendation.json"
TIMING_COLUMNS = ["wall_s", "worker"]
SCHEDULE_KEYS = {"continuous": ("mode",), "windowed": ("mode", "update_s", "timeout_s"),
                 "single": ("mode", "single_rate_hz"), "arbitrary": ("mode", "windows"), "none": ("mode",)}


def trials_frame(study, problem: Problem) -> pd.DataFrame:
    """Every trial of ``study`` as one row (module docstring), sorted by trial number."""
    rows = []
    for t in sorted(study.get_trials(deepcopy=False), key=lambda t: t.number):
        attrs = t.user_attrs
        metrics = attrs.get("metrics") or {}
        run = attrs.get("run") or {}
        row = {"trial": t.number, "state": t.state.name}
        row.update({v.key: t.params.get(v.key) for v in problem.variables})
        row.update({k: (math.nan if metrics.get(k) is None else float(metrics[k])) for k in problem.metric_keys()})
        viol = attrs.get("violations")
        for i, c in enumerate(problem.constraints):
            # not told yet (RUNNING): unknown (NaN); told with an undefined value: +inf
            row[f"violation:{c.key}"] = math.nan if viol is None else (math.inf if viol[i] is None else float(viol[i]))
        row["feasible"] = bool(t.state.name == "COMPLETE" and all(row[f"violation:{c.key}"] <= 0 for c in problem.constraints))
        row["reused_from"] = attrs.get("reused_from")
        row.update(status=run.get("status"), error=run.get("error"), wall_s=float(run.get("wall_s", math.nan)),
                   worker=run.get("worker"))
        rows.append(row)
    columns = (["trial", "state"] + problem.variable_keys() + list(problem.metric_keys())
               + [f"violation:{c.key}" for c in problem.constraints]
               + ["feasible", "reused_from", "status", "error", "wall_s", "worker"])
    df = pd.DataFrame(rows, columns=columns)
    df["trial"] = df["trial"].astype("int64")
    for k in problem.metric_keys():
        df[k] = df[k].astype("float64")
    for c in ("status", "error", "worker"):
        df[c] = df[c].astype("string")
    df["feasible"] = df["feasible"].astype(bool)
    df["reused_from"] = df["reused_from"].astype("Int64")
    for v in problem.variables:
        if v.kind != "categorical":
            df[v.key] = pd.to_numeric(df[v.key]).astype("float64" if v.kind == "float" else "Int64")
    return df.reset_index(drop=True)


def _minimised(df: pd.DataFrame, problem: Problem) -> np.ndarray:
    return np.column_stack([o.sign() * df[o.key].to_numpy(float) for o in problem.objectives])


def pareto_frame(trials: pd.DataFrame, problem: Problem) -> pd.DataFrame:
    """Feasible trials that no other feasible trial dominates (<= in every objective, < in one)."""
    feas = trials[trials["feasible"] & trials["reused_from"].isna()].reset_index(drop=True)  # no repeated points
    if not len(feas):
        return feas
    f = _minimised(feas, problem)
    keep = [not np.any(np.all(f <= f[i], axis=1) & np.any(f < f[i], axis=1)) for i in range(len(f))]
    front = feas[np.array(keep)]
    first = problem.objectives[0]
    return front.sort_values([first.key, "trial"], ascending=[first.direction == "minimize", True]).reset_index(drop=True)


def ranked(trials: pd.DataFrame, problem: Problem, key: str) -> pd.DataFrame:
    """Feasible trials, best first by objective ``key``, then the other objectives, then the trial number."""
    feas = trials[trials["feasible"]]
    order = [key] + [o.key for o in problem.objectives if o.key != key]
    signs = {o.key: o.sign() for o in problem.objectives}
    score = pd.DataFrame({k: signs[k] * feas[k] for k in order})
    score["trial"] = feas["trial"]
    return feas.loc[score.sort_values(order + ["trial"], kind="stable").index]


def closest_trials(trials: pd.DataFrame, problem: Problem, n: int = 5) -> pd.DataFrame:
    """Complete trials with the smallest total constraint violation sum(max(v_i, 0)) (infeasible studies)."""
    done = trials[trials["state"] == "COMPLETE"].copy()
    cols = [f"violation:{c.key}" for c in problem.constraints]
    done["total_violation"] = done[cols].clip(lower=0).sum(axis=1) if cols else 0.0
    return done.sort_values(["total_violation", "trial"], kind="stable").head(n)


def sensitivity(trials: pd.DataFrame, problem: Problem) -> pd.DataFrame:
    """One row per (metric, variable): ``measure`` ('spearman_rho' or 'eta_squared'), ``value``, ``trials``."""
    from scipy.stats import spearmanr

    done = trials[trials["state"] == "COMPLETE"]
    rows = []
    for metric in dict.fromkeys([o.key for o in problem.objectives] + [c.key for c in problem.constraints]):
        for v in problem.variables:
            sub = done[done[v.key].notna() & np.isfinite(done[metric].to_numpy(float))]
            y = sub[metric].to_numpy(float)
            value = math.nan
            if v.kind == "categorical":
                measure = "eta_squared"
                total = float(((y - y.mean()) ** 2).sum()) if len(y) else 0.0
                if len(y) > 1 and total > 0:
                    groups = sub.groupby(sub[v.key].astype(str))[metric]
                    value = float(sum(len(g) * (g.mean() - y.mean()) ** 2 for _, g in groups) / total)
            else:
                measure = "spearman_rho"
                x = sub[v.key].to_numpy(float)
                if len(y) > 2 and np.ptp(x) > 0 and np.ptp(y) > 0:
                    value = float(spearmanr(x, y).statistic)
            rows.append({"metric": metric, "variable": v.key, "measure": measure, "value": value, "trials": len(sub)})
    return pd.DataFrame(rows, columns=["metric", "variable", "measure", "value", "trials"])


def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, float):
        return repr(float(v))
    return json.dumps(v)


def schedule_toml(problem: Problem, params: dict) -> str:
    """Ready-to-paste TOML: the resolved ``[schedule]`` table (keys its mode uses), then the other varied keys
    grouped by table (e.g. ``[mac]`` ``max_retries``)."""
    scenario = problem.base.with_overrides(**params)
    sched = scenario.schedule.model_dump()
    lines = ["[schedule]"] + [f"{k} = {_toml_value(sched[k])}" for k in SCHEDULE_KEYS[sched["mode"]]]
    tables: dict[str, list[str]] = {}
    for key, value in params.items():
        table, _, leaf = key.rpartition(".")
        if table == "schedule":
            continue
        tables.setdefault(table, []).append(f"{leaf} = {_toml_value(value)}")
    for table, entries in tables.items():
        lines += ["", f"[{table}]" if table else ""] + entries
    return "\n".join(lines).strip() + "\n"


def _params(row: pd.Series, problem: Problem) -> dict:
    out = {}
    for v in problem.variables:
        value = row[v.key]
        if value is None or (not isinstance(value, str) and pd.isna(value)):
            continue
        out[v.key] = int(value) if v.kind == "int" else (float(value) if v.kind == "float" else value)
    return out


def _check(problem: Problem, metrics: dict) -> dict:
    viol = {c.key: c.violation(metrics.get(c.key, math.nan)) for c in problem.constraints}
    return {"metrics": metrics, "violations": {k: (None if math.isinf(v) else v) for k, v in viol.items()},
            "feasible": all(v <= 0 for v in viol.values())}


def validate(problem: Problem, params: dict, executor, run_fn, payload: dict | None = None) -> dict:
    """Re-run ``params`` and the baseline with the fresh validation seed (a run outside the search)."""
    tasks = [problem.task(0, params, seed=problem.validation_seed, realizations=problem.validation_realizations,
                          payload=payload)]
    baseline = dict(problem.baseline)
    if baseline:  # the base scenario (fixed overrides applied) with only the baseline's keys changed
        tasks.append(problem.task(1, baseline, seed=problem.validation_seed,
                                  realizations=problem.validation_realizations, payload=payload))
    records = {rec.point: rec for rec in executor.imap(run_fn, tasks)}
    for rec in records.values():
        if rec.status != "ok":
            raise NodesimError(f"validation run failed: {rec.error}")
    out = {"seed": problem.validation_seed, "realizations": problem.validation_realizations,
           "recommended": _check(problem, records[0].metrics)}
    if baseline:
        out["baseline"] = {"overrides": {k: v for k, v in tasks[1].params}, **_check(problem, records[1].metrics)}
        out["saving_vs_baseline"] = {
            o.key: (1.0 - records[0].metrics[o.key] / records[1].metrics[o.key]) if records[1].metrics[o.key] else None
            for o in problem.objectives
        }
    return out


@dataclass
class Study:
    """The result of :func:`nodesim.optimize`: tables as DataFrames, the recommendation and its validation."""

    directory: Path
    problem: Problem
    trials: pd.DataFrame
    pareto: pd.DataFrame
    sensitivity: pd.DataFrame
    recommended: dict | None
    validation: dict | None = None
    closest: pd.DataFrame = field(default_factory=pd.DataFrame)

    @property
    def feasible(self) -> bool:
        return self.recommended is not None

    def schedule_toml(self) -> str | None:
        return None if self.recommended is None else self.recommended["toml"]

    def summary(self) -> dict:
        return {
            "study": str(self.directory), "trials": int(len(self.trials)),
            "evaluations": int((self.trials["state"].isin(["COMPLETE", "FAIL"]) & self.trials["reused_from"].isna()).sum()),
            "complete": int((self.trials["state"] == "COMPLETE").sum()),
            "failed": int((self.trials["state"] == "FAIL").sum()),
            "feasible": int(self.trials["feasible"].sum()), "pareto": int(len(self.pareto)),
            "recommended": self.recommended, "validation": self.validation,
            "closest_infeasible": None if self.feasible else self.closest[["trial"] + list(self.problem.metric_keys())].to_dict("records"),
        }


def finish(problem: Problem, directory: Path, executor=None, run_fn=None, validate_run: bool = True,
           payload: dict | None = None) -> Study:
    """Build and write the tables and the recommendation of the study in ``directory``."""
    from nodesim.optimization.search import open_study

    directory = Path(directory)
    study = open_study(problem, directory, create=False)
    trials = trials_frame(study, problem)
    pareto = pareto_frame(trials, problem)
    write_parquet(directory / TRIALS, trials)
    write_parquet(directory / PARETO, pareto)
    best = ranked(trials, problem, problem.recommend)
    recommended = None
    validation = None
    if len(best):
        row = best.iloc[0]
        params = _params(row, problem)
        recommended = {"trial": int(row["trial"]), "params": params, "toml": schedule_toml(problem, params),
                       "objectives": {o.key: float(row[o.key]) for o in problem.objectives},
                       "constraints": {c.key: float(row[c.key]) for c in problem.constraints}}
        if validate_run and executor is not None:
            validation = validate(problem, params, executor, run_fn, payload)
    closest = closest_trials(trials, problem)
    result = Study(directory, problem, trials, pareto, sensitivity(trials, problem), recommended, validation, closest)
    write_json(directory / RECOMMENDATION, result.summary())
    return result


def load_study(directory: str | Path) -> dict:
    """The stored tables of a study directory: {'trials', 'pareto'} DataFrames and the recommendation dict."""
    d = Path(directory)
    if not (d / TRIALS).exists():
        raise NodesimError(f"{d}: no {TRIALS} (not a finished optimisation directory)")
    rec = json.loads((d / RECOMMENDATION).read_text()) if (d / RECOMMENDATION).exists() else {}
    return {"trials": pd.read_parquet(d / TRIALS), "pareto": pd.read_parquet(d / PARETO), "recommendation": rec}
