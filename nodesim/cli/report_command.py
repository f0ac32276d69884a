"""``nodesim report``: a self-contained HTML page (embedded PNG plots) of a run or a campaign directory."""

from __future__ import annotations

import sys
from pathlib import Path

from nodesim.io.rundir import dumps_json


def register(sub) -> None:
    p = sub.add_parser(
        "report",
        help="self-contained HTML report of a run or campaign",
        description=(
            "Write DIR/report.html: for a run, headline metrics, yaw error and bias estimate per node, survey "
            "stations with uncertainty ellipses, link margins; for a campaign, each metric against each swept "
            "axis with percentile bands and a table of the best points under a constraint."
        ),
    )
    p.add_argument("directory", type=Path, metavar="RUN_OR_CAMPAIGN_DIR", help="a run or campaign directory")
    p.add_argument("--out", type=Path, default=None, help="HTML file to write (default DIR/report.html)")
    p.add_argument("--where", default=None, metavar="EXPR",
                   help="campaign: keep points whose per-seed means satisfy EXPR, e.g. 'rms_azimuth_error_deg < 0.25'")
    p.add_argument("--minimize", default=None, metavar="METRIC", help="campaign: order the best points by METRIC, lowest first")
    p.add_argument("--maximize", default=None, metavar="METRIC", help="campaign: order the best points by METRIC, highest first")
    p.add_argument("--top", type=int, default=10, help="campaign: rows in the best-points table (default 10)")
    p.add_argument("--tool", default="mpu6500", help="run: tool model for the survey uncertainty ellipses (default mpu6500)")
    p.add_argument("--json", action="store_true", help="print {report, kind, images, ...} as JSON on stdout")
    p.set_defaults(func=run)


def run(args) -> int:
    from nodesim.errors import NodesimError
    from nodesim.report import write_report

    if args.top < 1:
        raise NodesimError(f"--top must be >= 1 (got {args.top})")
    info = write_report(
        args.directory, args.out, where=args.where, minimize=args.minimize, maximize=args.maximize, top=args.top,
        tool=args.tool,
    )
    if args.json:
        sys.stdout.write(dumps_json(info).decode())
    else:
        print(f"{info['kind']} report: {info['report']} ({info['images']} plots)")
    return 0


__all__ = ["register", "run"]
