"""Checks of our figures against published ones (``nodesim validate``).

Each module ``nodesim/validation/checks_<topic>.py`` defines ``CHECKS``: a list of zero-argument callables,
each returning a list of :class:`Check`.  Modules are discovered by name, so adding a topic never edits
this file.  A check records what we computed, what the source published, the tolerance and whether we are
inside it; a published figure we cannot reproduce stays in the list with ``ok = False`` and a note saying why.
Every check says what ``kind`` it is: ``reproduction`` (our model, run independently, against a published figure),
``self_consistency`` (a published value fed in and read back, or our own figures against each other) or
``hypothesis`` (a published figure matched under an assumption the source does not state; the note says which).
"""

from __future__ import annotations

import importlib
import pkgutil
from dataclasses import asdict, dataclass
from typing import Literal

KINDS = ("reproduction", "self_consistency", "hypothesis")


@dataclass(frozen=True)
class Check:
    name: str
    source: str  # seed document and table/page
    ours: float
    published: float
    tolerance: str  # human-readable rule, e.g. "rel 0.5 %" or "factor 2"
    ok: bool
    note: str = ""
    kind: Literal["reproduction", "self_consistency", "hypothesis"] = "reproduction"

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"check {self.name!r}: kind {self.kind!r} is not one of {KINDS}")

    def as_dict(self) -> dict:
        return asdict(self)


def within_rel(name: str, source: str, ours: float, published: float, rel: float, note: str = "",
               kind: str = "reproduction") -> Check:
    """Check |ours - published| <= rel * |published|."""
    ok = abs(ours - published) <= rel * abs(published)
    return Check(name, source, float(ours), float(published), f"rel {rel:g}", bool(ok), note, kind)


def within_abs(name: str, source: str, ours: float, published: float, tol: float, note: str = "",
               kind: str = "reproduction") -> Check:
    """Check |ours - published| <= tol."""
    return Check(name, source, float(ours), float(published), f"abs {tol:g}", bool(abs(ours - published) <= tol), note,
                 kind)


def within_factor(name: str, source: str, ours: float, published: float, factor: float, note: str = "",
                  kind: str = "reproduction") -> Check:
    """Check published / factor <= ours <= published * factor (both positive)."""
    ok = published / factor <= ours <= published * factor
    return Check(name, source, float(ours), float(published), f"factor {factor:g}", bool(ok), note, kind)


def counts_by_kind(checks) -> dict[str, tuple[int, int]]:
    """(ok, total) per kind, in the order of :data:`KINDS` (a kind without rows counts (0, 0))."""
    return {kind: (sum(c.ok for c in checks if c.kind == kind), sum(c.kind == kind for c in checks)) for kind in KINDS}


def check_modules() -> list[str]:
    """Names of the discovered check modules, sorted."""
    return sorted(m.name for m in pkgutil.iter_modules(__path__) if m.name.startswith("checks_"))


def run_checks() -> list[Check]:
    """Run every discovered check, in module order."""
    out: list[Check] = []
    for name in check_modules():
        module = importlib.import_module(f"{__name__}.{name}")
        for fn in module.CHECKS:
            out.extend(fn())
    return out
