"""Bundled scenario files (TOML), importable so they ship with the wheel.

    lab/      the thesis lab experiments and update modes
    field/    the thesis field wellbores
    whatif/   end-to-end link what-ifs
    perf/     benchmark cases
    sweeps/   campaigns

Use :func:`path` to get a real file path: ``scenarios.path("lab/continuous.toml")``.
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path


def path(relative: str) -> Path:
    """Filesystem path of a bundled scenario (the package is installed unzipped)."""
    p = Path(str(resources.files(__name__).joinpath(relative)))
    if not p.is_file():
        raise FileNotFoundError(f"no bundled scenario {relative!r}")
    return p
