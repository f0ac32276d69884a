"""``nodesim validate``: every check against a published figure."""

from __future__ import annotations

import sys

from nodesim.io.rundir import dumps_json


def register(sub) -> None:
    p = sub.add_parser(
        "validate",
        help="compare our figures with the published ones",
        description="Run every check against a published figure: name, source, ours, published, tolerance, ok.",
    )
    p.add_argument("--json", action="store_true", help="print a JSON list of checks on stdout")
    p.set_defaults(func=run)


def run(args) -> int:
    from nodesim.validation import run_checks

    checks = run_checks()
    if args.json:
        sys.stdout.write(dumps_json([c.as_dict() for c in checks]).decode())
        return 0
    print(format_table(checks))
    n_ok = sum(c.ok for c in checks)
    print(f"{n_ok} of {len(checks)} checks within tolerance")
    return 0


def format_table(checks) -> str:
    header = ("ok", "name", "ours", "published", "tolerance", "source")
    rows = [("yes" if c.ok else "NO", c.name, f"{c.ours:.4g}", f"{c.published:.4g}", c.tolerance, c.source) for c in checks]
    widths = [max(len(str(r[i])) for r in [header, *rows]) for i in range(len(header))]
    lines = ["  ".join(str(v).ljust(w) for v, w in zip(row, widths)).rstrip() for row in [header, *rows]]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)
