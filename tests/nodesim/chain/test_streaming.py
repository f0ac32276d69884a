"""Streamed runs (nodesim.chain.streaming, issue 20): the run directory `nodesim run` writes while it simulates,
node by node, is the one the whole-run path writes; the run keeps no per-tick records; a failure leaves nothing."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from nodesim.api import load_run, simulate_scenario
from nodesim.chain.network import simulate_chain
from nodesim.chain.streaming import NodeStream, TimeseriesFile
from nodesim.chain.yaw_plot import TRACE_POINTS, node_trace
from nodesim.cli.main import main
from nodesim.motion.chain_motion import build_motion
from nodesim.scenario.schema import load_scenario

REPO = Path(__file__).resolve().parents[3]
FIELD = REPO / "scenarios" / "field" / "drilling_10_tubes.toml"
LAB = REPO / "scenarios" / "lab" / "continuous.toml"


def _scenario(path: Path, **overrides):
    return load_scenario(path)[0].with_overrides(**overrides)


def _same_dirs(a: Path, b: Path) -> None:
    """Every table of two run directories value for value, the summaries except their timing."""
    x, y = load_run(a), load_run(b)
    x.summary.pop("timing"), y.summary.pop("timing")
    assert x == y  # scenario, summary and every table, value for value (Run.__eq__)
    assert (a / "yaw_error.png").is_file() == (b / "yaw_error.png").is_file()


@pytest.mark.parametrize("path, overrides", [
    (FIELD, {"chain.nodes": 6, "simulation.realizations": 2}),  # fixed firmware, survey frames, compiled engine
    (FIELD, {"chain.nodes": 4, "simulation.realizations": 2, "simulation.engine": "event",
             "output.timeseries": "every:2"}),  # the SimPy engine streams after its run
    (LAB, {"chain.nodes": 5, "simulation.duration_s": 300.0, "metrics.window_start_s": 200.0,
           "metrics.window_end_s": 300.0, "output.timeseries": "decimate:3", "output.format": "csv"}),
    (LAB, {"chain.nodes": 3, "simulation.duration_s": 300.0, "metrics.window_start_s": 200.0,
           "metrics.window_end_s": 300.0, "output.timeseries": "none"}),
])
def test_a_streamed_run_writes_the_directory_of_the_whole_run(tmp_path, path, overrides):
    scenario = _scenario(path, **overrides)
    whole = simulate_scenario(scenario, None)
    whole.save(tmp_path / "whole")
    stage = tmp_path / "stage"
    streamed = simulate_scenario(scenario, None, stream_to=stage)
    assert streamed.chain.nodes == () and len(streamed.chain.summaries) == scenario.chain.nodes
    streamed.save(tmp_path / "streamed")
    assert not any(stage.iterdir())  # the table was moved out of the stage, not copied
    _same_dirs(tmp_path / "whole", tmp_path / "streamed")
    if scenario.output.format == "csv":  # the same bytes as write_csv
        assert (tmp_path / "whole" / "timeseries.csv").read_bytes() == \
            (tmp_path / "streamed" / "timeseries.csv").read_bytes()


def test_nodesim_run_streams_and_leaves_no_stage(tmp_path):
    toml = tmp_path / "s.toml"
    toml.write_text(FIELD.read_text().replace("realizations = 4", "realizations = 1"))
    assert main(["run", str(toml), "--out", str(tmp_path / "run"), "--quiet", "--json"]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run", "s.toml"]  # no .run.stream-* left
    assert (tmp_path / "run" / "timeseries.parquet").is_file()


def test_a_run_that_fails_while_streaming_leaves_nothing(tmp_path, monkeypatch, capsys):
    """The simulation raises half way (after some nodes were streamed): no run directory, no stage, no table."""
    import nodesim.chain.network as network

    real = network.simulate_chain

    def failing(scenario, progress=None, on_node=None):
        def half(run, surveys):
            if run.node_id == 3:
                raise RuntimeError("disk on fire")
            return on_node(run, surveys)
        return real(scenario, progress, on_node=half)

    monkeypatch.setattr(network, "simulate_chain", failing)
    toml = tmp_path / "s.toml"
    toml.write_text(FIELD.read_text().replace("realizations = 4", "realizations = 1"))
    with pytest.raises(RuntimeError, match="disk on fire"):
        main(["run", str(toml), "--out", str(tmp_path / "run"), "--quiet"])
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.toml"]


def test_the_table_file_is_renamed_into_place_only_when_closed(tmp_path):
    cols = {"node": np.array([1, 1]), "t_s": np.array([0.5, 1.0])}
    from nodesim.chain.run_tables import TIMESERIES_COLUMNS

    block = {k: cols.get(k, np.zeros(2)) for k in TIMESERIES_COLUMNS}
    for fmt in ("parquet", "csv"):
        f = TimeseriesFile(tmp_path / f"t.{fmt}", fmt)
        f.write(block)
        assert not (tmp_path / f"t.{fmt}").exists()
        f.abort()
        assert list(tmp_path.iterdir()) == []
        f = TimeseriesFile(tmp_path / f"t.{fmt}", fmt)
        f.write(block)
        f.write(block)
        f.close()
        assert f.rows == 4 and [p.name for p in tmp_path.iterdir()] == [f"t.{fmt}"]
        (tmp_path / f"t.{fmt}").unlink()


def test_the_parquet_table_encodes_each_column_as_its_options_say(tmp_path):
    """A dictionary for the flag in DICTIONARY_COLUMNS, plain for PLAIN_COLUMNS, delta for the other integers,
    byte-stream split for the other floats, each at its zstd level; the values read back are the ones written."""
    import pyarrow.parquet as pq
    from nodesim.chain.run_tables import TIMESERIES_COLUMNS
    from nodesim.chain.streaming import DICTIONARY_COLUMNS, FAST_ZSTD_COLUMNS, INTEGER_COLUMNS, PLAIN_COLUMNS

    rng = np.random.default_rng(4)
    n = 5000
    block = {k: rng.normal(size=n) for k in TIMESERIES_COLUMNS}
    block.update(node=np.full(n, 3), running=rng.integers(0, 2, n), update=rng.integers(0, 2, n),
                 update_age_s=rng.choice([np.nan, 0.004, 0.009, 0.5], n), yaw_sigma_deg=rng.choice([0.1, 0.2], n))
    f = TimeseriesFile(tmp_path / "t.parquet", "parquet")
    f.write(block)
    f.close()
    meta = pq.ParquetFile(tmp_path / "t.parquet").metadata.row_group(0)
    for i, k in enumerate(TIMESERIES_COLUMNS):
        encodings = set(meta.column(i).encodings)
        want = ("RLE_DICTIONARY" if k in DICTIONARY_COLUMNS else "PLAIN" if k in PLAIN_COLUMNS else
                "DELTA_BINARY_PACKED" if k in INTEGER_COLUMNS else "BYTE_STREAM_SPLIT")
        assert want in encodings and meta.column(i).compression == "ZSTD", (k, encodings)
        if k in PLAIN_COLUMNS:
            assert encodings <= {"PLAIN", "RLE"}, (k, encodings)  # no dictionary page
    assert set(FAST_ZSTD_COLUMNS) <= set(TIMESERIES_COLUMNS) - set(INTEGER_COLUMNS)
    table = pq.read_table(tmp_path / "t.parquet")
    for k in TIMESERIES_COLUMNS:
        assert np.array_equal(table.column(k).to_numpy(), block[k], equal_nan=k not in INTEGER_COLUMNS), k


@pytest.mark.parametrize("threads", ["1", "2"])
def test_blocks_gather_into_row_groups_with_the_bytes_of_their_concatenation(tmp_path, monkeypatch, threads):
    """Blocks are written as chunks of one row group once ROW_GROUP_ROWS rows are buffered (no concatenation copy):
    the row groups hold whole blocks, the values read back are the blocks', and the file is byte for byte the one
    written from each row group's blocks concatenated."""
    import pyarrow.parquet as pq
    from nodesim.chain.run_tables import TIMESERIES_COLUMNS
    from nodesim.chain.streaming import INTEGER_COLUMNS, PARQUET_OPTIONS, timeseries_table

    monkeypatch.setenv("NODESIM_THREADS", threads)
    monkeypatch.setattr(TimeseriesFile, "ROW_GROUP_ROWS", 1000)
    rng = np.random.default_rng(7)
    blocks = []
    for n in (400, 700, 300, 900, 250):  # row groups: 400 + 700, 300 + 900, 250 (at close)
        block = {k: rng.normal(size=n) for k in TIMESERIES_COLUMNS}
        block.update(node=np.full(n, len(blocks)), running=rng.integers(0, 2, n), update=rng.integers(0, 2, n),
                     update_age_s=rng.choice([np.nan, 0.004, 0.5], n), yaw_sigma_deg=rng.choice([0.1, 0.2], n))
        blocks.append(block)
    f = TimeseriesFile(tmp_path / "t.parquet", "parquet")
    for block in blocks:
        f.write(block)
    f.close()
    got = pq.ParquetFile(tmp_path / "t.parquet")
    assert [got.metadata.row_group(i).num_rows for i in range(got.num_row_groups)] == [1100, 1200, 250]
    table = got.read()
    for k in TIMESERIES_COLUMNS:
        want = np.concatenate([b[k] for b in blocks])
        assert np.array_equal(table.column(k).to_numpy(), want, equal_nan=k not in INTEGER_COLUMNS), k
    groups = [blocks[0:2], blocks[2:4], blocks[4:]]
    joined = [timeseries_table({k: np.concatenate([b[k] for b in g]) for k in TIMESERIES_COLUMNS}) for g in groups]
    with pq.ParquetWriter(tmp_path / "joined.parquet", joined[0].schema, **PARQUET_OPTIONS) as writer:
        for t in joined:
            writer.write_table(t)
    assert (tmp_path / "t.parquet").read_bytes() == (tmp_path / "joined.parquet").read_bytes()


