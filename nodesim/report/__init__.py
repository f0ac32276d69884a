"""Self-contained HTML reports of a run directory or a campaign directory (``nodesim report DIR``).

The page is one file (``DIR/report.html`` by default) with every plot embedded as a base64 PNG, so it can be
mailed or archived alone.  :func:`write_report` picks the kind from the directory: ``campaign.json`` ->
campaign report (:mod:`nodesim.report.campaign_report`), ``optimization.json`` -> optimisation report
(:mod:`nodesim.report.optimization_report`), ``summary.json`` / ``manifest.json`` -> run report
(:mod:`nodesim.report.run_report`).
"""

from __future__ import annotations

from pathlib import Path

from nodesim.errors import NodesimError
from nodesim.io.rundir import atomic_write_bytes


def report_kind(directory: Path) -> str:
    d = Path(directory)
    if not d.is_dir():
        raise NodesimError(f"{d}: not a directory (give a run directory or a campaign directory)")
    if (d / "campaign.json").exists():
        return "campaign"
    if (d / "optimization.json").exists():
        return "optimization"
    if (d / "summary.json").exists() or (d / "manifest.json").exists():
        return "run"
    raise NodesimError(f"{d}: neither a run directory (summary.json), a campaign directory (campaign.json) nor an "
                      "optimisation directory (optimization.json)")


def write_report(directory: Path, out: Path | None = None, **options) -> dict:
    """Build the report of ``directory`` and write it atomically; returns {report, kind, images, ...}."""
    kind = report_kind(directory)
    if kind == "campaign":
        from nodesim.report.campaign_report import campaign_page as build
    elif kind == "optimization":
        from nodesim.report.optimization_report import optimization_page as build
    else:
        from nodesim.report.run_report import run_page as build
    page, info = build(Path(directory), **options)
    target = Path(out) if out is not None else Path(directory) / "report.html"
    atomic_write_bytes(target, page.render().encode("utf-8"))
    return {"report": str(target), "kind": kind, "images": page.n_images, **info}
