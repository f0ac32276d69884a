import os
from pathlib import Path

import pytest

os.environ.setdefault("MPLBACKEND", "Agg")

REPO = Path(__file__).resolve().parents[1]
LAB_CONTINUOUS = REPO / "scenarios" / "lab" / "continuous.toml"


@pytest.fixture
def lab_toml() -> Path:
    return LAB_CONTINUOUS


@pytest.fixture
def write_toml(tmp_path):
    """Write a scenario TOML text to a temporary file and return its path."""

    def _write(text: str, name: str = "scenario.toml") -> Path:
        p = tmp_path / name
        p.write_text(text)
        return p

    return _write
