"""Phase 2 in windows of time (nodesim.chain.compiled.time_windows, issue 20): a streamed run window by window gives
the node-by-node run's numbers (the RMS errors and the mean update age to rounding: their window sums are added),
its tables the same rows (window by window, so compared sorted by node and time), whatever the thread count."""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np
import pytest

import nodesim.chain.compiled.time_windows as tw
from nodesim.api import load_run, simulate_scenario
from nodesim.chain.yaw_plot import TraceBuilder, YawPlotData, node_trace
from nodesim.scenario.schema import load_scenario

REPO = Path(__file__).resolve().parents[3]
FIELD = REPO / "scenarios" / "field" / "drilling_10_tubes.toml"
LAB = REPO / "scenarios" / "lab" / "continuous.toml"
SUMMED = ("rms_azimuth_error_deg", "rms_inclination_error_deg", "rms_yaw_error_deg", "mean_update_age_s")
"""The metrics whose window sums are added (:class:`nodesim.chain.metrics.NodeMetricSums`)."""


def _run(tmp_path: Path, name: str, scenario, monkeypatch, window_s: float | None):
    """The streamed run of ``scenario`` saved and loaded back: in windows of ``window_s``, or node by node (None)."""
    with monkeypatch.context() as m:
        if window_s is None:
            m.setattr(tw, "windowed", lambda scenario, on_node: False)
        else:
            m.setattr(tw, "WINDOW_S", window_s)
            m.setattr(tw, "MAX_WINDOWS", 1000)
        run = simulate_scenario(scenario, None, stream_to=tmp_path / f"stage-{name}")
    run.save(tmp_path / name)
    return load_run(tmp_path / name)


def _sorted(columns: dict) -> dict:
    order = np.lexsort((np.asarray(columns["t_s"]), np.asarray(columns["node"])))
    return {k: np.asarray(v)[order] for k, v in columns.items()}


def _same_runs(a, b) -> None:
    """Every table value for value (the timeseries sorted by node and time), the summaries but for the summed
    metrics (to 1e-12 relative) and the timing."""
    x, y = dict(a.summary), dict(b.summary)
    x.pop("timing"), y.pop("timing")
    assert x.keys() == y.keys()
    for k in x:
        if any(m in k for m in SUMMED) and isinstance(x[k], float) and isinstance(y[k], float):
            assert y[k] == pytest.approx(x[k], rel=1e-12, abs=0.0), k
        else:
            assert x[k] == y[k], k
    ra, rb = a.table("realizations"), b.table("realizations")
    assert list(ra.columns) == list(rb.columns)
    for k in ra.columns:
        if any(m in k for m in SUMMED):
            np.testing.assert_allclose(rb[k].to_numpy(), ra[k].to_numpy(), rtol=1e-12, atol=0.0, err_msg=k)
        else:
            np.testing.assert_array_equal(rb[k].to_numpy(), ra[k].to_numpy(), err_msg=k)
    for name in ("surveys", "ground_survey", "hops"):
        ta, tb = a.table(name), b.table(name)
        assert (ta is None) == (tb is None)
        if ta is not None:
            assert ta.equals(tb), name
    ta, tb = _sorted(a._columns("timeseries")), _sorted(b._columns("timeseries"))
    assert ta.keys() == tb.keys()
    for k in ta:
        np.testing.assert_array_equal(ta[k], tb[k], err_msg=k)


@pytest.mark.parametrize("path, overrides, window_s", [
    # drilling: insertions, holds, surveys up the chain, fallback past a dead node, every window cut mid-tube
    (FIELD, {"filter.implementation": "fixed", "chain.nodes": 5, "simulation.realizations": 2, "faults.node_failure": [{"node": 3, "at_s": 500.0}],
             "faults.link_outage": [{"hop": 2, "start_s": 280.0, "end_s": 330.0}]}, 97.0),
    # clocks: staggered and drifting, one stepping (a gap in its ticks across a window's edge)
    (FIELD, {"filter.implementation": "fixed", "chain.nodes": 4, "chain.clock_stagger_s": 0.37, "chain.clock_drift_ppm": 40.0,
             "faults.clock_step": [{"node": 2, "at_s": 262.0, "step_s": 1.3}]}, 131.0),
    # the lab string's fixed firmware: the alignment window and the survey's moving average cut by the windows
    (LAB, {"chain.nodes": 3, "filter.implementation": "fixed",
           "output.timeseries": "decimate:3"}, 61.0),
])
def test_a_run_in_windows_of_time_is_the_node_by_node_run(tmp_path, monkeypatch, path, overrides, window_s):
    scenario = load_scenario(path)[0].with_overrides(**overrides)
    assert scenario.simulation.duration_s > 2 * window_s  # more than two windows
    assert tw.windowed(scenario, type("Stream", (), {"node_windows": None})())
    whole = _run(tmp_path, "nodes", scenario, monkeypatch, None)
    windows = _run(tmp_path, "windows", scenario, monkeypatch, window_s)
    _same_runs(whole, windows)
    order = windows._columns("timeseries")["t_s"]  # window by window: the rows are not in node order
    assert whole.summary["nodes"] == windows.summary["nodes"] and order.size


