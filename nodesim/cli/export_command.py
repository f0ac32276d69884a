"""``nodesim export``: a run's survey (or a survey CSV) for welleng, as LAS 2.0, or as CSV, in m or ft."""

from __future__ import annotations

from pathlib import Path


def register(sub) -> None:
    p = sub.add_parser(
        "export",
        help="export a survey with its wellpath and uncertainty to welleng, LAS 2.0 or CSV",
        description=(
            "Write the survey a drilling run's ground station received (RUN_DIR/ground_survey.csv) or a survey "
            "CSV with the minimum-curvature wellpath and, per station, the 1- and 2-sigma ISCWSA semi-axes for "
            "a tool model: --to welleng (md,inc,azi CSV for welleng.survey.Survey), las (LAS 2.0, lasio), csv."
        ),
    )
    p.add_argument("source", metavar="RUN_DIR|SURVEY.csv", help="run directory of a drilling run, or a survey CSV")
    p.add_argument("--to", dest="fmt", choices=("welleng", "las", "csv"), required=True, help="output format")
    p.add_argument("--units", choices=("m", "ft"), default="m", help="length unit of the file (default m)")
    p.add_argument("--tool", default="mpu6500_filtered", help="ISCWSA tool model of the uncertainty curves (default mpu6500_filtered)")
    p.add_argument("--seconds-per-station", type=float, default=60.0, metavar="S",
                   help="time between stations when the survey has no time_s (default 60)")
    p.add_argument("-o", "--output", required=True, type=Path, metavar="FILE", help="file to write")
    p.set_defaults(func=run)


def run(args) -> int:
    from nodesim.interop import write_export

    out = write_export(args.source, args.fmt, args.output, args.units, args.tool, args.seconds_per_station)
    print(f"wrote {out} ({args.fmt}, {args.units})")
    return 0


__all__ = ["register", "run"]
