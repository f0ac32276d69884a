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


BACKEND_PROBE = """
import importlib, sys
import matplotlib
matplotlib.use("svg")
before = matplotlib.get_backend()
for name in sys.argv[1:]:
    importlib.import_module(name)
print(before, matplotlib.get_backend())
"""


def _our_modules() -> list[tuple[str, Path]]:
    found = []
    for package in ("nodesim", "firmware_model", "channel"):
        for path in sorted((REPO / package).rglob("*.py")):
            if path.name == "__main__.py":
                continue
            parts = path.relative_to(REPO).with_suffix("").parts
            found.append((".".join(parts[:-1] if parts[-1] == "__init__" else parts), path))
    return found


def test_importing_any_module_keeps_the_matplotlib_backend():
    """A notebook's backend survives importing our code: no module switches it (no matplotlib.use)."""
    import os
    import subprocess
    import sys

    modules = _our_modules()
    env = {k: v for k, v in os.environ.items() if k != "MPLBACKEND"}
    done = subprocess.run([sys.executable, "-c", BACKEND_PROBE, *(name for name, _ in modules)], cwd=REPO, env=env,
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-3000:]
    before, after = done.stdout.split()[-2:]
    assert after == before, f"importing our modules switched the matplotlib backend from {before} to {after}"
    switching = [str(path.relative_to(REPO)) for _, path in modules if "matplotlib.use(" in path.read_text()]
    assert not switching, f"these modules call matplotlib.use(...): {switching}"
