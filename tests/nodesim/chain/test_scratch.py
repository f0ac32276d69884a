"""The whole-run tables kept on disk (nodesim.chain.scratch, issue 20): their values survive dropping their pages, the
pages leave the process's resident memory, a full disk is a clear error, a RAM file system is not used, and a streamed
run with its tables on disk writes the same run directory as one that keeps them in memory."""

from __future__ import annotations

import errno
import os
import threading
from pathlib import Path

import numpy as np
import pytest

from nodesim.api import load_run, simulate_scenario
from nodesim.chain import scratch
from nodesim.chain.network import Network
from nodesim.errors import NodesimError
from nodesim.scenario.schema import load_scenario

REPO = Path(__file__).resolve().parents[3]
FIELD = REPO / "scenarios" / "field" / "drilling_10_tubes.toml"
LAB = REPO / "scenarios" / "lab" / "continuous.toml"


def _rss_bytes() -> int:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


def test_an_array_keeps_its_values_after_its_pages_are_dropped(tmp_path):
    s = scratch.ScratchArrays(tmp_path)
    a = s.empty((3, 5000), np.int32)
    assert not a.any()  # the file's unwritten blocks read as zeros
    b = s.empty((2, 3, 7000), np.int8)
    s.fill(b, -1)
    assert (b == -1).all()
    values = np.arange(a.size, dtype=np.int32).reshape(a.shape)
    a[:] = values
    s.drop()
    assert np.array_equal(a, values) and (b == -1).all()
    assert s.nbytes == a.nbytes + b.nbytes
    assert not list(tmp_path.iterdir())  # the file is unlinked at once: nothing to clean up after a crash


@pytest.mark.skipif(not Path("/proc/self/statm").exists(), reason="reads the resident set from /proc")
def test_dropping_takes_the_pages_out_of_the_resident_memory(tmp_path):
    s = scratch.ScratchArrays(tmp_path)
    a = s.empty((64 * 2**20,), np.uint8)
    before = _rss_bytes()
    a[::4096] = 1  # touch every page
    touched = _rss_bytes()
    s.drop()
    dropped = _rss_bytes()
    assert touched - before > 48 * 2**20
    assert touched - dropped > 48 * 2**20
    assert int(a[::4096].sum()) == a.size // 4096  # and the values are read back from the file


def test_write_puts_the_values_in_the_file_the_mapping_reads(tmp_path):
    s = scratch.ScratchArrays(tmp_path)
    a, b = s.empty((4, 3000), np.float64), s.empty((5,), np.int16)
    row = np.linspace(-1.0, 1.0, 2000)
    s.write(a[2, 500:2500], row)
    s.write(b[1:3], np.array([7, -8], np.int16))
    s.write(a[0, :0], row[:0])  # nothing
    expected = np.zeros(a.shape)
    expected[2, 500:2500] = row
    assert np.array_equal(a, expected) and b.tolist() == [0, 7, -8, 0, 0]
    s.drop()
    assert np.array_equal(a, expected)  # in the file, not only in the process's pages
    with pytest.raises(ValueError, match="not one of these arrays"):
        s.write(np.zeros(3), np.ones(3))
    with pytest.raises(ValueError, match="not contiguous"):
        s.write(a[:, 0], np.ones(4))
    plain = np.zeros(3)
    scratch.write(None, plain, np.arange(3.0))  # no scratch arrays: in memory
    assert plain.tolist() == [0.0, 1.0, 2.0]


def _join_write_out() -> None:
    for t in threading.enumerate():
        if t.name == "nodesim-write-out":
            t.join()


def test_write_out_starts_writing_every_array_to_its_file_and_keeps_the_values(tmp_path, monkeypatch):
    real = scratch.sync_file_range()
    if real is None:
        pytest.skip("no sync_file_range here (not Linux with glibc)")
    calls = []

    def recording():
        def call(fd, offset, nbytes, flags):
            result = real(fd, offset, nbytes, flags)
            calls.append((fd, offset, nbytes, flags, result))
            return result
        return call

    monkeypatch.setattr(scratch, "sync_file_range", recording)
    s = scratch.ScratchArrays(tmp_path)
    a, b = s.empty((64, 4096), np.float64), s.empty((3,), np.int8)
    values = np.arange(a.size, dtype=float).reshape(a.shape)
    s.write(a, values)
    b[:] = [1, -2, 3]  # through the mapping
    s.write_out()
    _join_write_out()
    # each array's file, from its start to its end, writing started and not waited for, and the kernel took it
    assert sorted(c[0] for c in calls) == sorted(fd for _, _, fd in s._regions)
    assert [c[1:] for c in calls] == [(0, 0, scratch.SYNC_FILE_RANGE_WRITE, 0)] * 2
    s.drop()
    assert np.array_equal(a, values) and b.tolist() == [1, -2, 3]  # the same values, read back from the files
    calls.clear()
    monkeypatch.setattr(scratch, "sync_file_range", lambda: None)  # no such call (not Linux): nothing is done
    s.write_out()
    scratch.write_out(None)  # no scratch arrays: nothing
    _join_write_out()
    assert calls == []


def test_fill_writes_its_value_a_slice_at_a_time(tmp_path, monkeypatch):
    monkeypatch.setattr(scratch, "FILL_BYTES", 4096)
    s = scratch.ScratchArrays(tmp_path)
    a = s.empty((10, 1001), np.int64)
    s.fill(a, -7)
    assert (a == -7).all()


