"""Packaging metadata (issue 22): runtime dependencies are what the commands need, optional tools live in
extras, the version-sensitive ones are bounded, and the licence and typing marker ship."""

import re
import tomllib
from importlib.metadata import version
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
PROJECT = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]


def _names(requirements) -> set[str]:
    return {re.split(r"[\[<>=!~; ]", r, maxsplit=1)[0].lower() for r in requirements}


def _upper(requirements, name) -> tuple[int, ...] | None:
    for r in requirements:
        if _names([r]) == {name}:
            m = re.search(r"<\s*([\d.]+)", r)
            return tuple(int(x) for x in m.group(1).split(".")) if m else None
    return None


def _v(name) -> tuple[int, ...]:
    return tuple(int(x) for x in re.findall(r"\d+", version(name))[:3])


def test_runtime_dependencies_leave_the_optional_tools_to_extras():
    runtime = _names(PROJECT["dependencies"])
    assert not runtime & {"dask", "distributed", "filterpy", "fxpmath", "apytypes", "scikit-rf", "welleng", "lasio",
                          "allantools", "hypothesis", "cffi", "pytest"}
    extras = PROJECT["optional-dependencies"]
    assert _names(extras["dask"]) == {"dask"} and "distributed" in extras["dask"][0]
    assert {"dask", "filterpy", "apytypes", "scikit-rf", "welleng", "lasio", "allantools", "hypothesis", "cffi",
            "pytest"} <= _names(extras["test"])
    assert {"fxpmath", "filterpy"} <= _names(extras["bench"])


def test_numpy_numba_llvmlite_are_bounded_above_the_tested_versions():
    """Upper bounds exist (the bit-identical RNG copies follow their internals) and admit what is installed."""
    deps = PROJECT["dependencies"]
    for name in ("numpy", "numba", "llvmlite"):
        bound = _upper(deps, name)
        assert bound is not None, name
        assert _v(name)[: len(bound)] < bound, (name, version(name), bound)


def test_licence_and_typing_marker_ship():
    assert PROJECT["license"] == "MIT" and "MIT License" in (REPO / "LICENSE").read_text()
    data = tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["setuptools"]["package-data"]
    for package in ("nodesim", "firmware_model", "channel"):
        assert (REPO / package / "py.typed").exists() and "py.typed" in data[package]
    assert any(c.startswith("Programming Language :: Python :: 3.") for c in PROJECT["classifiers"])
