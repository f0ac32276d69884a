from pathlib import Path

import pytest

DATA = Path(__file__).resolve().parents[2] / "data" / "iscwsa"


@pytest.fixture(scope="session")
def iscwsa_dir() -> Path:
    return DATA
