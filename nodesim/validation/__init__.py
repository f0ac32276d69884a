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

import numpy as np

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
    # distribution rows (:func:`within_band`): ``ours`` is the median of ``realizations`` runs, the band their 5th and
    # 95th percentiles, ``published_percentile`` where the published value falls among them (per cent); None elsewhere
    band_p5: float | None = None
    band_p95: float | None = None
    published_percentile: float | None = None
    realizations: int | None = None

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


def percentile_of(values, value: float) -> float:
    """Where ``value`` falls among ``values`` [per cent]: the share below it, ties counted half."""
    v = np.asarray(values, dtype=float)
    return float(100.0 * (np.sum(v < value) + 0.5 * np.sum(v == value)) / v.size)


def within_band(name: str, source: str, values, published: float, note: str = "", kind: str = "reproduction",
                printed_below: float | None = None) -> Check:
    """A distribution row: ``values`` are our figure in each of many runs (realizations) and ``published`` the
    figure of the source's one run; ok when ``published`` lies inside our 5-95 % band, ``ours`` = the median.

    ``printed_below``: the published value is a printed zero, anywhere in [0, printed_below); ok when that interval
    reaches into the band (our 5th percentile below ``printed_below``), and its percentile is that of
    ``printed_below`` (the most the printed zero can be)."""
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    if v.size < 2:
        return Check(name, source, float("nan"), float(published), "published inside our 5-95 % band", False,
                     (note + "; " if note else "") + f"only {v.size} finite run(s)", kind, realizations=int(v.size))
    p5, p50, p95 = (float(x) for x in np.percentile(v, [5.0, 50.0, 95.0]))
    if printed_below is None:
        ok, at = p5 <= published <= p95, percentile_of(v, published)
    else:
        ok, at = p5 < printed_below, percentile_of(v, printed_below)
    return Check(name, source, p50, float(published), f"published inside our 5-95 % band ({v.size} runs)", bool(ok),
                 note, kind, band_p5=p5, band_p95=p95, published_percentile=at, realizations=int(v.size))


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