@pytest.mark.parametrize("threads", ["1", "2"])
def test_a_run_in_windows_is_the_same_whatever_the_thread_count(tmp_path, monkeypatch, threads):
    scenario = load_scenario(FIELD)[0].with_overrides(**{"chain.nodes": 4, "simulation.realizations": 3,
                                                         "filter.implementation": "fixed"})
    monkeypatch.setenv("NODESIM_THREADS", "2")
    ref = _run(tmp_path, "ref", scenario, monkeypatch, 113.0)
    monkeypatch.setenv("NODESIM_THREADS", threads)
    got = _run(tmp_path, "got", scenario, monkeypatch, 113.0)
    _same_bits(ref, got)


def _same_bits(a, b) -> None:
    """The summaries (but their timing) and every table, bit for bit."""
    x, y = dict(a.summary), dict(b.summary)
    x.pop("timing"), y.pop("timing")
    assert x == y
    for name in a._tables:
        ta, tb = a._columns(name), b._columns(name)
        for k in ta:
            np.testing.assert_array_equal(ta[k], tb[k], err_msg=f"{name}.{k}")


def test_only_the_fixed_two_state_firmware_without_bit_errors_goes_in_windows():
    stream = type("Stream", (), {"node_windows": None})()
    base = load_scenario(FIELD)[0].with_overrides(**{"filter.implementation": "fixed"})
    assert tw.windowed(base, stream)
    assert not tw.windowed(base, lambda run, surveys: None)  # a plain on_node: node by node
    assert not tw.windowed(base.with_overrides(**{"filter.implementation": "float"}), stream)
    assert not tw.windowed(base.with_overrides(**{"mac.bit_errors": True, "radio.model": "channel"}), stream)


