"""Regenerate the validation tables of docs/validation.md and README.md from a real ``nodesim validate`` run.

    nodesim validate --json > runs/validation.json
    python scripts/validation_table.py runs/validation.json          # both steps: make validation-docs

Between the marker lines ``<!-- validation-counts:start -->`` / ``<!-- validation-counts:end -->`` (README and
docs) it writes ok / total per kind; between ``<!-- validation-table:start -->`` / ``<!-- validation-table:end -->``
(docs) every row, grouped by kind, with its note for the rows that are not reproductions (the note says why); a
kind with distribution rows (``band_p5`` set: the lab's published runs against our runs) gets two more columns, our
5-95 % band and the percentile of the published value.  Between ``<!-- validation-bands:start -->`` /
``<!-- validation-bands:end -->`` (docs, optional) the distribution rows alone: median, band, percentile, inside.
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
COUNTS, TABLE, BANDS = "validation-counts", "validation-table", "validation-bands"


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


def _has_band(row: dict) -> bool:
    return row.get("band_p5") is not None


def band_cell(row: dict) -> str:
    """Our 5-95 % band as "[p5, p95]" ("-" for a row without one)."""
    return f"[{_cell(row['band_p5'])}, {_cell(row['band_p95'])}]" if _has_band(row) else "-"


def percentile_cell(row: dict) -> str:
    """Where the published value falls among our runs ("-" for a row without a band)."""
    return f"{row['published_percentile']:.1f} %" if _has_band(row) else "-"


def table_block(rows: list[dict]) -> str:
    """One section per kind (heading with ok / total), one table row per check, in ``nodesim validate`` order; a
    kind with distribution rows shows our 5-95 % band and the published value's percentile too."""
    out = []
    for kind, (ok, total) in counts(rows).items():
        with_note = kind != "reproduction"
        with_band = any(_has_band(r) for r in rows if r["kind"] == kind)
        head = (["ok", "check", "ours", "published"] + (["our 5-95 %", "published at"] if with_band else []) +
                ["tolerance", "source"] + (["note"] if with_note else []))
        out += [f"### {kind}: {ok} of {total} ok", "", "| " + " | ".join(head) + " |", "|---" * len(head) + "|"]
        for r in (r for r in rows if r["kind"] == kind):
            cells = [_cell("yes" if r["ok"] else "no"), _cell(r["name"]), _cell(r["ours"]), _cell(r["published"])]
            cells += [band_cell(r), percentile_cell(r)] if with_band else []
            cells += [_cell(r["tolerance"]), _cell(r["source"])] + ([_cell(r["note"])] if with_note else [])
            out.append("| " + " | ".join(cells) + " |")
        out.append("")
    return "\n".join(out).rstrip("\n")


def bands_block(rows: list[dict]) -> str:
    """The distribution rows alone: published, our median, 5 %, 95 %, the published value's percentile, inside."""
    lines = ["| check | published | our median | our 5 % | our 95 % | published at | inside |",
             "|---|---|---|---|---|---|---|"]
    for r in (r for r in rows if _has_band(r)):
        lines.append("| " + " | ".join([_cell(r["name"]), _cell(r["published"]), _cell(r["ours"]), _cell(r["band_p5"]),
                                        _cell(r["band_p95"]), percentile_cell(r), "yes" if r["ok"] else "no"]) + " |")
    inside, n = sum(r["ok"] for r in rows if _has_band(r)), sum(map(_has_band, rows))
    if n:
        lines += ["", f"{inside} of {n} published values inside our 5-95 % band ({100 * inside / n:.0f} %)."]
    return "\n".join(lines)


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
    text = replace_block(replace_block(docs.read_text(), COUNTS, counts_block(rows)), TABLE, table_block(rows))
    if f"<!-- {BANDS}:start -->" in text:
        text = replace_block(text, BANDS, bands_block(rows))
    docs.write_text(text)
    readme.write_text(replace_block(readme.read_text(), COUNTS, counts_block(rows)))
    print(f"{docs} and {readme}: {len(rows)} rows, " +
          ", ".join(f"{k} {ok}/{total}" for k, (ok, total) in counts(rows).items()))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