def test_a_full_disk_is_a_clear_error_naming_the_space_and_tmpdir(tmp_path, monkeypatch):
    def no_space(fd, offset, length):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(os, "posix_fallocate", no_space)
    with pytest.raises(NodesimError, match=r"need 0\.8 GB more of scratch space in .*TMPDIR.*No space left"):
        scratch.ScratchArrays(tmp_path).empty((100_000, 8000), np.int8)


def test_a_ram_file_system_is_not_used(monkeypatch):
    monkeypatch.setattr(scratch, "_mount_type", lambda path: "tmpfs")
    assert scratch.scratch_directory() is None
    assert not scratch.spills(10_000, 100_000, 1, False)
    monkeypatch.setattr(scratch, "_mount_type", lambda path: "ext4")
    assert scratch.scratch_directory() is not None
    assert scratch.spills(10_000, 100_000, 1, False)
    assert not scratch.spills(10, 100, 1, False)  # small tables stay in memory


def test_the_mount_of_a_path_is_found():
    kind = scratch._mount_type(Path("/proc/self"))
    assert kind in (None, "proc")


def test_the_whole_run_tables_are_counted_per_node_tick_and_realization():
    # tick times 8 + plan 1 a node-tick; per realization the flag 1, source offset 1, source tick 4;
    # with mac.bit_errors the tick's try (int64) and BER (float64)
    assert scratch.whole_run_table_bytes(2, 100, 3, False) == 2 * 100 * (9 + 3 * 6)
    assert scratch.whole_run_table_bytes(2, 100, 3, True) == 2 * 100 * (9 + 3 * 22)


@pytest.mark.parametrize("path, overrides", [
    (FIELD, {"chain.nodes": 6, "simulation.realizations": 2}),  # drilling, fixed firmware, surveys
    (LAB, {"chain.nodes": 4, "simulation.duration_s": 200.0, "metrics.window_start_s": 100.0,
           "metrics.window_end_s": 200.0, "simulation.realizations": 2, "radio.model": "channel",
           "radio.shadowing_sigma_db": 0.0, "radio.soil.distance_m": 2.0, "radio.soil.vwc": 0.275, "mac.enabled": True,
           "mac.bit_errors": True, "filter.implementation": "fixed"}),  # lossy hops with bit errors
])
def test_a_run_with_its_tables_on_disk_writes_the_same_directory(tmp_path, monkeypatch, path, overrides):
    scenario = load_scenario(path)[0].with_overrides(**overrides)
    made = []
    real = scratch.ScratchArrays.__init__

    def init(self, directory):
        made.append(self)
        real(self, directory)

    monkeypatch.setattr(scratch.ScratchArrays, "__init__", init)
    monkeypatch.setattr(scratch, "SPILL_MIN_BYTES", 0)
    simulate_scenario(scenario, None, stream_to=tmp_path / "s1").save(tmp_path / "disk")
    assert len(made) == 1 and made[0].nbytes > 0
    monkeypatch.setattr(scratch, "SPILL_MIN_BYTES", 2**62)
    simulate_scenario(scenario, None, stream_to=tmp_path / "s2").save(tmp_path / "memory")
    assert len(made) == 1
    x, y = load_run(tmp_path / "disk"), load_run(tmp_path / "memory")
    x.summary.pop("timing"), y.summary.pop("timing")
    assert x == y


def test_only_a_streamed_run_spills(monkeypatch):
    monkeypatch.setattr(scratch, "SPILL_MIN_BYTES", 0)
    scenario = load_scenario(FIELD)[0].with_overrides(**{"chain.nodes": 3})
    assert Network(scenario, attach_signals=False).scratch is None
    net = Network(scenario, attach_signals=False, spill=True)
    assert net.scratch is not None and net.tick_table.base is not None


def test_phase_1_drops_the_tables_pages_once_per_drop_interval_whatever_its_chunks(tmp_path, monkeypatch):
    """Phase 1 takes the scratch tables' pages out each time its events pass a multiple of DROP_EVERY_EVENTS (not
    after every chunk, which made a node's partly written page be read back after each): here chunks of 7 events
    and a drop every 50; the run directory is the same as with the tables in memory."""
    from nodesim.chain.compiled import engine

    scenario = load_scenario(FIELD)[0].with_overrides(**{"chain.nodes": 4})
    drops, phase_1, events = [], [], []
    real_drop, real_resolve = scratch.drop, engine._resolve

    def drop(arrays):
        drops.append(bool(phase_1))
        real_drop(arrays)

    def resolve(*args, **kwargs):
        phase_1.append(True)
        try:
            result = real_resolve(*args, **kwargs)
        finally:
            phase_1.clear()
        events.append(result[0])
        return result

    monkeypatch.setattr(scratch, "drop", drop)  # the engine's (``spill.drop``); a table's fill drops its own slices
    monkeypatch.setattr(engine, "_resolve", resolve)
    monkeypatch.setattr(engine.ev, "CHUNK_EVENTS", 7)
    monkeypatch.setattr(engine, "DROP_EVERY_EVENTS", 50)
    monkeypatch.setattr(scratch, "SPILL_MIN_BYTES", 0)
    simulate_scenario(scenario, None, stream_to=tmp_path / "s1").save(tmp_path / "disk")
    assert events[0] > 200 and sum(drops) == events[0] // 50
    monkeypatch.setattr(scratch, "SPILL_MIN_BYTES", 2**62)
    simulate_scenario(scenario, None, stream_to=tmp_path / "s2").save(tmp_path / "memory")
    x, y = load_run(tmp_path / "disk"), load_run(tmp_path / "memory")
    x.summary.pop("timing"), y.summary.pop("timing")
    assert x == y
