"""A SIGKILL of `nodesim sweep` (the driver alone, not its group) leaves no process and no temporary
directory behind (nodesim.sweep.watchdog)."""

import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="the watchdog reads /proc (Linux)")


def _children(pid: int) -> set[int]:
    out = set()
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                stat = Path(f"/proc/{entry}/stat").read_text()
            except OSError:
                continue
            if int(stat.rsplit(")", 1)[1].split()[1]) == pid:
                out.add(int(entry))
    return out


def _descendants(pid: int) -> set[int]:
    found, todo = set(), [pid]
    while todo:
        for child in _children(todo.pop()):
            if child not in found:
                found.add(child)
                todo.append(child)
    return found


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"  # a zombie has exited (its parent, maybe PID 1, has not reaped it yet)


def test_sigkill_of_the_sweep_driver_leaves_no_process_and_no_temp_dir(make_sweep, tmp_path):
    sweep = make_sweep("seeds = 40\n")
    # a short TMPDIR: multiprocessing's fork server binds a socket under it, whose path must fit in 108 bytes (pytest's
    # tmp_path under pytest-xdist, /tmp/pytest-of-<user>/pytest-<n>/popen-gw<i>/<test name>/..., may not)
    scratch = Path(tempfile.mkdtemp(prefix="nodesim-wd-"))
    env = {**os.environ, "TMPDIR": str(scratch)}
    env.pop("NODESIM_POOL_TOKEN", None)
    cmd = [sys.executable, "-m", "nodesim.cli.main", "sweep", str(sweep), "--out", str(tmp_path / "c"),
           "--workers", "2", "--quiet"]
    proc = subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, start_new_session=True)
    try:
        deadline = time.monotonic() + 120
        pool = set()
        while time.monotonic() < deadline:
            assert proc.poll() is None, proc.stderr.read().decode()
            pool = _descendants(proc.pid)
            if len(list((tmp_path / "c" / "parts").glob("part-*.parquet"))) >= 1 and len(pool) >= 4:
                break  # watchdog, fork server, resource tracker and at least one worker; runs finishing
            time.sleep(0.05)
        assert len(pool) >= 4, pool
        assert any(scratch.iterdir()), "multiprocessing's temporary directory is under TMPDIR"
        proc.send_signal(signal.SIGKILL)  # the driver only: its pool is not in the signal's way
        proc.wait()
        deadline = time.monotonic() + 20
        while time.monotonic() < deadline and (any(_alive(p) for p in pool) or any(scratch.iterdir())):
            time.sleep(0.1)
        assert [p for p in pool if _alive(p)] == []
        assert list(scratch.iterdir()) == []
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
        shutil.rmtree(scratch, ignore_errors=True)


def test_a_dask_localcluster_leaves_nothing_in_the_temp_dir(make_sweep, tmp_path, monkeypatch):
    """The LocalCluster's scratch space (dask's dask-scratch-space and the workers' directories) lives in a
    nodesim-dask-* directory that close() removes."""
    import tempfile

    from nodesim.sweep.campaign import run_campaign
    from nodesim.sweep.executors import DaskExecutor
    from nodesim.sweep.spec import load_sweep

    pytest.importorskip("distributed")
    scratch = tmp_path / "tmp"
    scratch.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(scratch))
    spec = load_sweep(make_sweep("seeds = 1\n"))
    with DaskExecutor(workers=1, processes=False) as ex:
        assert [p.name.startswith("nodesim-dask-") for p in scratch.iterdir()] == [True]
        res = run_campaign(spec, tmp_path / "c", ex, quiet=True)
    assert res.ok == 1
    assert list(scratch.iterdir()) == []
