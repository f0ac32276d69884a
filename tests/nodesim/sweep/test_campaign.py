"""Campaigns: same table on the local pool and on a Dask LocalCluster; failures recorded; resume after a kill."""

import dataclasses
import io
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pandas.testing as pdt
import pytest

from nodesim.errors import NodesimError
from nodesim.sweep.campaign import read_manifest, run_campaign
from nodesim.sweep.executors import DaskExecutor, LocalExecutor, make_executor
from nodesim.sweep.progress import Progress, format_duration
from nodesim.sweep.spec import load_sweep
from nodesim.sweep.store import TIMING_COLUMNS
from nodesim.sweep.tasks import busy_run

SMALL = """
seeds = 2
metrics = ["rms_azimuth_error_deg", "rms_yaw_error_deg", "update_fraction"]
[overrides]
"schedule.mode" = "windowed"
[[axis]]
key = "schedule.timeout_s"
values = [5.0, 20.0]
[[axis]]
key = "filter.tuning_b"
values = [1.0, 5.0]
"""

# the full 620 s lab profile with 8 realizations: slow enough (~0.2 s a run) to be killed mid-campaign
FULL_BASE = 'name = "full"\nseed = 3\n[simulation]\nrealizations = 8\n'


def _deterministic(df: pd.DataFrame) -> pd.DataFrame:
    return df.drop(columns=TIMING_COLUMNS)


def test_local_pool_and_dask_localcluster_give_the_same_table(make_sweep, tmp_path):
    spec = load_sweep(make_sweep(SMALL))
    with LocalExecutor(workers=2) as ex:
        local = run_campaign(spec, tmp_path / "local", ex, quiet=True)
    with DaskExecutor(workers=2, processes=False) as ex:
        dask = run_campaign(spec, tmp_path / "dask", ex, quiet=True)
    assert local.planned == 8 and local.ok == 8 and dask.ok == 8
    pdt.assert_frame_equal(_deterministic(local.table), _deterministic(dask.table))
    # and the table on disk is what was returned; loading it back is one pandas call
    pdt.assert_frame_equal(_deterministic(pd.read_parquet(tmp_path / "local" / "results.parquet")), _deterministic(local.table))
    # points really differ: the timeout changes the azimuth error (the table is not a constant)
    assert local.table["rms_azimuth_error_deg"].nunique() > 1
    assert list(local.table.columns[:6]) == ["run_id", "point", "seed_index", "seed", "schedule.timeout_s", "filter.tuning_b"]


def test_failing_point_is_recorded_with_its_error_and_the_others_finish(make_sweep, tmp_path):
    spec = load_sweep(make_sweep("""
seeds = 2
metrics = ["rms_azimuth_error_deg"]
[[axis]]
key = "simulation.realizations"
values = [1, 0, 2]
"""))
    with make_executor("local", workers=2) as ex:
        res = run_campaign(spec, tmp_path / "c", ex, quiet=True)
    t = res.table.set_index("run_id")
    assert res.ok == 4 and res.failed == 2
    bad = t[t["point"] == 1]
    assert (bad["status"] == "failed").all()
    assert bad["error"].str.contains("simulation.realizations").all()
    assert bad["rms_azimuth_error_deg"].isna().all()
    assert t.loc[t["point"] != 1, "rms_azimuth_error_deg"].notna().all()
    assert read_manifest(tmp_path / "c")["status"] == "complete"


def _synthetic_tasks(spec, **payloads):
    tasks = spec.plan()
    return [dataclasses.replace(t, payload=payloads.get(t.run_id, {})) for t in tasks]


def test_crashing_run_is_retried_then_recorded_and_a_dying_worker_is_replaced(make_sweep, tmp_path):
    spec = load_sweep(make_sweep('seeds = 4\nretries = 1\n'))
    tasks = _synthetic_tasks(
        spec,
        **{"p00000-s001": {"fail": True}, "p00000-s002": {"crash_marker": str(tmp_path / "crashed-once")}},
    )
    with LocalExecutor(workers=2) as ex:
        res = run_campaign(spec, tmp_path / "c", ex, quiet=True, run_fn=busy_run, tasks=tasks)
    t = res.table.set_index("run_id")
    assert t.loc["p00000-s001", "status"] == "failed"
    assert t.loc["p00000-s001", "attempts"] == 2  # retries = 1: two attempts, then recorded
    assert "synthetic failure of p00000-s001" in t.loc["p00000-s001", "error"]
    # the worker running s002 died (os._exit): the pool is replaced and the run retried successfully
    assert (tmp_path / "crashed-once").exists()
    assert t.loc["p00000-s002", "status"] == "ok" and t.loc["p00000-s002", "attempts"] >= 2
    assert t.loc[["p00000-s000", "p00000-s003"], "status"].eq("ok").all()


