"""Campaign driver: plan the runs of a sweep, hand them to an executor, store every finished run at once.

``run_campaign`` writes ``campaign.json`` (the manifest) before the first run and again at the end; finished
runs go to the campaign store as they arrive (see :mod:`nodesim.sweep.store`).  With ``resume=True`` it
checks that the directory was started from the same sweep (same spec hash: sweep file contents and resolved
base scenario), skips every run already stored as ``ok`` and runs the others.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path
from typing import Callable, TextIO

import pandas as pd

from nodesim.errors import NodesimError
from nodesim.io.rundir import git_commit, host_info, package_version, write_json
from nodesim.sweep.progress import Progress
from nodesim.sweep.spec import RESERVED_COLUMNS, RunTask, SweepSpec
from nodesim.sweep.store import RESULTS, CampaignStore
from nodesim.sweep.tasks import run_point

MANIFEST = "campaign.json"


@dataclass(frozen=True)
class CampaignResult:
    directory: Path
    planned: int
    ok: int
    failed: int
    skipped: int
    table: pd.DataFrame

    def summary(self) -> dict:
        return {
            "campaign": str(self.directory),
            "results": str(self.directory / RESULTS),
            "planned": self.planned,
            "ok": self.ok,
            "failed": self.failed,
            "skipped_already_done": self.skipped,
        }


def read_manifest(directory: Path, name: str = MANIFEST) -> dict | None:
    """The JSON manifest ``directory/name`` (default ``campaign.json``), or None when there is none."""
    path = Path(directory) / name
    if not path.exists():
        return None
    try:
        return json.loads(path.read_text())
    except (OSError, json.JSONDecodeError) as err:
        raise NodesimError(f"{path}: unreadable campaign manifest ({err})") from None


def run_campaign(
    spec: SweepSpec,
    out_dir: Path,
    executor,
    resume: bool = False,
    quiet: bool = False,
    run_fn: Callable[[RunTask], dict] = run_point,
    stream: TextIO | None = None,
    tasks: list[RunTask] | None = None,
) -> CampaignResult:
    """Run (or resume) the campaign of ``spec`` in ``out_dir``; returns counts and the consolidated table."""
    out = Path(out_dir)
    old = read_manifest(out)
    if old is None and resume:
        raise NodesimError(f"{out}: no campaign to resume (no {MANIFEST}); drop --resume to start a new one")
    if old is not None and not resume:
        raise NodesimError(f"{out}: already holds a campaign; pass --resume to continue it, or choose another --out")
    if old is not None and old.get("sweep", {}).get("spec_sha256") != spec.spec_hash:
        raise NodesimError(
            f"{out}: was started from a different sweep (sweep file or base scenario changed); "
            "--resume needs the same sweep, or choose another --out"
        )
    tasks = spec.plan(out) if tasks is None else tasks
    store = CampaignStore(out, spec.param_keys())
    planned_ids = {t.run_id for t in tasks}
    done = store.done_ids() & planned_ids
    todo = [t for t in tasks if t.run_id not in done]
    started = datetime.now(timezone.utc)
    manifest = {
        "nodesim_version": package_version(),
        "git_commit": git_commit(),
        "sweep": spec.describe(),
        "base_scenario": spec.base.model_dump(),
        "param_keys": spec.param_keys(),
        "planned_runs": len(tasks),
        "executor": executor.describe(),
        "host": host_info(),
        "started_utc": (old or {}).get("started_utc", started.isoformat()),
        "status": "running",
        "load_with": f"pandas.read_parquet('{out / RESULTS}')",
    }
    write_json(out / MANIFEST, manifest)
    t0 = time.perf_counter()
    progress = Progress(len(tasks), already_done=len(done), quiet=quiet, stream=stream)
    try:
        for rec in executor.imap(run_fn, todo):
            store.append([rec])
            progress.update(rec.status == "ok")
    finally:
        progress.close()
        table = store.consolidate()
        table = table[table["run_id"].isin(planned_ids)].reset_index(drop=True) if len(table) else table
        n_ok = int((table["status"] == "ok").sum()) if len(table) else 0
        n_failed = int((table["status"] == "failed").sum()) if len(table) else 0
        manifest.update(
            status="complete" if n_ok + n_failed == len(tasks) else "interrupted",
            ok=n_ok,
            failed=n_failed,
            finished_utc=datetime.now(timezone.utc).isoformat(),
            session_wall_s=time.perf_counter() - t0,
            metrics=[c for c in table.columns if c not in set(manifest["param_keys"]) | RESERVED_COLUMNS],
        )
        write_json(out / MANIFEST, manifest)
    return CampaignResult(out, len(tasks), n_ok, n_failed, len(done), table)