@pytest.mark.parametrize("threads", ["1", "2"])
def test_a_streamed_run_is_the_same_whatever_the_thread_count(monkeypatch, threads):
    """The sensors of the next nodes are computed on worker threads while phase 2 runs, the table is encoded on a
    writer thread: neither changes a bit (NODESIM_THREADS = 1 does everything in the calling thread)."""
    scenario = _scenario(LAB, **{"chain.nodes": 20, "simulation.duration_s": 300.0, "metrics.window_start_s": 200.0,
                                 "metrics.window_end_s": 300.0, "filter.implementation": "fixed"})
    monkeypatch.setenv("NODESIM_THREADS", threads)
    stream = NodeStream(scenario, build_motion(scenario), None)
    chain = simulate_chain(scenario, on_node=stream)
    monkeypatch.setenv("NODESIM_THREADS", "1")
    whole = simulate_chain(scenario)
    assert chain.nodes == ()
    for s, n in zip(chain.summaries, whole.nodes):
        assert s.node_id == n.node_id and np.array_equal(s.stale_packets, n.stale_packets)
    from nodesim.chain.metrics import per_realization_metrics

    a, b = per_realization_metrics(chain, scenario.metrics), per_realization_metrics(whole, scenario.metrics)
    assert a.keys() == b.keys()
    for key in a:
        assert np.array_equal(a[key], b[key], equal_nan=True), key


