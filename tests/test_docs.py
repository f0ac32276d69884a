"""The README and the user docs moved out of it (docs/guide.md, validation.md, benchmarks.md) name only
modules, objects and files that exist (the layout they describe is the tree's); the README stays short."""

import glob
import importlib
import re
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
USER_DOCS = ("README.md", "docs/guide.md", "docs/validation.md", "docs/benchmarks.md")
README = "\n".join((REPO / name).read_text() for name in USER_DOCS)
DOTTED = sorted(set(re.findall(r"\b(?:nodesim|firmware_model|channel)(?:\.[A-Za-z_]\w*)+", README)))
PATHS = sorted(set(re.findall(r"\b(?:nodesim|firmware_model|channel|tests|benchmarks|scenarios)/[\w./*-]*", README)))


def _resolves(dotted: str) -> bool:
    parts = dotted.split(".")
    for cut in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:cut]))
        except ModuleNotFoundError:
            continue
        for attr in parts[cut:]:
            if not hasattr(obj, attr):
                return False
            obj = getattr(obj, attr)
        return True
    return False


@pytest.mark.parametrize("dotted", DOTTED)
def test_readme_dotted_names_exist(dotted):
    assert _resolves(dotted), f"README names {dotted}, which does not exist"


@pytest.mark.parametrize("path", PATHS)
def test_readme_paths_exist(path):
    path = path.rstrip(".")
    if path == "benchmarks/latest.json":  # written by `make bench`, not committed
        return
    assert glob.glob(str(REPO / path)) or (REPO / path).with_suffix(".toml").exists(), \
        f"README names {path}, which is not in the tree"


SOURCES = [p for package in ("nodesim", "firmware_model", "channel", "benchmarks") for p in (REPO / package).rglob("*.py")]
TEST_PATHS = sorted({(str(p.relative_to(REPO)), m) for p in SOURCES
                     for m in re.findall(r"\btests/[\w/]+\.py", p.read_text())})


@pytest.mark.parametrize("source, path", TEST_PATHS)
def test_test_files_named_in_docstrings_exist(source, path):
    assert (REPO / path).is_file(), f"{source} cites {path}, which is not in the tree"


def test_readme_is_a_short_user_guide_that_links_the_docs():
    text = (REPO / "README.md").read_text()
    assert len(text.splitlines()) <= 400
    for doc in ("docs/guide.md", "docs/validation.md", "docs/benchmarks.md", "docs/scenario-reference.md"):
        assert f"]({doc})" in text and (REPO / doc).is_file(), doc