def test_dask_records_a_raising_run_and_keeps_going(make_sweep, tmp_path):
    spec = load_sweep(make_sweep('seeds = 3\nretries = 0\n'))
    tasks = _synthetic_tasks(spec, **{"p00000-s000": {"fail": True}})
    with DaskExecutor(workers=1, processes=False) as ex:
        res = run_campaign(spec, tmp_path / "c", ex, quiet=True, run_fn=busy_run, tasks=tasks)
    assert (res.ok, res.failed) == (2, 1)
    assert res.table.loc[0, "error"].startswith("RuntimeError: synthetic failure")


class _Killed(BaseException):
    """Stands for the driver dying mid-campaign."""


class _DiesAfter:
    """Wraps an executor; the driver 'dies' after ``n`` finished runs have been yielded."""

    def __init__(self, inner, n):
        self.inner, self.n = inner, n

    def imap(self, fn, tasks):
        for i, rec in enumerate(self.inner.imap(fn, tasks)):
            if i == self.n:
                raise _Killed()
            yield rec

    def describe(self):
        return self.inner.describe()


def test_resume_after_an_interrupted_driver_neither_duplicates_nor_loses_rows(make_sweep, tmp_path):
    spec = load_sweep(make_sweep(SMALL))
    out = tmp_path / "c"
    with LocalExecutor(workers=1) as ex:
        with pytest.raises(_Killed):
            run_campaign(spec, out, _DiesAfter(ex, 3), quiet=True)
    assert read_manifest(out)["status"] == "interrupted"
    assert len(pd.read_parquet(out / "results.parquet")) == 3
    with pytest.raises(NodesimError, match="--resume"):
        with LocalExecutor(workers=1) as ex:
            run_campaign(spec, out, ex, quiet=True)
    with LocalExecutor(workers=1) as ex:
        res = run_campaign(spec, out, ex, resume=True, quiet=True)
    assert res.skipped == 3 and res.ok == 8
    df = pd.read_parquet(out / "results.parquet")
    assert len(df) == 8 and df["run_id"].is_unique
    # a fresh uninterrupted campaign gives the same rows
    with LocalExecutor(workers=1) as ex:
        fresh = run_campaign(spec, tmp_path / "fresh", ex, quiet=True)
    pdt.assert_frame_equal(_deterministic(df), _deterministic(fresh.table))


def test_resume_refuses_a_changed_sweep(make_sweep, tmp_path):
    spec = load_sweep(make_sweep(SMALL))
    with LocalExecutor(workers=1) as ex:
        run_campaign(spec, tmp_path / "c", ex, quiet=True)
    changed = load_sweep(make_sweep(SMALL.replace("20.0", "25.0"), name="other.toml"))
    with LocalExecutor(workers=1) as ex, pytest.raises(NodesimError, match="different sweep"):
        run_campaign(changed, tmp_path / "c", ex, resume=True, quiet=True)


