"""Run-directory files, every one written atomically, and the facts a manifest records.

A run directory (:meth:`nodesim.api.Run.save`; default ``runs/<scenario-name>-<UTC timestamp>``) holds
``manifest.json`` (package version, git commit, scenario hash, resolved scenario, root seed, wall time,
host), ``summary.json`` (flat headline metrics, :mod:`nodesim.chain.metrics`; timing under "timing"), the
CSV tables of :mod:`nodesim.chain.run_tables` and ``yaw_error.png``.

Atomic writes: each file is written to a temporary file in the same directory and renamed into place, so
an interrupted run never leaves a half-written file under its final name.  Files get the mode an ordinary
``open()`` would give, 0o666 & ~umask (0644 under umask 022; ``mkstemp`` alone would leave 0600), and
directories 0o777 & ~umask.

Used directories: a run is written only into a missing or empty directory (:func:`check_empty_dir`); with
``force`` it is written into a fresh sibling directory which is then swapped into place
(:func:`replace_dir`: ``renameat2(RENAME_EXCHANGE)`` on Linux, two renames elsewhere), so the directory
holds only the new run and an interrupted run leaves the old one whole.
"""

from __future__ import annotations

import csv
import io
import json
import os
import platform
import subprocess
import shutil
import sys
import tempfile
from contextlib import contextmanager
from datetime import datetime, timezone
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Iterator

from nodesim.errors import NodesimError

if TYPE_CHECKING:
    import numpy as np


def current_umask() -> int:
    """The process umask (Linux: read from /proc/self/status; elsewhere set and restored at once)."""
    try:
        with open("/proc/self/status", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError, IndexError):
        pass
    old = os.umask(0o022)
    os.umask(old)
    return old


def file_mode() -> int:
    """Mode of a newly created file, as ``open()`` gives it: 0o666 & ~umask."""
    return 0o666 & ~current_umask()


def dir_mode() -> int:
    """Mode of a newly created directory, as ``mkdir`` gives it: 0o777 & ~umask."""
    return 0o777 & ~current_umask()


def atomic_write_bytes(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file (mode 0o666 & ~umask) and ``os.replace``."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        os.fchmod(fd, file_mode())
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
        os.chmod(tmp, file_mode())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def check_empty_dir(directory: str | Path, what: str = "run", marker_files: tuple[str, ...] = ()) -> None:
    """Refuse an existing non-directory or a non-empty directory (one line naming what is there and --force)."""
    d = Path(directory)
    if d.exists() and not d.is_dir():
        raise NodesimError(f"{d}: exists and is not a directory; give a directory for the {what}")
    if not d.is_dir():
        return
    entries = sorted(p.name for p in d.iterdir())
    if not entries:
        return
    held = [name for name in marker_files if name in entries]
    shown = ", ".join((held or entries)[:6]) + (", ..." if len(held or entries) > 6 else "")
    state = f"already holds a {what} ({shown})" if held else f"is not empty ({shown})"
    raise NodesimError(f"{d}: {state}; give a new directory, or pass --force to replace it")


@contextmanager
def replace_dir(directory: str | Path) -> Iterator[Path]:
    """Yield a fresh sibling directory of ``directory``; when the block succeeds, swap it into place.

    The stage is ``.<name>.new-XXXX`` beside ``directory`` (same file system, so the swap is a rename).
    An existing ``directory`` is exchanged atomically with the stage (Linux ``renameat2`` with
    ``RENAME_EXCHANGE``; elsewhere renamed aside first) and then deleted.  If the block fails, the stage is
    deleted and ``directory`` is untouched.
    """
    d = Path(directory)
    if d.exists() and not d.is_dir():
        raise NodesimError(f"{d}: exists and is not a directory")
    d.parent.mkdir(parents=True, exist_ok=True)
    stage = Path(tempfile.mkdtemp(prefix=f".{d.name}.new-", dir=d.parent))
    try:
        os.chmod(stage, dir_mode())
        yield stage
        if not d.exists():
            os.rename(stage, d)
            return
        if not _exchange(stage, d):
            aside = Path(tempfile.mkdtemp(prefix=f".{d.name}.old-", dir=d.parent))
            os.rename(d, aside / "old")
            os.rename(stage, d)
            stage = aside
    except BaseException:
        shutil.rmtree(stage, ignore_errors=True)
        raise
    shutil.rmtree(stage, ignore_errors=True)  # the old directory, now under the stage's name


def _exchange(a: Path, b: Path) -> bool:
    """Atomically exchange two paths (Linux renameat2 RENAME_EXCHANGE); False where that is unavailable."""
    import ctypes

    from nodesim.io.libc import libc_function

    renameat2 = libc_function("renameat2", [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p,
                                            ctypes.c_uint])
    if renameat2 is None:
        return False
    at_fdcwd, rename_exchange = -100, 2
    return renameat2(at_fdcwd, os.fsencode(a), at_fdcwd, os.fsencode(b), rename_exchange) == 0


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
    atomic_write_bytes(path, csv_text(columns).encode())


def csv_text(columns: dict[str, np.ndarray], header: bool = True) -> str:
    """Equal-length columns as CSV text (floats with repr precision), with the header line of their names or without
    (a later block of the same table, :class:`nodesim.chain.streaming.TimeseriesFile`)."""
    import numpy as np

    names = list(columns)
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    if header:
        w.writerow(names)
    w.writerows(zip(*(np.asarray(columns[n]).tolist() for n in names)))
    return buf.getvalue()


def write_parquet(path: Path, data, compression: str = "snappy", **options) -> None:
    """Write a DataFrame, equal-length columns (dict of arrays) or a pyarrow Table as one Parquet file, atomically
    (``options``: more of ``pyarrow.parquet.write_table``'s)."""
    import numpy as np
    import pyarrow as pa
    import pyarrow.parquet as pq

    if isinstance(data, pa.Table):
        table = data
    elif isinstance(data, dict):
        table = pa.table({k: np.asarray(v) for k, v in data.items()})
    else:
        table = pa.Table.from_pandas(data, preserve_index=False)
    atomic_write_with(path, lambda p: pq.write_table(table, p, compression=compression, **options))


def read_parquet(path: Path):
    """A Parquet file as a DataFrame; an unreadable one is a :class:`NodesimError` naming it."""
    import pandas as pd

    try:
        return pd.read_parquet(path)
    except (OSError, ValueError) as err:
        raise NodesimError(f"{path}: unreadable Parquet ({err})") from None


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
