"""``nodesim bench``: benchmark figures as ratios against baselines measured in the same run."""

from __future__ import annotations

import sys
from pathlib import Path

from nodesim.io.rundir import dumps_json, write_json


def register(sub) -> None:
    p = sub.add_parser(
        "bench",
        help="run the benchmarks",
        description="Run benchmarks/bench_*.py; each figure is a ratio against a baseline timed in the same run.",
    )
    p.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    p.add_argument("--write", type=Path, default=None, help="also write the JSON object to this file")
    p.add_argument("--dir", type=Path, default=None, help="benchmark folder (default ./benchmarks)")
    p.add_argument("--only", default=None, help="run only benchmarks whose name contains this text")
    p.set_defaults(func=run)


def run(args) -> int:
    from nodesim.bench import default_bench_dir, run_benchmarks

    figures = run_benchmarks(args.dir or default_bench_dir(), args.only)
    if args.write is not None:
        write_json(args.write, figures)
    if args.json:
        sys.stdout.write(dumps_json(figures).decode())
    else:
        width = max(len(k) for k in figures)
        for key, value in figures.items():
            shown = f"{value:.4g}" if isinstance(value, float) else str(value)
            print(f"{key:<{width}}  {shown}")
    return 0