def test_a_long_trace_keeps_each_bins_smallest_and_largest_yaw_error():
    rng = np.random.default_rng(4)
    K = 3 * TRACE_POINTS + 17
    err = rng.normal(size=K)
    rows = {"node": np.full(K, 7), "t_s": np.arange(K) * 0.5, "running": np.ones(K, int), "yaw_error_deg": err,
            "bias_est_deg_s": err * 2, "bias_true_deg_s": err * 3}
    trace = node_trace(rows)
    assert trace.node_id == 7 and trace.t_s.size <= TRACE_POINTS
    assert trace.yaw_error_deg.max() == err.max() and trace.yaw_error_deg.min() == err.min()
    assert np.all(np.diff(trace.t_s) > 0)  # in time order, each tick once
    b = -(-2 * K // TRACE_POINTS)
    kept = set((trace.t_s / 0.5).astype(int).tolist())
    for start in range(0, K, b):  # every bin's extremes are there
        block = err[start:start + b]
        assert start + int(block.argmax()) in kept and start + int(block.argmin()) in kept
    short = {k: v[:100] for k, v in rows.items()}
    assert np.array_equal(node_trace(short).yaw_error_deg, err[:100])  # short nodes: every tick


def test_the_band_keeps_each_time_bins_smallest_and_largest_yaw_error_of_every_node():
    """YawPlotData's band (one compiled pass per node) against its definition: per bin of the run's time, min and
    max over the nodes' running ticks of finite yaw error."""
    from nodesim.chain.yaw_plot import BAND_BINS, YawPlotData, shown_nodes

    rng = np.random.default_rng(5)
    ids, duration = list(range(1, 41)), 100.0
    data = YawPlotData(ids, duration)
    assert data.band is not None and len(shown_nodes(ids)) < len(ids)
    lo, hi = np.full(BAND_BINS, np.inf), np.full(BAND_BINS, -np.inf)
    for i in ids:
        t = np.sort(rng.uniform(-1.0, duration + 1.0, size=3000))  # ticks outside [0, duration] go to the end bins
        err, running = rng.normal(size=t.size), rng.random(t.size) > 0.2
        err[rng.choice(t.size, 50)] = np.nan
        data.add({"node": np.full(t.size, i), "t_s": t, "running": running.astype(int), "yaw_error_deg": err,
                  "bias_est_deg_s": err, "bias_true_deg_s": err})
        ok = running & np.isfinite(err)
        b = np.clip((t[ok] / duration * BAND_BINS).astype(np.int64), 0, BAND_BINS - 1)
        np.minimum.at(lo, b, err[ok])
        np.maximum.at(hi, b, err[ok])
    assert np.array_equal(data.band[0], lo) and np.array_equal(data.band[1], hi)


def test_a_negative_variance_gives_a_nan_sigma_without_a_warning_per_node(recwarn):
    """A diverged filter (the 6-state chain in a long rotating string, docs/deviated_wells.md) can report a negative
    yaw variance: its row's sigma is NaN, and the table does not print a numpy warning for every node."""
    from nodesim.chain.run_tables import node_timeseries

    scenario = _scenario(LAB, **{"chain.nodes": 1, "simulation.duration_s": 120.0, "metrics.window_start_s": 60.0,
                                 "metrics.window_end_s": 120.0})
    node = simulate_chain(scenario).nodes[0]
    node.yaw_var_rad2[0, -1] = -1e-6
    rows = node_timeseries(node)
    assert np.isnan(rows["yaw_sigma_deg"][-1]) and np.isfinite(rows["yaw_sigma_deg"][-2])
    assert not [w for w in recwarn.list if issubclass(w.category, RuntimeWarning)]


def test_a_run_directory_that_cannot_be_made_is_a_clear_error_before_any_work(tmp_path, capsys):
    """--out under a file (its parent cannot be a directory): one line naming it, exit 2, nothing written."""
    blocker = tmp_path / "a_file"
    blocker.write_text("not a directory")
    code = main(["run", str(LAB), "--out", str(blocker / "run"), "--quiet"])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "cannot write beside it" in err and "--out" in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a_file"]
