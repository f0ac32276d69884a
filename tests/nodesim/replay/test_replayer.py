"""The replayer on synthetic logs: resampling 65 Hz samples to the firmware ticks, schedules, gaps, errors."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from nodesim.errors import NodesimError
from nodesim.replay import logformat as lf
from nodesim.replay.reader import read_log
from nodesim.replay.recorder import NodeRecording, write_log
from nodesim.replay.replayer import FirmwareSetup, parse_schedule, replay_log
from nodesim.scenario.schema import Scenario
from nodesim.units import DEG

SCENARIO = Scenario().with_overrides(**{"motion.stationary_s": 10.0})
SETUP = FirmwareSetup.from_scenario(SCENARIO)


def synthetic(tmp_path: Path, rate_deg_s: float, bias_deg_s: float, duration_s: float = 60.0, hz: float = 65.0,
              encoder: bool = True, name: str = "syn.csv", drop=None) -> Path:
    """Still for 10 s, then a constant rotation; gyro = rate + bias; encoder = the exact angle."""
    t = np.arange(int(duration_s * hz)) / hz
    rate = np.where(t >= 10.0, rate_deg_s, 0.0) * DEG
    angle = np.where(t >= 10.0, (t - 10.0) * rate_deg_s, 0.0) * DEG
    cols = {"t_s": t, "gyro_x": np.zeros_like(t), "gyro_y": np.zeros_like(t), "gyro_z": rate + bias_deg_s * DEG,
            "accel_x": np.full_like(t, 0.3), "accel_y": np.zeros_like(t), "accel_z": np.full_like(t, 9.8)}
    if encoder:
        cols["encoder"] = angle
    if drop is not None:
        cols = {k: np.delete(v, drop) for k, v in cols.items()}
    meta = lf.LogMeta(encoder_unit="rad" if encoder else "absent")
    return write_log(tmp_path / name, [NodeRecording(1, cols)], meta)


@settings(max_examples=15, deadline=None)
@given(st.floats(-80.0, 80.0), st.floats(-2.0, 2.0))
def test_free_running_yaw_follows_the_rotation_and_removes_the_static_bias(tmp_path_factory, rate, bias):
    """65 Hz samples averaged per 1.9 Hz tick, bias from the static window: psi(t) - psi(t_start) = rate (t - t_start)
    up to the tick where the rotation starts (the tick mean straddles it: at most one tick of rotation)."""
    path = synthetic(tmp_path_factory.mktemp("s"), rate, bias)
    rep = replay_log(read_log(path), SETUP, parse_schedule("none", SETUP))[0]
    run = rep.running
    assert rep.bias_rad_s[run] == pytest.approx(bias * DEG, abs=1e-12)
    t = rep.t_s[run]
    yaw = np.degrees(np.unwrap(rep.yaw_rad[run]))
    expected = rate * (t - 10.0)
    assert np.max(np.abs(yaw - expected)) <= abs(rate) / 1.9 + 1e-9


def test_grid_ticks_start_at_the_first_sample_at_the_firmware_rate(tmp_path):
    rep = replay_log(read_log(synthetic(tmp_path, 10.0, 0.0)), SETUP, parse_schedule("continuous", SETUP))[0]
    assert rep.t_s[0] == 0.0 and np.allclose(np.diff(rep.t_s), 1 / 1.9)
    assert rep.update[rep.running].all()
    err = np.degrees(np.abs(np.angle(np.exp(1j * (rep.yaw_rad[rep.running] - np.radians(10.0 * (rep.t_s[rep.running] - 10.0)))))))
    assert err.max() < 0.5  # encoder-aided: stays on the exact angle


def test_windowed_schedule_updates_only_in_windows(tmp_path):
    rep = replay_log(read_log(synthetic(tmp_path, 10.0, 0.5)), SETUP, parse_schedule("windowed:5:15", SETUP))[0]
    phase = np.remainder(rep.t_s, 20.0)
    assert np.array_equal(rep.update[rep.running], (phase < 5.0)[rep.running])


def test_recorded_schedule_needs_recorded_updates_and_no_encoder_allows_only_none(tmp_path):
    log = read_log(synthetic(tmp_path, 10.0, 0.0))
    with pytest.raises(NodesimError, match="records no reference updates"):
        replay_log(log, SETUP, parse_schedule("recorded", SETUP))
    blind = read_log(synthetic(tmp_path, 10.0, 0.0, encoder=False, name="blind.csv"))
    with pytest.raises(NodesimError, match="no encoder.*allowed --schedule none"):
        replay_log(blind, SETUP, parse_schedule("continuous", SETUP))
    assert replay_log(blind, SETUP, parse_schedule("none", SETUP))[0].running.any()


@pytest.mark.parametrize("text", ["windowed", "windowed:0:5", "single:0", "single:x", "sometimes", "none:1"])
def test_bad_schedule_texts(text):
    with pytest.raises(NodesimError, match="allowed recorded \\| config"):
        parse_schedule(text, SETUP)


def test_repaired_gap_holds_ticks_and_counts_them(tmp_path):
    path = synthetic(tmp_path, 10.0, 0.0, drop=np.arange(30 * 65, 33 * 65))  # 3 s without samples
    with pytest.raises(NodesimError, match="gap of 3.01"):
        read_log(path)
    log = read_log(path, repair=True)
    rep = replay_log(log, SETUP, parse_schedule("continuous", SETUP))[0]
    assert log.repairs == {"gaps": 1}
    assert rep.held_ticks == math.floor(3.0 * 1.9)  # ticks whose (t_{k-1}, t_k] holds no sample
    # without the repair flag the averaging refuses an empty tick
    from nodesim.replay.reader import ReplayLog

    strict = ReplayLog(log.path, log.meta, log.nodes, log.row_kind, {}, log.max_gap_s, hold_gaps=False)
    with pytest.raises(NodesimError, match="has no sensor sample"):
        replay_log(strict, SETUP, parse_schedule("continuous", SETUP))


def test_fixed_and_float_replays_agree(tmp_path):
    log = read_log(synthetic(tmp_path, 20.0, 0.3))
    fixed = FirmwareSetup.from_scenario(SCENARIO.with_overrides(**{"filter.implementation": "fixed"}))
    a = replay_log(log, SETUP, parse_schedule("windowed:10:10", SETUP))[0]
    b = replay_log(log, fixed, parse_schedule("windowed:10:10", SETUP))[0]
    d = np.degrees(np.angle(np.exp(1j * (a.yaw_rad - b.yaw_rad))))
    assert np.nanmax(np.abs(d)) < 1e-3 and b.overflows is not None


def test_seq_is_copied_to_the_timeseries(tmp_path):
    from nodesim.replay.output_files import timeseries_columns

    t = np.arange(200) / 20.0
    cols = {"t_s": t, "encoder": np.zeros_like(t), "seq": np.floor(t), **{c: np.zeros_like(t) for c in lf.GYRO + lf.ACCEL}}
    cols["accel_z"] = np.full_like(t, 9.8)
    log = read_log(write_log(tmp_path / "seq.csv", [NodeRecording(1, cols)], lf.LogMeta()))
    reps = replay_log(log, SETUP, parse_schedule("continuous", SETUP))
    ts = timeseries_columns(log.nodes, reps)
    assert np.array_equal(ts["seq"], np.floor(reps[0].t_s))  # the row at the tick time carries floor(t)


@pytest.mark.parametrize(("header", "message"), [
    ({"gyro_unit": "counts"}, "gyro_unit = counts needs gyro_lsb_per_deg_s > 0"),
    ({"encoder_unit": "counts", "encoder_counts_per_rev": 0}, "encoder_counts_per_rev > 0"),
    ({"angle_unit": "grad"}, r"angle_unit = 'grad' is not a known unit; allowed \['rad', 'deg'\]"),
    ({"adc_bits": 12}, r"adc_bits = 12; allowed \[16, 32\]"),
    ({"colour": "red"}, "unknown header key 'colour'"),
    ({"adc_bits": "many"}, "header adc_bits = 'many' is not a valid int"),
])
def test_bad_headers(header, message):
    with pytest.raises(NodesimError, match=message):
        lf.meta_from_dict(header, "log.csv")


def test_deg_and_g_units_convert():
    meta = lf.meta_from_dict({"gyro_unit": "deg/s", "accel_unit": "g", "encoder_unit": "deg", "angle_unit": "deg"}, "x")
    assert meta.gyro_to_rad_s == pytest.approx(DEG) and meta.encoder_to_rad == pytest.approx(DEG)
    from nodesim.units import G0_M_S2

    assert meta.accel_to_m_s2 == G0_M_S2 and meta.angle_to_rad == pytest.approx(DEG)
