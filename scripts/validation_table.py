"""Regenerate the validation tables of docs/validation.md and README.md from a real ``nodesim validate`` run.

    nodesim validate --json > runs/validation.json
    python scripts/validation_table.py runs/validation.json          # both steps: make validation-docs

Between the marker lines ``<!-- validation-counts:start -->`` / ``<!-- validation-counts:end -->`` (README and
docs) it writes ok / total per kind; between ``<!-- validation-table:start -->`` / ``<!-- validation-table:end -->``
(docs) every row, grouped by kind, with its note for the rows that are not reproductions (the note says why).
Everything outside the markers is left as it is.  Do not edit the generated blocks by hand.
"""

from __future__ import annotations

import argparse
import json
import math
import re
from pathlib import Path

from nodesim.validation import KINDS

REPO = Path(__file__).resolve().parents[1]
MEANING = {
    "reproduction": "our model, run independently, against a published figure",
    "self_consistency": "a published value fed in and read back, or our own figures against each other",
    "hypothesis": "a published figure matched only under an assumption the source does not state (the note says which)",
}
if tuple(MEANING) != KINDS:
    raise RuntimeError(f"MEANING must describe every kind of nodesim.validation.KINDS {KINDS}, in order")
COUNTS, TABLE = "validation-counts", "validation-table"


def _cell(value) -> str:
    """A markdown table cell: numbers to four significant digits, "-" for no figure, pipes escaped."""
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "-"
    if isinstance(value, float):
        return f"{value:.4g}"
    return str(value).replace("|", "\\|")


def counts(rows: list[dict]) -> dict[str, tuple[int, int]]:
    """(ok, total) per kind, in the order of ``KINDS``."""
    return {k: (sum(r["ok"] for r in rows if r["kind"] == k), sum(r["kind"] == k for r in rows)) for k in KINDS}


def counts_block(rows: list[dict]) -> str:
    """Markdown table: kind, ok, total, what the kind means; and a line for all rows."""
    lines = ["| kind | ok | total | what the row compares |", "|---|---|---|---|"]
    lines += [f"| {k} | {ok} | {total} | {MEANING[k]} |" for k, (ok, total) in counts(rows).items()]
    lines.append(f"| all | {sum(r['ok'] for r in rows)} | {len(rows)} | |")
    return "\n".join(lines)


def table_block(rows: list[dict]) -> str:
    """One section per kind (heading with ok / total), one table row per check, in ``nodesim validate`` order."""
    out = []
    for kind, (ok, total) in counts(rows).items():
        with_note = kind != "reproduction"
        head = ["ok", "check", "ours", "published", "tolerance", "source"] + (["note"] if with_note else [])
        out += [f"### {kind}: {ok} of {total} ok", "", "| " + " | ".join(head) + " |", "|---" * len(head) + "|"]
        for r in (r for r in rows if r["kind"] == kind):
            cells = ["yes" if r["ok"] else "no", r["name"], r["ours"], r["published"], r["tolerance"], r["source"]]
            out.append("| " + " | ".join(_cell(c) for c in cells + ([r["note"]] if with_note else [])) + " |")
        out.append("")
    return "\n".join(out).rstrip("\n")


def replace_block(text: str, marker: str, block: str) -> str:
    """``text`` with the lines between ``<!-- marker:start -->`` and ``<!-- marker:end -->`` replaced by ``block``."""
    pattern = re.compile(rf"(<!-- {marker}:start -->\n).*?(<!-- {marker}:end -->)", re.S)
    if not pattern.search(text):
        raise SystemExit(f"marker <!-- {marker}:start --> ... <!-- {marker}:end --> not found")
    return pattern.sub(lambda m: m.group(1) + block + "\n" + m.group(2), text, count=1)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("json", type=Path, help="output of `nodesim validate --json`")
    parser.add_argument("--repo", type=Path, default=REPO, help="checkout whose README.md and docs/ to rewrite")
    args = parser.parse_args(argv)
    rows = json.loads(args.json.read_text())
    unknown = {r.get("kind") for r in rows} - set(KINDS)
    if unknown:
        raise SystemExit(f"{args.json}: rows of unknown kind {sorted(map(str, unknown))}")
    docs, readme = args.repo / "docs" / "validation.md", args.repo / "README.md"
    text = replace_block(docs.read_text(), COUNTS, counts_block(rows))
    docs.write_text(replace_block(text, TABLE, table_block(rows)))
    readme.write_text(replace_block(readme.read_text(), COUNTS, counts_block(rows)))
    print(f"{docs} and {readme}: {len(rows)} rows, " +
          ", ".join(f"{k} {ok}/{total}" for k, (ok, total) in counts(rows).items()))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
