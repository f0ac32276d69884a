"""Reading the small user CSV files (calibration positions, surveys): the checks every reader shares.

Blank lines and lines starting with ``#`` are skipped; the first remaining line is the header.  Errors are
:class:`nodesim.errors.NodesimError` naming the file and what is wrong; each reader checks its own rows.
"""

from __future__ import annotations

import csv
from pathlib import Path

from nodesim.errors import NodesimError


def read_header_and_rows(path: Path, required: tuple[str, ...], what: str) -> tuple[list[str], list[list[str]]]:
    """(header, data rows) of a CSV whose header must contain ``required``; ``what`` names the file's content
    in messages ("survey", "calibration data")."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as err:
        raise NodesimError(f"{path}: cannot read {what} ({getattr(err, 'strerror', None) or err})") from None
    rows = list(csv.reader(line for line in text.splitlines() if line.strip() and not line.lstrip().startswith("#")))
    if not rows:
        raise NodesimError(f"{path}: empty {what} file (expected a header {','.join(required)})")
    header = [h.strip() for h in rows[0]]
    missing = [c for c in required if c not in header]
    if missing:
        raise NodesimError(f"{path}: missing column(s) {missing}; header must contain {list(required)}")
    return header, rows[1:]
