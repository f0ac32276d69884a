"""Reading the small user CSV files (calibration positions, surveys): the checks every reader shares.

Blank lines and lines starting with ``#`` are skipped; the first remaining line is the header.  Errors are
:class:`nodesim.errors.NodesimError` naming the file and what is wrong; each reader checks its own rows.
"line N" in every message is the file's line N (1-based, counting blank and comment lines), the number a
text editor shows.
"""

from __future__ import annotations

import csv
from pathlib import Path

from nodesim.errors import NodesimError


def read_table(
    path: Path, required: tuple[str, ...], what: str, optional: tuple[str, ...] | None = None
) -> tuple[list[str], list[list[str]], list[int]]:
    """(header, data rows, file line number of each data row) of a CSV whose header holds ``required``.

    With ``optional`` given, a column that is neither required nor optional is rejected (a misspelt
    ``sigma_azi_deg`` would otherwise be ignored silently).
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as err:
        raise NodesimError(f"{path}: cannot read {what} ({getattr(err, 'strerror', None) or err})") from None
    numbered = [(n, line) for n, line in enumerate(text.splitlines(), start=1)
                if line.strip() and not line.lstrip().startswith("#")]
    if not numbered:
        raise NodesimError(f"{path}: empty {what} file (expected a header {','.join(required)})")
    rows = [next(csv.reader([line])) for _, line in numbered]
    header = [h.strip() for h in rows[0]]
    missing = [c for c in required if c not in header]
    if missing:
        raise NodesimError(f"{path}, line {numbered[0][0]}: missing column(s) {missing}; header must contain {list(required)}")
    if optional is not None:
        unknown = [c for c in header if c not in required and c not in optional]
        if unknown:
            raise NodesimError(f"{path}, line {numbered[0][0]}: unknown column(s) {unknown}; "
                               f"allowed {list(required) + list(optional)}")
    dupes = sorted({c for c in header if header.count(c) > 1})
    if dupes:
        raise NodesimError(f"{path}, line {numbered[0][0]}: column(s) {dupes} appear more than once")
    return header, rows[1:], [n for n, _ in numbered[1:]]


def read_header_and_rows(path: Path, required: tuple[str, ...], what: str) -> tuple[list[str], list[list[str]]]:
    """(header, data rows) of :func:`read_table`, without line numbers."""
    header, rows, _ = read_table(path, required, what)
    return header, rows
