"""``nodesim optimize``: the cheapest update/timeout schedule that meets an accuracy target, with its Pareto front."""

from __future__ import annotations

import sys
from pathlib import Path

from nodesim.io.rundir import dumps_json


def register(sub) -> None:
    p = sub.add_parser(
        "optimize",
        help="search schedules (Optuna) for the least energy/airtime that meets accuracy constraints",
        description=(
            "Search the decision variables of OPT.toml (schedule mode, update window, timeout, retries, any "
            "scenario key) with Optuna, every trial a batched Monte Carlo run with the same random streams; write "
            "DIR/trials.parquet, DIR/pareto.parquet, DIR/recommendation.json and DIR/report.html, and print the "
            "recommended schedule as a [schedule] TOML table. Exit 1 when no trial meets every constraint."
        ),
    )
    p.add_argument("opt", type=Path, metavar="OPT.toml", help="base scenario, variables, objectives, constraints")
    p.add_argument("--out", type=Path, default=None, help="study directory (default runs/<name>-<UTC timestamp>)")
    p.add_argument("--trials", type=int, default=None, help="trial budget (default: the file's trials)")
    p.add_argument("--executor", choices=["local", "dask"], default="local", help="where the trials run (default local)")
    p.add_argument("--scheduler", metavar="ADDR", help="address of an existing Dask scheduler (e.g. tcp://host:8786)")
    p.add_argument("--workers", type=int, default=None, help="local pool size, or LocalCluster workers (default: CPUs)")
    p.add_argument("--resume", action="store_true", help="continue the study in --out without repeating finished trials")
    p.add_argument("--no-validate", action="store_true", help="skip the fresh-seed validation run of the recommendation")
    p.add_argument("--no-report", action="store_true", help="do not write DIR/report.html")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--json", action="store_true", help="print the study summary as JSON on stdout")
    p.set_defaults(func=run)


def run(args) -> int:
    from nodesim.optimization.driver import optimize
    from nodesim.errors import NodesimError

    if args.resume and args.out is None:
        raise NodesimError("--resume needs --out DIR (the study to continue)")
    study = optimize(args.opt, out=args.out, trials=args.trials, executor=args.executor, scheduler=args.scheduler,
                     workers=args.workers, resume=args.resume, validate=not args.no_validate,
                     report=not args.no_report, quiet=args.quiet or args.json)
    summary = study.summary()
    if args.json:
        sys.stdout.write(dumps_json(summary).decode())
        return 0 if study.feasible else 1
    print(f"study {summary['study']}: {summary['trials']} trials ({summary['evaluations']} runs), "
          f"{summary['feasible']} feasible, {summary['pareto']} on the Pareto front")
    if not study.feasible:
        print("no trial meets every constraint; the closest trials (smallest total violation):")
        print(study.closest.drop(columns=["status", "error", "wall_s", "worker"], errors="ignore").to_string(index=False))
        return 1
    rec = summary["recommended"]
    print(f"recommended (trial {rec['trial']}): " + ", ".join(f"{k} = {v:.4g}" for k, v in rec["objectives"].items()))
    val = summary["validation"]
    if val:
        verdict = "meets" if val["recommended"]["feasible"] else "DOES NOT meet"
        print(f"validation (fresh seed {val['seed']}, {val['realizations']} realizations): {verdict} the constraints: "
              + ", ".join(f"{k} = {v:.4g}" for k, v in val["recommended"]["metrics"].items()))
        for key, saving in (val.get("saving_vs_baseline") or {}).items():
            if saving is not None:
                word = "less" if saving >= 0 else "more"
                print(f"  {key}: {100 * abs(saving):.1f} % {word} than the baseline {val['baseline']['overrides']}")
    print("\n# paste into the scenario:")
    print(study.schedule_toml(), end="")
    return 0


__all__ = ["register", "run"]
