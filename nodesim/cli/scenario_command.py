"""``nodesim scenario``: the scenario keys, as JSON Schema (for editors) or as the Markdown reference."""

from __future__ import annotations

import json
import sys


def register(sub) -> None:
    p = sub.add_parser(
        "scenario",
        help="print the scenario schema (JSON Schema) or the key reference (Markdown)",
        description="Print every scenario key with its type, default, range, unit and meaning.",
    )
    g = p.add_mutually_exclusive_group(required=True)
    g.add_argument("--schema", action="store_true", help="JSON Schema of a scenario (for editors and validators)")
    g.add_argument("--reference", action="store_true", help="Markdown reference (docs/scenario-reference.md)")
    p.set_defaults(func=run)


def run(args) -> int:
    from nodesim.scenario.scenario_reference import json_schema, reference_markdown

    if args.schema:
        sys.stdout.write(json.dumps(json_schema(), indent=2, sort_keys=True) + "\n")
    else:
        sys.stdout.write(reference_markdown())
    return 0


__all__ = ["register", "run"]
