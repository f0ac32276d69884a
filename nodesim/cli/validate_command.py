"""``nodesim validate``: every check against a published figure, with its kind and a count per kind.

Exit status: 0 whatever the checks say (the failing rows are part of the record), unless ``--strict``: then 1
when any row is not within its tolerance.
"""

from __future__ import annotations

import math
import sys

from nodesim.io.rundir import dumps_json


def register(sub) -> None:
    p = sub.add_parser(
        "validate",
        help="compare our figures with the published ones",
        description="Run every check against a published figure: ok, kind (reproduction | self_consistency | "
        "hypothesis), name, ours, published, band (distribution rows: our 5-95 % band and the percentile of the "
        "published value), tolerance, source; then ok / total per kind.",
    )
    p.add_argument("--json", action="store_true", help="print a JSON list of checks on stdout (each with its kind)")
    p.add_argument("--strict", action="store_true",
                   help="exit 1 when any check is not within tolerance (without it the exit status is 0)")
    p.set_defaults(func=run)


def run(args) -> int:
    from nodesim.validation import run_checks

    checks = run_checks()
    if args.json:
        sys.stdout.write(dumps_json([c.as_dict() for c in checks]).decode())
    else:
        print(format_table(checks))
        print(format_summary(checks))
    return 1 if args.strict and not all(c.ok for c in checks) else 0


def _number(value: float) -> str:
    """Four significant digits; "-" where there is no figure (e.g. no published value for a self-consistency row)."""
    return f"{value:.4g}" if value is not None and math.isfinite(value) else "-"


def _band(c) -> str:
    """A distribution row's 5-95 % band of our runs and the percentile of the published value among them; "-"."""
    if getattr(c, "band_p5", None) is None:
        return "-"
    return f"[{_number(c.band_p5)}, {_number(c.band_p95)}] at {c.published_percentile:.0f}%"


def format_table(checks) -> str:
    """One line per check: ok, kind, name, ours, published, our band (distribution rows: 5-95 % of our runs and the
    published value's percentile; "-" otherwise), tolerance, source (columns padded)."""
    header = ("ok", "kind", "name", "ours", "published", "band 5-95%", "tolerance", "source")
    rows = [("yes" if c.ok else "NO", c.kind, c.name, _number(c.ours), _number(c.published), _band(c), c.tolerance,
             c.source) for c in checks]
    widths = [max(len(str(r[i])) for r in [header, *rows]) for i in range(len(header))]
    lines = ["  ".join(str(v).ljust(w) for v, w in zip(row, widths)).rstrip() for row in [header, *rows]]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


def format_summary(checks) -> str:
    """One line per kind ("reproduction: 120 of 180 ok") and the total."""
    from nodesim.validation import counts_by_kind

    lines = [f"{kind}: {ok} of {total} ok" for kind, (ok, total) in counts_by_kind(checks).items()]
    lines.append(f"{sum(c.ok for c in checks)} of {len(checks)} checks within tolerance")
    return "\n".join(lines)