@pytest.mark.parametrize("seed", range(4))
def test_a_trace_fed_in_pieces_is_the_trace_of_all_rows(seed):
    rng = np.random.default_rng(seed)
    K = int(rng.integers(5000, 20000))
    rows = {"node": np.full(K, 7), "t_s": np.arange(K) * 0.5, "running": rng.random(K) < 0.9,
            "yaw_error_deg": np.where(rng.random(K) < 0.01, np.nan, rng.normal(size=K)),
            "bias_est_deg_s": rng.normal(size=K), "bias_true_deg_s": rng.normal(size=K)}
    whole = node_trace(rows)
    cuts = np.sort(rng.choice(np.arange(1, K), size=int(rng.integers(1, 9)), replace=False))
    builder = TraceBuilder(7, K)
    for a, b in zip(np.concatenate([[0], cuts]), np.concatenate([cuts, [K]])):
        builder.add({k: v[a:b] for k, v in rows.items()})
    got = builder.finish()
    for name in ("t_s", "yaw_error_deg", "bias_est_deg_s", "bias_true_deg_s"):
        np.testing.assert_array_equal(getattr(got, name), getattr(whole, name), err_msg=name)
    data = YawPlotData.from_table({k: np.concatenate([v[:K // 2], v[K // 2:]]) for k, v in rows.items()}, K * 0.5)
    np.testing.assert_array_equal(data.traces[0].t_s, whole.t_s)


def test_a_window_truth_goes_on_with_the_last_ones_sums():
    """Each window's shared truth starts from the one before's prefix sums: its tick sums are the whole run's."""
    from nodesim.chain.network import Network
    from nodesim.chain.sensing import shared_truth
    from nodesim.sensors.chain_imu import ChainImu

    scenario = load_scenario(LAB)[0].with_overrides(**{"chain.nodes": 3})  # a rigid string: one truth for all
    net = Network(scenario, attach_signals=False)
    whole = shared_truth(scenario, net.motion, net.dt_s)
    imu = ChainImu.from_scenario(scenario)
    span = tw._Span(whole.j_lo, whole.j_hi)
    last, duration = None, scenario.simulation.duration_s
    for i in range(math.ceil(duration / 150.0)):
        t0, t1 = 150.0 * i, 150.0 * (i + 1)
        bounds = []
        for node in net.nodes:
            k0, k1 = np.searchsorted(node.t_s, [t0, t1]).tolist()
            bounds.append((k0, k1, (node.t_s[k0 - 1] if k0 else node.t_s[0] - net.dt_s) if k0 < k1 else 0.0,
                           node.t_s[k1 - 1] if k0 < k1 else 0.0))
        last = tw._window_truth(net, imu, span, last, bounds)
        a, b = last.j_lo + 1, last.j_hi
        first, n = np.arange(a, b - 5, 5), np.full((b - 5 - a + 4) // 5, 5)
        got, want = last.tick_sums(first, n), whole.tick_sums(first, n)
        np.testing.assert_array_equal(got[0], want[0])
        np.testing.assert_array_equal(got[1], want[1])


def test_a_run_is_cut_into_windows_of_an_hour_at_most_two():
    assert tw.window_s(600.0) == 3600.0  # one window
    assert tw.window_s(7200.0) == 3600.0  # two hours: two windows of one
    assert tw.window_s(86400.0) == 43200.0  # a day: two of twelve hours


def test_phase_one_beside_the_windows_starts_again_after_they_began(tmp_path, monkeypatch):
    """Phase 1 on its own thread (nodesim.chain.compiled.phase_one) starts again when an inbox is full; here a full
    inbox is made up in the chunk of events that crosses into the fourth window, once phase 2 has been given the
    first two windows' records: the steps phase 2 was given keep the records of the attempt that made them final
    (the same events before the overflow), the later ones wait for the new attempt's (the chunk that overflowed
    does not make the third window's final)."""
    import threading

    from nodesim.chain.compiled import events as ev, phase_one

    scenario = load_scenario(FIELD)[0].with_overrides(**{"chain.nodes": 4, "filter.implementation": "fixed"})
    monkeypatch.setenv("NODESIM_THREADS", "1")  # phase 1 before phase 2
    ref = _run(tmp_path, "ref", scenario, monkeypatch, 113.0)
    monkeypatch.setenv("NODESIM_THREADS", "2")
    monkeypatch.setattr(ev, "CHUNK_EVENTS", 64)  # many chunks: phase 1 tells its progress often
    given, made_up = threading.Event(), []
    run_events, wait = ev.run_events, phase_one.PhaseOne.wait

    def spy_wait(self, t_s):
        tables = wait(self, t_s)
        if t_s >= 2 * 113.0:
            given.set()
        return tables

    def full_inbox_once(N, chunk, *args):
        if not made_up and chunk[2][0] < 3 * 113.0 <= chunk[2][-1]:
            assert given.wait(60.0), "phase 2 was not given the first windows beside phase 1"
            made_up.append(chunk[2][0])
            return ev.INBOX_FULL
        return run_events(N, chunk, *args)

    monkeypatch.setattr(phase_one.PhaseOne, "wait", spy_wait)
    monkeypatch.setattr(ev, "run_events", full_inbox_once)
    got = _run(tmp_path, "got", scenario, monkeypatch, 113.0)
    assert made_up
    _same_bits(ref, got)


def test_phase_one_on_its_thread_raises_its_error_where_it_is_waited_for():
    from nodesim.chain.compiled.phase_one import PhaseOne

    def fails(progress):
        progress.publish(None, (), 10.0)
        raise ValueError("phase 1 broke")

    p = PhaseOne(fails)
    with pytest.raises(ValueError, match="phase 1 broke"):
        p.wait(20.0)
    with pytest.raises(ValueError, match="phase 1 broke"):
        p.result()
    done = PhaseOne(done=(5, "records", None, None, "arrivals"))
    assert done.wait(math.inf) == ("records", "arrivals") and done.result()[0] == 5


def test_phase_one_on_its_thread_stops_when_phase_two_fails(tmp_path, monkeypatch):
    """A window that raises stops phase 1 beside it at its next chunk (no work left running in the background) and
    the run raises the window's error."""
    from nodesim.chain.compiled import events as ev, phase_one

    scenario = load_scenario(FIELD)[0].with_overrides(**{"chain.nodes": 4, "filter.implementation": "fixed"})
    monkeypatch.setenv("NODESIM_THREADS", "2")
    monkeypatch.setattr(ev, "CHUNK_EVENTS", 64)
    made: list = []
    init = phase_one.PhaseOne.__init__

    def keep(self, *args, **kwargs):
        init(self, *args, **kwargs)
        made.append(self)

    def broken(*args):
        raise RuntimeError("window broke")

    run_events = ev.run_events

    waited: list = []

    def slow(N, chunk, *args):  # phase 1 waits once past the third window's start until phase 2 has given up
        if chunk[2][0] > 3 * 113.0 and not waited:
            waited.append(1)
            deadline = time.monotonic() + 20.0
            while not made[0]._cancelled and time.monotonic() < deadline:
                time.sleep(0.01)
        return run_events(N, chunk, *args)

    monkeypatch.setattr(phase_one.PhaseOne, "__init__", keep)
    monkeypatch.setattr(tw, "_window", broken)
    monkeypatch.setattr(ev, "run_events", slow)
    with pytest.raises(RuntimeError, match="window broke"):
        _run(tmp_path, "broken", scenario, monkeypatch, 113.0)
    assert len(made) == 1
    with pytest.raises(phase_one.Cancelled):
        made[0].result()


def test_a_run_in_windows_leaves_the_collector_as_it_found_it(tmp_path, monkeypatch):
    """The windows freeze the objects made before them (gc.freeze) and unfreeze them after: nothing stays frozen
    after a run, and a caller's own frozen objects stay frozen."""
    import gc

    scenario = load_scenario(FIELD)[0].with_overrides(**{"chain.nodes": 3, "filter.implementation": "fixed"})
    gc.unfreeze()
    _run(tmp_path, "free", scenario, monkeypatch, 113.0)
    assert gc.get_freeze_count() == 0
    gc.freeze()  # the caller's
    try:
        mine = gc.get_freeze_count()
        assert mine > 0
        _run(tmp_path, "frozen", scenario, monkeypatch, 113.0)
        assert gc.get_freeze_count() > mine // 2  # still frozen (a few of them freed meanwhile), not unfrozen
    finally:
        gc.unfreeze()
