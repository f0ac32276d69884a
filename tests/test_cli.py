"""The console script: help texts, pending commands, dry run, run directory, validate and bench contracts."""

import json
import subprocess
import sys

import pytest

from nodesim.cli.main import COMMANDS, main

OPTION_OF = {
    "run": "--dry-run",
    "link": "--sweep",
    "uncertainty": "--tool",
    "calibrate": "--method",
    "sweep": "--executor",
    "optimize": "--resume",
    "replay": "--firmware",
    "firmware": "export-config",
    "report": "RUN_OR_CAMPAIGN_DIR",
    "validate": "--json",
    "bench": "--json",
    "export": "--to",
    "scenario": "--schema",
}


def test_top_level_help_lists_every_command(capsys):
    with pytest.raises(SystemExit) as info:
        main(["--help"])
    assert info.value.code == 0
    out = capsys.readouterr().out
    for name in COMMANDS:
        assert name in out


@pytest.mark.parametrize("command", COMMANDS)
def test_each_command_help_describes_its_options(command, capsys):
    with pytest.raises(SystemExit) as info:
        main([command, "--help"])
    assert info.value.code == 0
    assert OPTION_OF[command] in capsys.readouterr().out


def test_console_script_is_installed_and_exits_2_on_user_error(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[chain]\nnodes = 0\n")
    proc = subprocess.run(
        [sys.executable, "-m", "nodesim.cli.main", "run", str(bad)], capture_output=True, text=True, check=False
    )
    assert proc.returncode == 2
    assert proc.stderr.count("\n") == 1 and "chain.nodes" in proc.stderr


def test_dry_run_prints_resolved_scenario_and_writes_nothing(lab_toml, tmp_path, capsys):
    out = tmp_path / "dry"
    assert main(["run", str(lab_toml), "--dry-run", "--out", str(out), "--seed", "7"]) == 0
    resolved = json.loads(capsys.readouterr().out)
    assert resolved["seed"] == 7
    assert resolved["chain"]["firmware_rate_hz"] == 1.9
    assert resolved["filter"]["bias_tau_s"] == 500.0  # a default filled in
    assert not out.exists()


def test_run_writes_the_run_directory(lab_toml, tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["run", str(lab_toml), "--out", str(out), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    for key in ("rms_azimuth_error_deg", "rms_inclination_error_deg", "bias_convergence_time_s"):
        assert isinstance(summary[key], float)
    assert set(summary["timing"]) == {"simulation_s", "wall_s", "save_s"}
    files = {p.name for p in out.iterdir()}
    assert {"manifest.json", "summary.json", "realizations.csv", "timeseries.parquet", "yaw_error.png"} <= files
    assert not [n for n in files if n.endswith(".tmp")]
    manifest = json.loads((out / "manifest.json").read_text())
    for key in ("nodesim_version", "git_commit", "scenario_sha256", "scenario", "root_seed", "wall_time_s", "host"):
        assert key in manifest
    assert manifest["scenario"]["name"] == "lab-continuous"


def test_validate_json_contract(capsys):
    assert main(["validate", "--json"]) == 0
    checks = json.loads(capsys.readouterr().out)
    assert checks, "at least one check"
    for c in checks:
        assert {"name", "source", "ours", "published", "tolerance", "ok", "kind"} <= set(c)
        assert isinstance(c["ok"], bool)
        assert c["kind"] in ("reproduction", "self_consistency", "hypothesis")
        assert "thesis" in c["source"] or "ISCWSA" in c["source"] or "paper" in c["source"]


def test_bench_json_contract(tmp_path, capsys):
    bench_dir = tmp_path / "benchmarks"
    bench_dir.mkdir()
    (bench_dir / "bench_toy.py").write_text(
        "from nodesim.bench import best_time_s\n"
        "def toy():\n"
        "    t_base = best_time_s(lambda: sum(range(1000)))\n"
        "    t_ours = best_time_s(lambda: sum(range(10)))\n"
        "    return {'toy_speedup_vs_sum1000': t_base / t_ours, 'toy_ours_s': t_ours}\n"
        "BENCHMARKS = [toy]\n"
    )
    out_file = tmp_path / "latest.json"
    assert main(["bench", "--json", "--dir", str(bench_dir), "--write", str(out_file)]) == 0
    figures = json.loads(capsys.readouterr().out)
    assert figures["toy_speedup_vs_sum1000"] > 0
    assert json.loads(out_file.read_text()) == figures


def test_best_times_interleave_the_sides_and_keep_each_ones_best(monkeypatch):
    """best_times_s calls its functions in turn, repeat rounds, and returns each one's fastest call: a host that is
    slow for a while slows every side's calls alike (a fake clock: each call takes the time its round says)."""
    import nodesim.bench as bench

    calls, now = [], [0.0]
    round_s = {0: 5.0, 1: 1.0, 2: 3.0}  # the host's speed by round: round 1 is fast

    def side(name: str, factor: float):
        def fn():
            calls.append(name)
            now[0] += factor * round_s[sum(c == "a" for c in calls) - 1]
        return fn

    monkeypatch.setattr(bench.time, "perf_counter", lambda: now[0])
    best = bench.best_times_s([side("a", 1.0), side("b", 10.0)], repeat=3)
    assert calls == ["a", "b"] * 3
    assert best == [1.0, 10.0]


def test_bench_missing_folder_is_a_clear_error(tmp_path, capsys):
    assert main(["bench", "--dir", str(tmp_path / "none")]) == 2
    assert "benchmark folder" in capsys.readouterr().err


def test_bench_only_without_a_match_exits_2(tmp_path, capsys):
    bench_dir = tmp_path / "benchmarks"
    bench_dir.mkdir()
    (bench_dir / "bench_toy.py").write_text("def toy():\n    return {'toy_s': 1.0}\nBENCHMARKS = [toy]\n")
    assert main(["bench", "--dir", str(bench_dir), "--only", "NO_MATCH"]) == 2
    assert "'NO_MATCH'" in capsys.readouterr().err
    assert main(["bench", "--dir", str(bench_dir), "--only", "toy"]) == 0


def test_bench_from_an_installed_wheel_says_what_it_needs(tmp_path, capsys, monkeypatch):
    """Outside a source checkout (no ./benchmarks, none beside the package) the error names the checkout and extra."""
    import nodesim.bench as bench

    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(bench, "__file__", str(tmp_path / "site-packages" / "nodesim" / "bench.py"))
    assert main(["bench"]) == 2
    err = capsys.readouterr().err
    assert "source checkout" in err and "[bench]" in err


def test_the_console_script_returns_mains_status_and_leaves_the_objects_frozen(tmp_path, capsys):
    """``nodesim`` is :func:`console`: main's exit status, then the objects frozen so that the interpreter's exit
    does not collect them all once more (the process ends next)."""
    import gc
    import tomllib
    from pathlib import Path

    from nodesim.cli.main import console

    scripts = tomllib.loads((Path(__file__).parents[1] / "pyproject.toml").read_text())["project"]["scripts"]
    assert scripts["nodesim"] == "nodesim.cli.main:console"
    assert gc.get_freeze_count() == 0
    try:
        assert console(["run", str(tmp_path / "missing.toml")]) == 2
        assert gc.get_freeze_count() > 0
    finally:
        gc.unfreeze()
    assert "missing.toml" in capsys.readouterr().err
