"""``[output]``: which timeseries rows a run keeps and in which format it writes them (issue 20)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import nodesim
from nodesim.chain.run_tables import TIMESERIES_COLUMNS
from nodesim.cli.main import main
from nodesim.errors import ScenarioError
from nodesim.scenario.schema import Scenario

REPO = Path(__file__).resolve().parents[3]
SMALL = {"chain.nodes": 5, "simulation.duration_s": 120.0, "metrics.window_start_s": 50.0,
         "metrics.window_end_s": 120.0}


@pytest.fixture(scope="module")
def all_rows():
    return nodesim.simulate(REPO / "scenarios" / "lab" / "continuous.toml", **SMALL).timeseries


@pytest.mark.parametrize("choice, nodes, step", [
    ("all", [1, 2, 3, 4, 5], 1), ("bottom", [5], 1), ("every:2", [1, 3, 5], 1), ("every:3", [1, 4, 5], 1),
    ("decimate:4", [1, 2, 3, 4, 5], 4), ("none", [], 1)])
def test_each_choice_keeps_its_nodes_and_ticks(all_rows, choice, nodes, step):
    run = nodesim.simulate(REPO / "scenarios" / "lab" / "continuous.toml", **SMALL, **{"output.timeseries": choice})
    got = run.timeseries
    assert list(got.columns) == list(TIMESERIES_COLUMNS)
    assert sorted(set(got["node"])) == nodes
    want = pd.concat([all_rows[all_rows["node"] == n].iloc[::step] for n in nodes]) if nodes else all_rows.iloc[:0]
    pd.testing.assert_frame_equal(got.reset_index(drop=True), want.reset_index(drop=True), check_dtype=False)
    # the metrics do not come from the kept rows
    assert run.summary["rms_yaw_error_deg"] == nodesim.simulate(REPO / "scenarios" / "lab" / "continuous.toml",
                                                                **SMALL).summary["rms_yaw_error_deg"]


def test_timeseries_columns_are_the_declared_ones(all_rows):
    assert list(all_rows.columns) == list(TIMESERIES_COLUMNS)


@pytest.mark.parametrize("bad", ["some", "every:0", "decimate:", "every:-2", "bottom,all", ""])
def test_a_bad_choice_names_the_key_and_the_choices(bad):
    with pytest.raises(ScenarioError, match=r"output.timeseries.*allowed all, bottom, every:N, decimate:K, none"):
        Scenario.model_validate({}).with_overrides(**{"output.timeseries": bad})
    with pytest.raises(ScenarioError, match="output.format"):
        Scenario.model_validate({}).with_overrides(**{"output.format": "hdf5"})


def test_parquet_is_the_default_csv_on_request_and_both_load_back(tmp_path, capsys):
    lab = REPO / "scenarios" / "lab" / "continuous.toml"
    assert main(["run", str(lab), "--out", str(tmp_path / "pq"), "--quiet"]) == 0
    assert main(["run", str(lab), "--out", str(tmp_path / "csv"), "--quiet", "--csv"]) == 0
    capsys.readouterr()
    assert (tmp_path / "pq" / "timeseries.parquet").is_file() and not (tmp_path / "pq" / "timeseries.csv").exists()
    assert (tmp_path / "csv" / "timeseries.csv").is_file() and not (tmp_path / "csv" / "timeseries.parquet").exists()
    assert pd.read_parquet(tmp_path / "pq" / "timeseries.parquet").shape[0] > 1000
    a, b = nodesim.load_run(tmp_path / "pq"), nodesim.load_run(tmp_path / "csv")
    pd.testing.assert_frame_equal(a.timeseries, b.timeseries, check_dtype=False)


def test_none_writes_an_empty_table_and_no_plot(tmp_path):
    run = nodesim.simulate(REPO / "scenarios" / "lab" / "continuous.toml", **SMALL, **{"output.timeseries": "none"})
    out = run.save(tmp_path / "run")
    names = {p.name for p in out.iterdir()}
    assert "yaw_error.png" not in names and {"summary.json", "hops.csv", "timeseries.parquet"} <= names
    loaded = nodesim.load_run(out)
    assert len(loaded.timeseries) == 0 and list(loaded.timeseries.columns) == list(TIMESERIES_COLUMNS)
    assert np.isfinite(loaded.summary["rms_yaw_error_deg"])


def test_an_unreadable_parquet_file_is_a_clear_error(tmp_path):
    run = nodesim.simulate(REPO / "scenarios" / "lab" / "continuous.toml", **SMALL)
    out = run.save(tmp_path / "run", plots=False)
    (out / "timeseries.parquet").write_bytes(b"not parquet")
    with pytest.raises(nodesim.NodesimError, match="timeseries.parquet: unreadable Parquet"):
        nodesim.load_run(out)
