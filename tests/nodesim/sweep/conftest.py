"""Small, fast sweeps for the campaign tests: a shortened lab run (120 s, metrics window 80-120 s)."""

from pathlib import Path

import pytest

SHORT_BASE = """
name = "short"
seed = 7
[simulation]
duration_s = 120.0
[motion]
fast_turns = 2.0
[metrics]
window_start_s = 80.0
window_end_s = 120.0
"""


@pytest.fixture
def make_sweep(tmp_path):
    """Write a base scenario and a sweep TOML body (``base`` is set) into tmp_path; return the sweep path."""

    def _make(body: str, base: str = SHORT_BASE, name: str = "sweep.toml") -> Path:
        (tmp_path / "base.toml").write_text(base)
        p = tmp_path / name
        p.write_text('base = "base.toml"\n' + body)
        return p

    return _make
