"""``nodesim sweep``: parameter sweeps and Monte Carlo campaigns on a local pool or a Dask cluster."""

from __future__ import annotations

import sys
from pathlib import Path

from nodesim.io.rundir import dumps_json


def register(sub) -> None:
    p = sub.add_parser(
        "sweep",
        help="parameter sweeps and Monte Carlo campaigns (local pool or Dask)",
        description=(
            "Run every (point, seed) of a sweep file and store one row per run in DIR/results.parquet "
            "(load it with pandas.read_parquet). Same sweep and seeds give the same table on any executor. "
            "Exit status 1 when any run failed (the table is still written), 2 on a usage error."
        ),
    )
    p.add_argument("sweep", type=Path, metavar="SWEEP.toml", help="base scenario plus axes")
    p.add_argument("--out", type=Path, default=None, help="campaign directory (default runs/<sweep name>-<UTC timestamp>)")
    p.add_argument("--executor", choices=["local", "dask"], default="local", help="where the runs execute (default local)")
    p.add_argument("--scheduler", metavar="ADDR", help="address of an existing Dask scheduler (e.g. tcp://host:8786)")
    p.add_argument("--workers", type=int, default=None, help="local pool size, or LocalCluster workers (default: CPUs)")
    p.add_argument("--resume", action="store_true", help="continue a campaign in --out: skip the runs already ok")
    p.add_argument("--dry-run", action="store_true", help="validate the sweep and print the planned runs; run nothing")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--json", action="store_true", help="print the campaign summary as JSON on stdout")
    p.set_defaults(func=run)


def run(args) -> int:
    from nodesim.errors import NodesimError
    from nodesim.io.rundir import default_run_dir
    from nodesim.sweep.campaign import run_campaign
    from nodesim.sweep.executors import make_executor
    from nodesim.sweep.spec import load_sweep

    spec = load_sweep(args.sweep)
    if args.dry_run:
        tasks = spec.plan()
        plan = {
            "sweep": spec.describe(),
            "points": len(spec.points()),
            "runs": len(tasks),
            "invalid_points": sorted({t.point for t in tasks if t.invalid}),
        }
        sys.stdout.write(dumps_json(plan).decode())
        return 0
    if args.resume and args.out is None:
        raise NodesimError("--resume needs --out DIR (the campaign to continue)")
    out = args.out if args.out is not None else default_run_dir(spec.name)
    with make_executor(args.executor, args.workers, args.scheduler) as executor:
        result = run_campaign(spec, out, executor, resume=args.resume, quiet=args.quiet or args.json)
    summary = result.summary()
    if args.json:
        sys.stdout.write(dumps_json(summary).decode())
    else:
        for key, value in summary.items():
            print(f"{key:<22} {value}")
        print(f"load it with: pandas.read_parquet('{summary['results']}')")
    if result.failed:
        sys.stderr.write(f"nodesim sweep: {result.failed} of {result.planned} runs failed (status and error columns "
                         f"of {summary['results']})\n")
        return 1
    return 0


__all__ = ["register", "run"]
