"""The strict log reader: each malformed-log case gets its own clear error naming the line, and --repair
applies the documented fix and counts it."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from nodesim.errors import NodesimError
from nodesim.units import G0_M_S2
from nodesim.replay import logformat as lf
from nodesim.replay.reader import read_log
from nodesim.replay.recorder import NodeRecording, write_log

HEADER_LINES = 9  # "# nodesim-log 1" + 8 header keys of the counts log below
FIRST_DATA_LINE = HEADER_LINES + 2


def counts_log(n: int = 40, rate_hz: float = 10.0, seed: int = 0) -> tuple[NodeRecording, lf.LogMeta]:
    rng = np.random.default_rng(seed)
    cols = {"t_s": np.arange(n) / rate_hz, "encoder": np.arange(n) % 1024}
    for c in lf.GYRO + lf.ACCEL:
        cols[c] = rng.integers(-300, 300, n).astype(float)
    meta = lf.LogMeta(gyro_unit="counts", accel_unit="counts", encoder_unit="counts", gyro_lsb_per_deg_s=131.0,
                      accel_lsb_per_g=16384.0, encoder_counts_per_rev=1024)
    return NodeRecording(1, cols), meta


def write_text(tmp_path, edit=None, name="log.csv") -> tuple:
    node, meta = counts_log()
    path = write_log(tmp_path / name, [node], meta)
    lines = path.read_text().splitlines()
    assert lines[HEADER_LINES].startswith("node,t_s")  # the layout the line numbers below rely on
    if edit is not None:
        edit(lines)
        path.write_text("\n".join(lines) + "\n")
    return path, node


def set_cell(lines, data_row: int, column: str, value: str) -> None:
    names = lines[HEADER_LINES].split(",")
    cells = lines[HEADER_LINES + 1 + data_row].split(",")
    cells[names.index(column)] = value
    lines[HEADER_LINES + 1 + data_row] = ",".join(cells)


def test_counts_are_converted_to_si(tmp_path):
    path, node = write_text(tmp_path)
    log = read_log(path)
    n = log.nodes[0]
    assert n.gyro_rad_s[:, 2] == pytest.approx(node.columns["gyro_z"] / 131.0 * math.pi / 180)
    assert n.accel_m_s2[:, 0] == pytest.approx(node.columns["accel_x"] / 16384.0 * G0_M_S2)
    assert n.encoder_rad == pytest.approx(node.columns["encoder"] * 2 * math.pi / 1024)
    assert n.rows[0] == FIRST_DATA_LINE and log.repairs == {}


def test_missing_column(tmp_path):
    def drop_gyro_y(lines):
        for i in range(HEADER_LINES, len(lines)):
            cells = lines[i].split(",")
            del cells[3]
            lines[i] = ",".join(cells)

    path, _ = write_text(tmp_path, drop_gyro_y)
    with pytest.raises(NodesimError, match=r"missing required column\(s\) \['gyro_y'\]"):
        read_log(path, repair=True)  # not repairable


def test_unknown_column_and_unknown_unit(tmp_path):
    path, _ = write_text(tmp_path, lambda L: L.__setitem__(HEADER_LINES, L[HEADER_LINES].replace("node", "nodeid")))
    with pytest.raises(NodesimError, match=r"unknown column\(s\) \['nodeid'\]"):
        read_log(path)
    path, _ = write_text(tmp_path, lambda L: L.__setitem__(1, "# gyro_unit = rpm"))
    with pytest.raises(NodesimError, match=r"line 2|gyro_unit = 'rpm' is not a known unit; allowed \['counts', 'rad/s', 'deg/s'\]"):
        read_log(path, repair=True)


def test_missing_header_and_non_numeric_cell(tmp_path):
    path, _ = write_text(tmp_path, lambda L: L.__delitem__(slice(0, HEADER_LINES)))
    with pytest.raises(NodesimError, match="no header"):
        read_log(path)
    path, _ = write_text(tmp_path, lambda L: set_cell(L, 5, "accel_y", "abc"))
    with pytest.raises(NodesimError, match=rf"line {FIRST_DATA_LINE + 5}, column accel_y: 'abc' is not a number"):
        read_log(path)


def test_nan_stops_and_repair_drops_the_row(tmp_path):
    path, node = write_text(tmp_path, lambda L: set_cell(L, 7, "gyro_x", "nan"))
    with pytest.raises(NodesimError, match=rf"line {FIRST_DATA_LINE + 7}: column gyro_x is empty or not finite"):
        read_log(path)
    log = read_log(path, repair=True)
    assert log.repairs == {"dropped_nan_rows": 1}
    assert log.nodes[0].t_s.size == node.columns["t_s"].size - 1
    assert FIRST_DATA_LINE + 7 not in log.nodes[0].rows


def test_counts_out_of_int16_range_and_clipping_repair(tmp_path):
    path, _ = write_text(tmp_path, lambda L: set_cell(L, 3, "gyro_z", "40000"))
    with pytest.raises(NodesimError, match=rf"line {FIRST_DATA_LINE + 3}: column gyro_z = 40000 counts is outside the int16 range \[-32768, 32767\]"):
        read_log(path)
    log = read_log(path, repair=True)
    assert log.repairs == {"clipped_counts": 1}
    assert log.nodes[0].gyro_rad_s[3, 2] == pytest.approx(32767 / 131.0 * math.pi / 180)


def test_non_integer_count(tmp_path):
    path, _ = write_text(tmp_path, lambda L: set_cell(L, 2, "accel_z", "12.5"))
    with pytest.raises(NodesimError, match=rf"line {FIRST_DATA_LINE + 2}: column accel_z = 12.5 is not an integer count"):
        read_log(path)
    assert read_log(path, repair=True).repairs == {"rounded_counts": 1}


def test_duplicated_and_backward_time(tmp_path):
    path, node = write_text(tmp_path, lambda L: set_cell(L, 10, "t_s", repr(node_t(9))))
    with pytest.raises(NodesimError, match=rf"line {FIRST_DATA_LINE + 10}: duplicated time on node 1"):
        read_log(path)
    log = read_log(path, repair=True)
    assert log.repairs == {"dropped_duplicate_time": 1} and log.nodes[0].t_s.size == 39
    path, _ = write_text(tmp_path, lambda L: set_cell(L, 20, "t_s", "1.05"))
    with pytest.raises(NodesimError, match=rf"line {FIRST_DATA_LINE + 20}: time goes back on node 1: t_s = 1.05"):
        read_log(path)
    assert read_log(path, repair=True).repairs == {"dropped_backward_time": 1}


def node_t(i: int) -> float:
    return i / 10.0


def test_gap_longer_than_threshold(tmp_path):
    def gap(lines):
        for r in range(20, 40):
            set_cell(lines, r, "t_s", repr(node_t(r) + 5.0))

    path, _ = write_text(tmp_path, gap)
    with pytest.raises(NodesimError, match=rf"line {FIRST_DATA_LINE + 20}: gap of 5.1 s on node 1.*max_gap_s = 1 s"):
        read_log(path)
    assert read_log(path, max_gap_s=6.0).repairs == {}
    log = read_log(path, repair=True)
    assert log.repairs == {"gaps": 1} and log.hold_gaps


def test_first_problem_is_the_lowest_line(tmp_path):
    def two(lines):
        set_cell(lines, 30, "gyro_x", "nan")
        set_cell(lines, 12, "accel_x", "99999")

    path, _ = write_text(tmp_path, two)
    with pytest.raises(NodesimError, match=rf"line {FIRST_DATA_LINE + 12}:"):
        read_log(path)
    assert read_log(path, repair=True).repairs == {"dropped_nan_rows": 1, "clipped_counts": 1}


def test_parquet_reports_rows_and_round_trips(tmp_path):
    node, meta = counts_log()
    node.columns["gyro_x"][4] = np.nan
    path = write_log(tmp_path / "log.parquet", [node], meta)
    with pytest.raises(NodesimError, match=r"log.parquet, row 5: column gyro_x is empty"):
        read_log(path)
    log = read_log(path, repair=True)
    assert log.row_kind == "row" and log.repairs == {"dropped_nan_rows": 1}


def test_sidecar_header(tmp_path):
    path, _ = write_text(tmp_path, lambda L: L.__delitem__(slice(0, HEADER_LINES)))
    (tmp_path / "log.csv.meta.json").write_text('{"gyro_unit": "counts", "gyro_lsb_per_deg_s": 131, "accel_unit": "counts", '
                                                '"accel_lsb_per_g": 16384, "encoder_unit": "counts", "encoder_counts_per_rev": 1024}')
    assert read_log(path).nodes[0].t_s.size == 40


def test_ref_update_needs_a_reference(tmp_path):
    node, meta = counts_log()
    node.columns["ref_update"] = np.zeros(40, dtype=bool)
    node.columns["ref_update"][6] = True
    node.columns["ref_yaw"] = np.full(40, np.nan)
    node.columns["ref_var"] = np.full(40, 1e-6)
    path = write_log(tmp_path / "log.csv", [node], meta)
    with pytest.raises(NodesimError, match="ref_update = 1 needs a finite ref_yaw"):
        read_log(path, repair=True)


@settings(max_examples=25, deadline=None)
@given(st.lists(st.floats(-1e3, 1e3, allow_nan=False, allow_subnormal=True), min_size=3, max_size=30), st.sampled_from(["csv", "parquet"]))
def test_si_values_round_trip_exactly(tmp_path_factory, values, kind):
    """record -> read is exact for any double (shortest round-trip representation)."""
    n = len(values)
    v = np.asarray(values)
    cols = {"t_s": np.arange(n) * 0.1, "encoder": v, **{c: v for c in lf.GYRO + lf.ACCEL}}
    path = write_log(tmp_path_factory.mktemp("rt") / f"log.{kind}", [NodeRecording(1, cols)], lf.LogMeta())
    node = read_log(path).nodes[0]
    assert np.array_equal(node.gyro_rad_s[:, 1], v) and np.array_equal(node.encoder_rad, v)


def _frames_log(tmp_path, suffix="csv"):
    from firmware_model import frames as fr

    node, meta = counts_log()
    values = np.array([[1, k, 100_000 * k, 1000 * k, 5, -3, 7] for k in range(40)])
    sent = fr.encode(fr.ESTIMATE, values)[0]
    node.columns["frame"] = np.array([sent[k].tobytes().hex() if k % 3 == 0 else None for k in range(40)],
                                     dtype=object)
    return write_log(tmp_path / f"frames.{suffix}", [node], meta), sent


@pytest.mark.parametrize("suffix", ["csv", "parquet"])
def test_frames_round_trip_as_hex(tmp_path, suffix):
    path, sent = _frames_log(tmp_path, suffix)
    got = read_log(path).nodes[0].extra["frame"]
    assert got.shape == (40, 27) and got.dtype == np.uint8
    every_third = np.arange(40) % 3 == 0
    assert np.array_equal(got[every_third], sent[every_third]) and not got[~every_third].any()


@pytest.mark.parametrize("cell, message", [
    ("abc", "allowed 54 hex digits"),
    ("zz" * 27, "allowed 54 hex digits"),
    ("01" * 27, "fails its CRC-16"),
])
def test_a_bad_frame_cell_names_its_line(tmp_path, cell, message):
    path, _ = _frames_log(tmp_path)
    lines = path.read_text().splitlines()
    names = lines[HEADER_LINES].split(",")
    col = names.index("frame")
    cells = lines[FIRST_DATA_LINE + 2].split(",")  # a row (k = 3) that carries a frame
    cells[col] = cell
    lines[FIRST_DATA_LINE + 2] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(NodesimError, match=f"line {FIRST_DATA_LINE + 3}: frame = .*{message}"):
        read_log(path)
