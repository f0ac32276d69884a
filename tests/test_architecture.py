"""Package rules of the architecture note: firmware_model and channel never import nodesim or each other."""

import ast
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
FORBIDDEN = {"firmware_model": {"nodesim", "channel", "simpy"}, "channel": {"nodesim", "firmware_model", "simpy"}}


def _imports(path: Path) -> set[str]:
    tree = ast.parse(path.read_text())
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names |= {a.name.split(".")[0] for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module.split(".")[0])
    return names


@pytest.mark.parametrize("package", sorted(FORBIDDEN))
def test_lower_packages_do_not_import_upwards(package):
    for path in (REPO / package).rglob("*.py"):
        bad = _imports(path) & FORBIDDEN[package]
        assert not bad, f"{path.relative_to(REPO)} imports {sorted(bad)}"


def test_modules_stay_focused():
    for package in ("nodesim", "firmware_model", "channel", "scenarios"):
        for path in (REPO / package).rglob("*.py"):
            assert len(path.read_text().splitlines()) <= 600, f"{path} is over 600 lines: split it"
