"""The package layout: no import cycles (every import statement, wherever it stands), few modules directly
under nodesim/, and no two modules with the same name unless they are the same concept."""

import ast
from collections import defaultdict
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
PACKAGES = ("nodesim", "firmware_model", "channel")
# Base names that several packages share on purpose: each package's own error type, and package __init__s.
SAME_CONCEPT = {"errors": "the error type of each top-level package", "__init__": "package modules"}
MAX_TOP_LEVEL_MODULES = 6  # besides nodesim/__init__.py


def module_files(root: Path = REPO) -> dict[str, Path]:
    """Dotted module name -> file, for every module of the three packages (a package is its __init__)."""
    out = {}
    for package in PACKAGES:
        for path in sorted((root / package).rglob("*.py")):
            parts = list(path.relative_to(root).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts.pop()
            out[".".join(parts)] = path
    return out


def _resolve(name: str, modules: dict[str, Path]) -> str | None:
    """The module an imported dotted name lives in: ``a.b.c`` is module ``a.b.c`` or an attribute of ``a.b``."""
    while name and name not in modules:
        name = name.rpartition(".")[0]
    return name or None


def import_graph(modules: dict[str, Path]) -> dict[str, set[str]]:
    """module -> the project modules it imports, from every ``import`` / ``from ... import`` in its source
    (top level, inside functions, under ``if TYPE_CHECKING``, relative or absolute)."""
    graph = {}
    for name, path in modules.items():
        is_package = path.name == "__init__.py"
        deps = set()
        for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    anchor = name.split(".") if is_package else name.split(".")[:-1]
                    anchor = anchor[: len(anchor) - (node.level - 1)]
                    base = ".".join(anchor + ([base] if base else []))
                # ``from pkg import sub`` imports module pkg.sub; ``from mod import attr`` imports mod
                targets = [f"{base}.{a.name}" if f"{base}.{a.name}" in modules else base for a in node.names]
            else:
                continue
            deps |= {m for m in (_resolve(t, modules) for t in targets) if m and m != name}
        graph[name] = deps
    return graph


def find_cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Every strongly connected component of more than one module (Tarjan), each as one cycle path."""
    index, low, stack, on_stack, comps = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                comps.append(comp)

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return [_cycle_path(graph, set(c)) for c in comps]


def _cycle_path(graph: dict[str, set[str]], comp: set[str]) -> list[str]:
    """A closed path a -> b -> ... -> a through the component (breadth-first back to the start)."""
    start = min(comp)
    previous, frontier = {start: None}, [start]
    while frontier:
        nxt = []
        for v in frontier:
            for w in sorted(graph[v] & comp):
                if w == start:
                    path = [v]
                    while previous[path[-1]] is not None:
                        path.append(previous[path[-1]])
                    return path[::-1] + [start]
                if w not in previous:
                    previous[w] = v
                    nxt.append(w)
        frontier = nxt
    return sorted(comp)


def test_no_import_cycles():
    cycles = find_cycles(import_graph(module_files()))
    assert not cycles, "import cycles: " + "; ".join(" -> ".join(c) for c in cycles)


def test_the_cycle_check_finds_a_cycle_behind_a_function_level_import(tmp_path):
    """The check fails on a cycle hidden in a function body and under TYPE_CHECKING (a copy of the tree)."""
    for package in PACKAGES:
        (tmp_path / package).mkdir()
        (tmp_path / package / "__init__.py").write_text("")
    (tmp_path / "nodesim" / "a.py").write_text("def f():\n    from nodesim.b import g\n")
    (tmp_path / "nodesim" / "b.py").write_text(
        "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from nodesim import a\ndef g():\n    pass\n")
    (tmp_path / "channel" / "c.py").write_text("from . import d\n")
    (tmp_path / "channel" / "d.py").write_text("from .c import x\n")
    cycles = find_cycles(import_graph(module_files(tmp_path)))
    assert sorted(map(tuple, cycles)) == [("channel.c", "channel.d", "channel.c"), ("nodesim.a", "nodesim.b", "nodesim.a")]


def test_few_modules_directly_under_nodesim():
    top = sorted(p.name for p in (REPO / "nodesim").glob("*.py") if p.name != "__init__.py")
    assert len(top) <= MAX_TOP_LEVEL_MODULES, f"{len(top)} modules directly under nodesim/: {top}"


def test_no_two_modules_share_a_base_name():
    by_name = defaultdict(list)
    for path in module_files().values():
        by_name[path.stem].append(str(path.relative_to(REPO)))
    shared = {k: v for k, v in by_name.items() if len(v) > 1 and k not in SAME_CONCEPT}
    assert not shared, f"modules sharing a base name: {shared}"


@pytest.mark.parametrize("package", ["nodesim.chain", "nodesim.sensors", "nodesim.motion", "nodesim.rng", "nodesim.io"])
def test_package_modules_hold_no_code(package):
    """Importing one module of a package does not import its siblings: the package module is a docstring."""
    path = module_files()[package]
    body = ast.parse(path.read_text()).body
    assert all(isinstance(n, ast.Expr) and isinstance(n.value, ast.Constant) for n in body), f"{path} holds code"


def test_only_the_command_line_imports_the_command_line():
    """The CLI is a thin top layer: no library module (validation, API, ...) depends on it."""
    graph = import_graph(module_files())
    bad = sorted(f"{m} -> {d}" for m, deps in graph.items() if not m.startswith("nodesim.cli")
                 for d in deps if d.startswith("nodesim.cli"))
    assert not bad, f"library modules importing the CLI: {bad}"
