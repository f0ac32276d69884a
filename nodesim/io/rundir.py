"""Run-directory files, every one written atomically, and the facts a manifest records.

A run directory (:meth:`nodesim.api.Run.save`; default ``runs/<scenario-name>-<UTC timestamp>``) holds
``manifest.json`` (package version, git commit, scenario hash, resolved scenario, root seed, wall time,
host), ``summary.json`` (flat headline metrics, :mod:`nodesim.chain.metrics`; timing under "timing"), the
CSV tables of :mod:`nodesim.chain.run_tables` and ``yaw_error.png``.

Atomic writes: each file is written to a temporary file in the same directory and renamed into place, so
an interrupted run never leaves a half-written file under its final name.
"""

from __future__ import annotations

import csv
import io
import json
import os
import platform
import subprocess
import tempfile
from datetime import datetime, timezone
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable

if TYPE_CHECKING:
    import numpy as np


def atomic_write_bytes(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file and ``os.replace``."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def atomic_write_with(path: Path, writer: Callable[[Path], None]) -> None:
    """Let ``writer`` produce a file at a temporary path (e.g. matplotlib savefig), then rename it."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=path.suffix, dir=path.parent)
    os.close(fd)
    try:
        writer(Path(tmp))
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def write_png(path: Path, fig, dpi: int = 110) -> None:
    """Save a matplotlib Figure to ``path`` as PNG at ``dpi``, atomically (:func:`atomic_write_with`)."""
    atomic_write_with(path, lambda p: fig.savefig(p, dpi=dpi, format="png"))


def dumps_json(obj: Any) -> bytes:
    """Deterministic JSON: sorted keys, fixed indentation, NaN/inf turned into null."""
    import numpy as np  # here, not at module top: the CLI parsers import this module and must start fast

    return (json.dumps(_jsonable(obj, np), indent=2, sort_keys=True, allow_nan=False) + "\n").encode()


def _jsonable(obj: Any, np) -> Any:
    if isinstance(obj, dict):
        return {str(k): _jsonable(v, np) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v, np) for v in obj]
    if isinstance(obj, np.ndarray):
        return _jsonable(obj.tolist(), np)
    if isinstance(obj, (np.floating, float)):
        value = float(obj)
        return value if np.isfinite(value) else None
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, np.bool_):
        return bool(obj)
    return obj


def write_json(path: Path, obj: Any) -> None:
    atomic_write_bytes(path, dumps_json(obj))


def write_csv(path: Path, columns: dict[str, np.ndarray]) -> None:
    """Write equal-length columns as CSV with a header (floats with repr precision)."""
    import numpy as np

    names = list(columns)
    rows = zip(*(np.asarray(columns[n]).tolist() for n in names))
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(names)
    w.writerows(rows)
    atomic_write_bytes(path, buf.getvalue().encode())


def git_commit(start: Path | None = None) -> str | None:
    """The git commit of the source tree, if it is a checkout; None otherwise."""
    here = Path(start or Path(__file__).resolve().parent)
    try:
        out = subprocess.run(
            ["git", "rev-parse", "HEAD"], cwd=here, capture_output=True, text=True, timeout=5, check=False
        )
    except (OSError, subprocess.SubprocessError):
        return None
    return out.stdout.strip() or None if out.returncode == 0 else None


def default_run_dir(scenario_name: str, now: datetime | None = None) -> Path:
    stamp = (now or datetime.now(timezone.utc)).strftime("%Y%m%dT%H%M%SZ")
    return Path("runs") / f"{scenario_name}-{stamp}"


def host_info() -> dict[str, str]:
    return {"hostname": platform.node(), "platform": platform.platform(), "python": platform.python_version()}


def package_version() -> str:
    """The installed nodesim version ("0.0.0+unknown" when run from a source tree without installation)."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("nodesim")
    except PackageNotFoundError:
        return "0.0.0+unknown"