def test_cli_resume_after_sigkill(make_sweep, tmp_path):
    """Kill -9 the whole `nodesim sweep` process group mid-campaign, then --resume: every run exactly once."""
    sweep = make_sweep("""
seeds = 12
metrics = ["rms_azimuth_error_deg"]
[[axis]]
key = "filter.tuning_b"
values = [1.0, 5.0]
""", base=FULL_BASE)
    out = tmp_path / "camp"
    cmd = [sys.executable, "-m", "nodesim.cli.main", "sweep", str(sweep), "--out", str(out), "--workers", "1", "--quiet"]
    proc = subprocess.Popen(cmd, start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and len(list((out / "parts").glob("part-*.parquet"))) < 3:
        assert proc.poll() is None, proc.stderr.read().decode()
        time.sleep(0.02)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    assert not (out / "results.parquet").exists() or len(pd.read_parquet(out / "results.parquet")) < 24
    assert read_manifest(out)["status"] == "running"  # the driver never got to write its end
    done = subprocess.run(cmd + ["--resume", "--json"], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    df = pd.read_parquet(out / "results.parquet")
    assert len(df) == 24 and df["run_id"].is_unique and (df["status"] == "ok").all()
    assert not list((out / "parts").glob("part-*.parquet"))


def test_progress_is_silent_off_a_terminal_and_shows_counts_and_eta_on_one():
    plain = io.StringIO()
    p = Progress(10, stream=plain)
    p.update(True)
    p.close()
    assert plain.getvalue() == ""

    class Tty(io.StringIO):
        def isatty(self):
            return True

    tty = Tty()
    p = Progress(4, already_done=1, stream=tty, max_rate_hz=1e9)
    p.update(True)
    p.update(False)
    p.close()
    last = tty.getvalue().strip().split("\r")[-1]
    assert "3/4" in last and "ok 2" in last and "failed 1" in last and "remaining 1" in last and "ETA" in last
    quiet = Tty()
    Progress(4, quiet=True, stream=quiet).close()
    assert quiet.getvalue() == ""
    assert format_duration(75) == "1m15s" and format_duration(3700) == "1h01m" and format_duration(float("nan")) == "?"


def test_cli_errors_exit_2(make_sweep, tmp_path, capsys):
    from nodesim.cli.main import main

    sweep = make_sweep('[[axis]]\nkey = "chain.nodez"\nvalues = [1]\n')
    assert main(["sweep", str(sweep), "--out", str(tmp_path / "x")]) == 2
    assert "chain.nodez" in capsys.readouterr().err
    ok = make_sweep("seeds = 1\n", name="ok.toml")
    assert main(["sweep", str(ok), "--resume"]) == 2
    assert "--resume needs --out" in capsys.readouterr().err
    assert main(["sweep", str(ok), "--scheduler", "tcp://127.0.0.1:1"]) == 2
    assert "--scheduler needs --executor dask" in capsys.readouterr().err
    assert not (tmp_path / "x").exists()


def test_cli_sweep_on_a_dask_localcluster_matches_the_local_pool(make_sweep, tmp_path, capsys):
    from nodesim.cli.main import main

    sweep = make_sweep('seeds = 2\nmetrics = ["rms_azimuth_error_deg"]\n')
    assert main(["sweep", str(sweep), "--out", str(tmp_path / "d"), "--executor", "dask", "--workers", "1", "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert (summary["planned"], summary["ok"]) == (2, 2)
    assert main(["sweep", str(sweep), "--out", str(tmp_path / "l"), "--workers", "1", "--quiet"]) == 0
    capsys.readouterr()
    d, l = (pd.read_parquet(tmp_path / x / "results.parquet") for x in ("d", "l"))
    pdt.assert_frame_equal(_deterministic(d), _deterministic(l))
    assert read_manifest(tmp_path / "d")["executor"]["executor"] == "dask"


def test_dask_worker_that_dies_is_replaced_and_its_run_finishes(make_sweep, tmp_path):
    """A Dask worker process killed mid-run (os._exit): the nanny restarts it and the run is retried."""
    spec = load_sweep(make_sweep("seeds = 3\n"))
    marker = tmp_path / "dask-crashed-once"
    tasks = _synthetic_tasks(spec, **{"p00000-s001": {"crash_marker": str(marker)}})
    with DaskExecutor(workers=1, processes=True) as ex:
        res = run_campaign(spec, tmp_path / "c", ex, quiet=True, run_fn=busy_run, tasks=tasks)
    assert marker.exists()
    assert res.ok == 3 and res.failed == 0


def test_a_kept_run_directory_is_replaced_when_its_task_runs_again(make_sweep, tmp_path):
    """keep_runs: a retried or resumed task owns DIR/runs/<run_id> and replaces an earlier attempt's files
    (a Run refuses a used directory anywhere else)."""
    from nodesim.sweep.tasks import run_point

    spec = load_sweep(make_sweep("keep_runs = true\n" + SMALL))
    task = spec.plan(tmp_path / "campaign")[0]
    first = run_point(task)
    (Path(task.keep_dir) / "summary.json").write_text("{}")  # an earlier, different attempt
    assert run_point(task) == first
    assert json.loads((Path(task.keep_dir) / "summary.json").read_text())["scenario"] == "short"


def test_cli_sweep_with_a_failed_run_exits_1_and_still_writes_the_table(make_sweep, tmp_path, capsys):
    from nodesim.cli.main import main

    sweep = make_sweep('[[axis]]\nkey = "simulation.realizations"\nvalues = [1, 0]\n')
    out = tmp_path / "c"
    assert main(["sweep", str(sweep), "--out", str(out), "--workers", "1", "--quiet"]) == 1
    assert "1 of 2 runs failed" in capsys.readouterr().err
    df = pd.read_parquet(out / "results.parquet")
    assert sorted(df["status"]) == ["failed", "ok"]


def test_cli_resume_of_a_missing_campaign_is_an_error(make_sweep, tmp_path, capsys):
    from nodesim.cli.main import main

    ok = make_sweep("seeds = 1\n")
    missing = tmp_path / "never-started"
    assert main(["sweep", str(ok), "--out", str(missing), "--resume"]) == 2
    assert "no campaign to resume" in capsys.readouterr().err
    assert not missing.exists()
