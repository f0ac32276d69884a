"""A real recording no one here made: scikit-kinematics' Pololu MinIMU-9 v5 log (BSD licence, converted by
scripts/convert_skinematics_pololu.py into tests/data/replay/pololu_skinematics.csv), replayed through the
firmware with its Allan-derived noise parameters.

The board lies still ~14 s (x up), turns ~180 deg about its z axis, lies still again.  The z axis plays the
string axis; with no reference the firmware runs free (schedule none).  Physics check: the yaw the firmware
integrates over the turn must cancel the accelerometer toolface change, so the azimuth A = tau' + psi (eq 1.3)
is the same before and after the turn.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from nodesim.errors import NodesimError
from nodesim.replay.convert import POLOLU_GYRO_DEG_S_PER_LSB
from nodesim.replay.reader import read_log
from nodesim.replay.session import replay

DATA = Path(__file__).resolve().parents[2] / "data" / "replay"
LOG = DATA / "pololu_skinematics.csv"
CONFIG = DATA / "pololu_firmware.toml"


@pytest.fixture(scope="module")
def outcome():
    return replay(LOG, CONFIG, noise="allan", allan_slope_tolerance=0.1, write=False)


def toolface_deg(node, t0, t1):
    sel = (node.t_s >= t0) & (node.t_s < t1)
    f = node.accel_m_s2[sel].mean(axis=0)
    return math.degrees(math.atan2(f[1], f[0]))


def test_fixture_reads_cleanly_in_raw_int16_counts():
    log = read_log(LOG)
    node = log.nodes[0]
    assert log.repairs == {} and node.t_s.size == 3653 and log.meta.gyro_unit == "counts"
    assert node.encoder_rad is None  # the recording has no reference
    counts = np.round(node.gyro_rad_s[:, 2] / math.radians(POLOLU_GYRO_DEG_S_PER_LSB))
    assert counts.max() == 32766  # the turn almost saturates the int16 gyro (32767)
    assert 24.0 < node.t_s[-1] - node.t_s[0] < 25.0
    assert 140 < 1 / np.median(np.diff(node.t_s)) < 170  # ~146 Hz


def test_allan_noise_of_the_static_window():
    """The 13 s still part has a ~1 Hz disturbance: the default -1/2-slope band (0.05) finds no ARW line and
    says so; a 0.1 band gives ARW ~0.05 deg/sqrt(s), ~5x the LSM6DS33 typical 0.011 dps/sqrt(Hz) (measured,
    not asserted against the datasheet: the board was not on a vibration-isolated table)."""
    with pytest.raises(NodesimError, match="no -1/2 slope region"):
        replay(LOG, CONFIG, noise="allan", write=False)
    out = replay(LOG, CONFIG, noise="allan", allan_slope_tolerance=0.1, write=False)
    assert out.summary["noise_source"] == "allan"
    assert 0.03 < out.summary["arw_deg_per_sqrt_s"] < 0.08
    assert out.summary["bias_instability_deg_s"] > 0


def test_integrated_yaw_cancels_the_toolface_change_over_the_turn(outcome):
    node = outcome.log.nodes[0]
    rep = outcome.replays[0]
    before, after = toolface_deg(node, 10.0, 13.0), toolface_deg(node, 17.5, 18.5)
    toolface_turn = (after - before + 180.0) % 360.0 - 180.0  # ~ -179 deg
    k0 = int(np.searchsorted(rep.t_s, 13.0)) - 1  # last static tick
    k1 = int(np.searchsorted(rep.t_s, 18.0)) - 1
    yaw_turn = math.degrees(rep.yaw_rad[k1] - rep.yaw_rad[k0])
    assert abs(toolface_turn) > 170.0
    assert yaw_turn + toolface_turn == pytest.approx(0.0, abs=2.0)
    # scikit-kinematics' own 4.375e-3 deg/s per LSB would have integrated only half the turn
    assert yaw_turn * 4.375e-3 / POLOLU_GYRO_DEG_S_PER_LSB == pytest.approx(90.0, abs=2.0)


def test_free_running_yaw_after_the_turn_drifts_faster_than_its_sigma(outcome):
    """Measured gap: after the turn the yaw drifts ~1.4 deg/s with the board still (toolface constant): the
    z-gyro bias changed with the board upside down (g-sensitivity); the filter's sigma (Allan-derived Q, no
    reference) grows to ~2.3 deg, ~3.5x below the ~8 deg drift. Recorded, not hidden."""
    rep = outcome.replays[0]
    k1, k2 = (int(np.searchsorted(rep.t_s, t)) for t in (18.0, 24.0))
    drift = math.degrees(rep.yaw_rad[k2] - rep.yaw_rad[k1]) / (rep.t_s[k2] - rep.t_s[k1])
    assert -2.0 < drift < -1.0
    sigma = np.degrees(np.sqrt(rep.yaw_var_rad2[rep.running]))
    assert np.all(np.diff(sigma) > 0)  # no reference: P only grows
    assert abs(drift) * (rep.t_s[k2] - rep.t_s[k1]) > 3.0 * sigma[-1]


def test_cli_replay_of_the_fixture_and_a_malformed_copy(tmp_path, capsys):
    from nodesim.cli.main import main

    assert main(["replay", str(LOG), "--firmware", str(CONFIG), "--out", str(tmp_path / "ok"), "--json"]) == 0
    import json

    summary = json.loads(capsys.readouterr().out)
    assert summary["schedule"] == "none" and summary["repairs"] == {} and "comparison" not in summary
    assert (tmp_path / "ok" / "yaw_error.png").is_file()
    lines = LOG.read_text().splitlines()
    first = next(i for i, line in enumerate(lines) if line.startswith("node,")) + 1
    lines[first + 100] = lines[first + 99]  # a duplicated sample
    bad = tmp_path / "bad.csv"
    bad.write_text("\n".join(lines) + "\n")
    assert main(["replay", str(bad), "--firmware", str(CONFIG), "--out", str(tmp_path / "bad")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"line {first + 101}: duplicated time on node 1" in err
    assert not (tmp_path / "bad").exists()
    assert main(["replay", str(bad), "--firmware", str(CONFIG), "--out", str(tmp_path / "fixed"), "--repair", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["repairs"] == {"dropped_duplicate_time": 1}
