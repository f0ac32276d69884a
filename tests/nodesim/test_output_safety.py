"""Output safety (issue 22): a used --out is refused unless --force, which swaps a fresh directory in;
files are created with the process umask."""

import os
import stat
from pathlib import Path

import pytest

import nodesim
from nodesim.cli.main import main
from nodesim.errors import NodesimError
from nodesim.io import rundir

REPO = Path(__file__).resolve().parents[2]
LAB = REPO / "scenarios" / "lab" / "continuous.toml"
SHORT = ["--seed", "3"]


@pytest.fixture
def umask022():
    old = os.umask(0o022)
    yield
    os.umask(old)


def _snapshot(d: Path) -> dict:
    return {p.name: p.read_bytes() for p in d.iterdir()}


def _mode(p: Path) -> int:
    return stat.S_IMODE(p.stat().st_mode)


def test_atomic_writes_honour_the_umask(tmp_path):
    old = os.umask(0o022)
    try:
        rundir.write_json(tmp_path / "a.json", {"x": 1})
        rundir.atomic_write_with(tmp_path / "b.bin", lambda p: p.write_bytes(b"1"))
        assert _mode(tmp_path / "a.json") == 0o644 and _mode(tmp_path / "b.bin") == 0o644
        os.umask(0o077)
        rundir.write_json(tmp_path / "c.json", {"x": 1})
        assert _mode(tmp_path / "c.json") == 0o600
        os.umask(0o002)
        assert rundir.file_mode() == 0o664 and rundir.dir_mode() == 0o775
    finally:
        os.umask(old)


def test_run_files_are_readable_by_others_under_umask_022(tmp_path, capsys, umask022):
    out = tmp_path / "run"
    assert main(["run", str(LAB), "--out", str(out), "--quiet", *SHORT]) == 0
    files = list(out.iterdir())
    assert files and all(_mode(p) == 0o644 for p in files), {p.name: oct(_mode(p)) for p in files}
    assert _mode(out) == 0o755


def test_a_used_directory_is_refused_and_force_leaves_only_the_new_run(tmp_path, capsys, umask022):
    out = tmp_path / "run"
    assert main(["run", str(LAB), "--out", str(out), "--quiet", *SHORT]) == 0
    (out / "surveys.csv").write_text("stale drilling survey\n")  # what an earlier drilling run left
    before = _snapshot(out)
    capsys.readouterr()
    assert main(["run", str(LAB), "--out", str(out), "--quiet", "--seed", "4"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "already holds a run" in err and "--force" in err
    assert _snapshot(out) == before
    assert main(["run", str(LAB), "--out", str(out), "--quiet", "--seed", "4", "--force"]) == 0
    assert "surveys.csv" not in {p.name for p in out.iterdir()}
    assert nodesim.load_run(out).manifest["root_seed"] == 4
    fresh = tmp_path / "fresh"
    assert main(["run", str(LAB), "--out", str(fresh), "--quiet", "--seed", "4"]) == 0
    assert {p.name for p in out.iterdir()} == {p.name for p in fresh.iterdir()}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fresh", "run"]  # no stage left beside them
    assert _mode(out) == 0o755


def test_a_directory_with_foreign_files_is_refused(tmp_path, capsys):
    out = tmp_path / "notes"
    out.mkdir()
    (out / "mine.txt").write_text("keep me")
    assert main(["run", str(LAB), "--out", str(out), "--quiet"]) == 2
    assert "is not empty (mine.txt)" in capsys.readouterr().err
    assert (out / "mine.txt").read_text() == "keep me"
    empty = tmp_path / "empty"
    empty.mkdir()
    rundir.check_empty_dir(empty)  # an empty directory is fine
    with pytest.raises(NodesimError, match="not a directory"):
        rundir.check_empty_dir(out / "mine.txt")


def test_replace_dir_keeps_the_old_directory_when_writing_fails(tmp_path):
    old = tmp_path / "d"
    old.mkdir()
    (old / "x").write_text("old")
    with pytest.raises(RuntimeError):
        with rundir.replace_dir(old) as stage:
            (stage / "y").write_text("new")
            raise RuntimeError("interrupted")
    assert _snapshot(old) == {"x": b"old"} and [p.name for p in tmp_path.iterdir()] == ["d"]
    with rundir.replace_dir(old) as stage:
        (stage / "y").write_text("new")
    assert _snapshot(old) == {"y": b"new"} and [p.name for p in tmp_path.iterdir()] == ["d"]
    with rundir.replace_dir(tmp_path / "new") as stage:  # a missing directory is simply created
        (stage / "z").write_text("z")
    assert _snapshot(tmp_path / "new") == {"z": b"z"}


def test_replace_dir_without_renameat2_swaps_by_two_renames(tmp_path, monkeypatch):
    monkeypatch.setattr(rundir, "_exchange", lambda a, b: False)
    old = tmp_path / "d"
    old.mkdir()
    (old / "x").write_text("old")
    with rundir.replace_dir(old) as stage:
        (stage / "y").write_text("new")
    assert _snapshot(old) == {"y": b"new"} and [p.name for p in tmp_path.iterdir()] == ["d"]


def test_the_terminal_summary_shows_the_headline_and_the_bottom_node_unless_all():
    from nodesim.cli.run_command import shown_keys

    summary = {"rms_azimuth_error_deg": 1.0, "nodes": 3, "timing": {}, "delivery_ratio": 1.0}
    for n in (1, 2, 3):
        summary[f"node{n}_rms_azimuth_error_deg"] = float(n)
    for h in (1, 2, 3):
        summary[f"hop{h}_latency_s"] = 0.01
    assert shown_keys(summary) == ["rms_azimuth_error_deg", "nodes", "delivery_ratio", "node3_rms_azimuth_error_deg"]
    assert len(shown_keys(summary, every_key=True)) == len(summary) - 1
