"""The Python API (nodesim.simulate, Run, load_run): scenario sources, overrides, tables, plots, save/load."""

import re
import subprocess
import sys
import tomllib
from pathlib import Path

import pandas as pd
import pytest
from matplotlib.figure import Figure

import nodesim
from nodesim.cli.main import main

REPO = Path(__file__).resolve().parents[2]
LAB = REPO / "scenarios" / "lab" / "continuous.toml"
FIELD = REPO / "scenarios" / "field" / "drilling_10_tubes.toml"
SHORT = {"simulation.duration_s": 300.0, "metrics.window_start_s": 200.0, "metrics.window_end_s": 300.0}


@pytest.fixture(scope="module")
def lab_run():
    return nodesim.simulate(LAB, seed=5, realizations=3, **{"chain.nodes": 2})


@pytest.fixture(scope="module")
def drilling_run():
    return nodesim.simulate(FIELD, seed=5, **{"chain.nodes": 3, "simulation.realizations": 2})


def test_simulate_writes_nothing_and_returns_tables_as_dataframes(lab_run, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    run = nodesim.simulate(LAB, seed=5, **{"chain.nodes": 2, **SHORT})
    assert list(tmp_path.iterdir()) == []
    assert isinstance(run.timeseries, pd.DataFrame) and set(run.timeseries["node"]) == {1, 2}
    assert len(lab_run.realizations) == 3 and lab_run.summary["realizations"] == 3
    assert lab_run.surveys is None and lab_run.ground_survey is None
    assert "Run(scenario='lab-continuous'" in repr(lab_run) and "nodes=2" in repr(lab_run)


@pytest.fixture(scope="module")
def short_reference():
    return nodesim.simulate(LAB, seed=3, **SHORT)


@pytest.mark.parametrize("kind", ["path", "str", "toml", "dict", "scenario"])
def test_every_kind_of_scenario_source_gives_the_same_run(kind, short_reference):
    text = LAB.read_text()
    source = {"path": LAB, "str": str(LAB), "toml": text, "dict": tomllib.loads(text),
              "scenario": nodesim.Scenario.model_validate(tomllib.loads(text))}[kind]
    run = nodesim.simulate(source, seed=3, **SHORT)
    reference = short_reference
    assert run.timeseries.equals(reference.timeseries)
    assert {k: v for k, v in run.summary.items() if k != "timing"} == \
        {k: v for k, v in reference.summary.items() if k != "timing"}


@pytest.mark.parametrize("overrides, message", [
    ({"chain.nodez": 3}, "chain.nodez: unknown key"),
    ({"chain.nodes": 0}, "chain.nodes: Input should be greater than or equal to 1"),
    ({"seed.x": 1}, "seed.x: seed is a value, not a section"),
])
def test_bad_overrides_are_clear_errors(overrides, message):
    with pytest.raises(nodesim.NodesimError, match=re.escape(message)):
        nodesim.simulate(LAB, **overrides)


def test_bad_scenario_sources_are_clear_errors(tmp_path):
    with pytest.raises(nodesim.NodesimError, match="cannot read scenario file"):
        nodesim.simulate(tmp_path / "missing.toml")
    with pytest.raises(nodesim.NodesimError, match="not valid TOML"):
        nodesim.simulate("[chain\nnodes = 2\n")
    with pytest.raises(nodesim.NodesimError, match="expected a path, a TOML string, a dict or a Scenario"):
        nodesim.simulate(42)


def test_save_writes_the_run_directory_and_load_run_reads_it_back_equal(drilling_run, tmp_path):
    out = drilling_run.save(tmp_path / "run")
    names = sorted(p.name for p in out.iterdir())
    assert names == ["ground_survey.csv", "hops.csv", "manifest.json", "realizations.csv", "summary.json",
                     "surveys.csv", "timeseries.parquet", "yaw_error.png"]
    loaded = nodesim.load_run(out)
    assert loaded == drilling_run
    for name in ("timeseries", "realizations", "hops", "surveys", "ground_survey"):
        on_disk = pd.read_parquet(out / "timeseries.parquet") if name == "timeseries" else pd.read_csv(out / f"{name}.csv")
        assert list(on_disk.columns) == list(getattr(drilling_run, name).columns)
        pd.testing.assert_frame_equal(getattr(loaded, name), getattr(drilling_run, name), check_dtype=False)
    assert loaded.chain is None and drilling_run.chain is not None
    # a loaded run saves the same tables again, byte for byte
    again = loaded.save(tmp_path / "again")
    for name in names:
        if name.endswith((".csv", ".png")):
            assert (again / name).read_bytes() == (out / name).read_bytes(), name


def test_equality_sees_a_changed_value(lab_run, tmp_path):
    out = lab_run.save(tmp_path / "run", plots=False)
    loaded = nodesim.load_run(out)
    assert loaded == lab_run
    loaded._tables["timeseries"]["yaw_est_deg"] = loaded._tables["timeseries"]["yaw_est_deg"] + 1e-12
    assert loaded != lab_run


def test_save_refuses_a_used_directory_and_loses_nothing(lab_run, tmp_path):
    out = lab_run.save(tmp_path / "run", plots=False)
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    with pytest.raises(nodesim.NodesimError, match="already holds a run"):
        lab_run.save(out)
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before


def test_load_run_of_a_directory_that_is_no_run_is_a_clear_error(tmp_path):
    with pytest.raises(nodesim.NodesimError, match=r"not a run directory \(no summary.json, manifest.json\)"):
        nodesim.load_run(tmp_path)


def test_plots_are_figures(lab_run, drilling_run):
    assert isinstance(lab_run.plot_yaw(), Figure)
    fig = drilling_run.plot_wellpath(tool="mpu6500_filtered", sigma="2")
    assert isinstance(fig, Figure) and len(fig.axes) == 2
    fig = drilling_run.plot_wellpath(tool="mpu6500_filtered", sigma="2", propagation="thesis")
    assert isinstance(fig, Figure) and len(fig.axes) == 2
    with pytest.raises(nodesim.NodesimError, match="propagation 'x' unknown; allowed: iscwsa, thesis"):
        drilling_run.plot_wellpath(propagation="x")
    with pytest.raises(nodesim.NodesimError, match="no surveys to plot"):
        lab_run.plot_wellpath()


def test_nodesim_run_is_simulate_then_save(tmp_path, capsys):
    """The command line writes the same files, byte for byte, as the API (apart from timing and host facts)."""
    assert main(["run", str(LAB), "--out", str(tmp_path / "cli"), "--seed", "9", "--quiet"]) == 0
    capsys.readouterr()
    api = nodesim.simulate(LAB, seed=9).save(tmp_path / "api")
    for name in ("timeseries.parquet", "realizations.csv", "hops.csv", "yaw_error.png"):
        assert (tmp_path / "cli" / name).read_bytes() == (api / name).read_bytes(), name
    cli_run = nodesim.load_run(tmp_path / "cli")
    assert cli_run.manifest["scenario_sha256"] == nodesim.load_run(api).manifest["scenario_sha256"]
    strip = lambda s: {k: v for k, v in s.items() if k != "timing"}  # noqa: E731
    assert strip(cli_run.summary) == strip(nodesim.load_run(api).summary)


def test_the_readme_example_runs(tmp_path):
    """The README's "Python API" block, executed as written from a directory with the scenarios."""
    readme = (REPO / "README.md").read_text()
    block = readme.split("## Python API", 1)[1].split("```python\n", 1)[1].split("```", 1)[0]
    (tmp_path / "scenarios").symlink_to(REPO / "scenarios")
    proc = subprocess.run([sys.executable, "-c", block], cwd=tmp_path, capture_output=True, text=True, check=False)
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "yaw.png").stat().st_size > 0 and (tmp_path / "runs" / "api-demo" / "summary.json").exists()
    assert "Run(scenario='lab-continuous'" in proc.stdout


def test_importing_nodesim_is_light():
    code = ("import sys, nodesim; heavy = [m for m in ('numba', 'pandas', 'matplotlib', 'simpy', 'pydantic', "
            "'scipy') if m in sys.modules]; print(heavy)")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert proc.stdout.strip() == "[]"


def test_nodesim_run_refuses_a_used_directory_before_simulating(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["run", str(LAB), "--out", str(out), "--quiet"]) == 0
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    capsys.readouterr()
    assert main(["run", str(LAB), "--out", str(out), "--quiet", "--seed", "1"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "already holds a run" in err
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before
