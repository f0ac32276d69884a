"""The report page of an optimisation directory (``nodesim report DIR`` on a ``nodesim optimize`` study).

Sections: the study (problem, counts), the recommended schedule (ready-to-paste TOML, its validation run with
a fresh seed and the baseline), the best feasible trial per objective, the Pareto front plot (every complete
trial of the first two objectives; feasible ones coloured, infeasible grey, the front joined; with one
objective, the objective against the first constraint's value with the feasible band shaded), each metric
against each variable, and the sensitivity table (:func:`nodesim.optimization.outcome.sensitivity`).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from nodesim.errors import NodesimError
from nodesim.optimization.outcome import PARETO, RECOMMENDATION, TRIALS, ranked, sensitivity
from nodesim.optimization.problem import read_problem_description
from nodesim.optimization.search import MANIFEST
from nodesim.report.html import Page


def front_figure(trials: pd.DataFrame, pareto: pd.DataFrame, x: str, y: str, bound: tuple | None = None) -> Figure:
    """Scatter of ``y`` against ``x`` over complete trials: feasible (blue), infeasible (grey), front (line)."""
    fig = Figure(figsize=(6.4, 4.2), layout="constrained")
    ax = fig.add_subplot()
    done = trials[trials["state"] == "COMPLETE"]
    bad, good = done[~done["feasible"]], done[done["feasible"]]
    ax.scatter(bad[x], bad[y], s=14, color="0.6", label=f"infeasible ({len(bad)})")
    ax.scatter(good[x], good[y], s=18, color="tab:blue", label=f"feasible ({len(good)})")
    if len(pareto) and x != y:
        front = pareto.sort_values(x)
        ax.plot(front[x], front[y], "-o", color="tab:red", ms=4, label=f"Pareto front ({len(pareto)})")
    if bound is not None:
        lo, hi = bound
        ymin, ymax = ax.get_ylim()
        ax.axhspan(lo if lo is not None else ymin, hi if hi is not None else ymax, color="tab:green", alpha=0.1,
                   label="feasible region")
        ax.set_ylim(ymin, ymax)
    ax.set_xlabel(x)
    ax.set_ylabel(y)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return fig


def variable_figure(trials: pd.DataFrame, variable: str, metric: str) -> Figure:
    fig = Figure(figsize=(5.2, 3.4), layout="constrained")
    ax = fig.add_subplot()
    done = trials[(trials["state"] == "COMPLETE") & trials[variable].notna()]
    xs = done[variable]
    if not pd.api.types.is_numeric_dtype(xs):
        cats = sorted(xs.astype(str).unique())
        xs = xs.astype(str).map({c: i for i, c in enumerate(cats)})
        ax.set_xticks(range(len(cats)), cats)
    ax.scatter(xs, done[metric], c=np.where(done["feasible"], "tab:blue", "0.6"), s=14)
    ax.set_xlabel(variable)
    ax.set_ylabel(metric)
    ax.grid(alpha=0.3)
    return fig


def optimization_page(directory, **_ignored) -> tuple[Page, dict]:
    """The report page of one study directory."""
    d = Path(directory)
    if not (d / TRIALS).exists():
        raise NodesimError(f"{d}: the study has no {TRIALS} yet (run or resume `nodesim optimize`)")
    manifest = json.loads((d / MANIFEST).read_text())
    problem = read_problem_description(manifest)
    trials, pareto = pd.read_parquet(d / TRIALS), pd.read_parquet(d / PARETO)
    rec = json.loads((d / RECOMMENDATION).read_text()) if (d / RECOMMENDATION).exists() else {}
    opt = manifest["optimize"]
    page = Page(f"nodesim optimisation report: {opt['name']}")
    page.table(["study", "value"], [
        ["directory", str(d)], ["description", opt.get("description", "")], ["status", manifest.get("status")],
        ["trials", len(trials)], ["runs", rec.get("evaluations")], ["feasible", int(trials["feasible"].sum())],
        ["Pareto front", len(pareto)], ["sampler", f"{opt['sampler']} (seed {opt['sampler_seed']}, batch {opt['batch']})"],
        ["realizations per trial", opt["realizations"]], ["root seed (every trial)", opt["seed"]],
        ["objectives", ", ".join(f"{o['direction']} {o['key']}" for o in opt["objectives"])],
        ["constraints", ", ".join(c.text() for c in problem.constraints) or "none"],
        ["executor", str(manifest.get("executor"))], ["git commit", manifest.get("git_commit")],
    ])
    page.heading("Recommended schedule")
    if rec.get("recommended"):
        r = rec["recommended"]
        page.para(f"trial {r['trial']}: " + ", ".join(f"{k} = {v:.4g}" for k, v in r["objectives"].items()))
        page.parts.append(f"<pre>{r['toml']}</pre>")
        val = rec.get("validation")
        if val:
            rows = [["recommended (validation)", val["recommended"]["feasible"]]
                    + [val["recommended"]["metrics"].get(k) for k in problem.metric_keys()]]
            if "baseline" in val:
                rows.append([f"baseline {val['baseline']['overrides']}", val["baseline"]["feasible"]]
                            + [val["baseline"]["metrics"].get(k) for k in problem.metric_keys()])
            page.table(["fresh seed " + str(val["seed"]), "feasible"] + list(problem.metric_keys()), rows)
            for key, saving in (val.get("saving_vs_baseline") or {}).items():
                if saving is not None:
                    page.para(f"{key}: {100 * abs(saving):.1f} % {'less' if saving >= 0 else 'more'} than the baseline")
    else:
        page.para("no trial meets every constraint; the closest trials:", note=True)
        closest = pd.DataFrame(rec.get("closest_infeasible") or [])
        if len(closest):
            page.table(list(closest.columns), closest.values.tolist())
    page.heading("Best feasible trial per objective")
    cols = ["trial"] + problem.variable_keys() + list(problem.metric_keys())
    rows = []
    for o in problem.objectives:
        best = ranked(trials, problem, o.key)
        if len(best):
            rows.append([f"{o.direction} {o.key}"] + [best.iloc[0][c] for c in cols])
    page.table(["best for"] + cols, rows) if rows else page.para("no feasible trial", note=True)
    page.heading("Pareto front")
    keys = [o.key for o in problem.objectives]
    if len(keys) >= 2:
        page.figure(front_figure(trials, pareto, keys[0], keys[1]), f"{keys[1]} vs {keys[0]}, every complete trial")
    if problem.constraints:
        c = problem.constraints[0]
        page.figure(front_figure(trials, pareto, keys[0], c.key, (c.min, c.max)),
                    f"constraint {c.text()} vs {keys[0]} (shaded: feasible region)")
    page.heading("Sensitivity of each objective and constraint to each variable")
    sens = sensitivity(trials, problem)
    page.table(list(sens.columns), sens.values.tolist())
    page.para("spearman_rho: rank correlation of a numeric variable with the metric; eta_squared: share of the "
              "metric's variance explained by a categorical choice (complete trials where the variable is active)",
              note=True)
    for metric in dict.fromkeys(keys + [c.key for c in problem.constraints]):
        for v in problem.variable_keys():
            page.figure(variable_figure(trials, v, metric), f"{metric} vs {v}")
    return page, {"trials": int(len(trials)), "feasible": int(trials["feasible"].sum()), "pareto": int(len(pareto))}
