"""Calibration: round trips for both methods, the calibration paper's Tables II-V, the CLI and bad input."""

import json
import tomllib
from importlib import resources

import numpy as np
import pytest

from nodesim.sensors.calibration import (
    calibrate,
    least_squares,
    read_positions,
    simulate_positions,
    six_position_rates,
    turntable,
)
from nodesim.cli.main import main
from nodesim.errors import NodesimError

DATA = resources.files("nodesim") / "data" / "calibration"
TRUE_M = np.array([[1.02, 0.015, -0.008], [-0.012, 0.985, 0.02], [0.005, -0.01, 1.01]])
TRUE_B = np.array([0.3, -0.15, 0.05])


def _paper(name):
    with resources.as_file(DATA / f"{name}.csv") as p:
        return read_positions(p)


def _published(name):
    pub = tomllib.loads((DATA / "published.toml").read_text())[name]
    m = np.array(pub["matrix"])
    return (m.T if pub["transpose"] else m), np.array(pub["bias"])


def test_turntable_round_trip_within_noise_implied_tolerance():
    """Thesis III.1.5-18: +/-r about each axis; error of a column = sigma_mean / r (sqrt(2)/2 from the pair)."""
    rng = np.random.default_rng(11)
    rate, sigma, samples = 200.0, 0.5, 1000
    true = six_position_rates(rate)
    meas = simulate_positions(true, TRUE_M, TRUE_B, sigma, samples, rng)
    cal = turntable(true, meas)
    sigma_mean = sigma / np.sqrt(samples)
    assert np.all(np.abs(cal.matrix - TRUE_M) < 4 * sigma_mean / (np.sqrt(2) * rate))
    assert np.all(np.abs(cal.bias - TRUE_B) < 4 * sigma_mean / np.sqrt(6))
    assert np.allclose(cal.apply(meas), true, atol=4 * sigma_mean * 3)


def test_least_squares_round_trip_multi_position_accelerometer():
    """Thesis III.1.19-29: 12 parameters from multi-position gravity data; error within 4 sigma of the LS covariance."""
    rng = np.random.default_rng(12)
    dirs = rng.normal(size=(24, 3))
    true = 9.81 * dirs / np.linalg.norm(dirs, axis=1, keepdims=True)
    meas = simulate_positions(true, TRUE_M, TRUE_B, 0.03, 1000, rng)
    cal = least_squares(true, meas)
    theta_err = np.concatenate([cal.bias - TRUE_B, (cal.matrix - TRUE_M).ravel()])
    assert np.all(np.abs(theta_err) < 4 * cal.parameter_std)
    assert cal.rms_residual == pytest.approx(0.03 / np.sqrt(1000), rel=0.4)


def test_both_methods_agree_on_two_direction_data():
    """Thesis App. III: basic and least-squares methods agree on the same six positions."""
    rng = np.random.default_rng(13)
    true = six_position_rates(720.0)
    meas = simulate_positions(true, TRUE_M, TRUE_B, 0.2, 500, rng)
    a, b = turntable(true, meas), least_squares(true, meas)
    assert np.allclose(a.matrix, b.matrix, atol=1e-12) and np.allclose(a.bias, b.bias, atol=1e-12)


@pytest.mark.parametrize(
    "case,bias,row0,rms",
    [
        ("vn100t_accel", [-1.0760, 0.9729, 0.4108], [-3.6957, 9.0528, 0.8310], 0.0124),
        ("mpu9255_accel", [0.1030, 0.0793, 0.1296], [-0.7645, -0.6450, -0.1070], 0.0012),
        ("vn100t_gyro", [-0.13133, 0.01650, -0.12917], [-0.92904, 0.37122, 0.00105], 0.127),
        ("mpu9255_gyro", [0.02172, 0.01750, -0.01167], [0.63875, 0.77025, 0.01415], 0.061),
    ],
)
def test_paper_tables_ii_to_v_through_the_estimator(case, bias, row0, rms):
    """Calibration paper Tables I-V (R = I on the averaged outputs); reference values: paper digest section 5."""
    cal = least_squares(*_paper(case))
    assert np.allclose(cal.bias, bias, atol=2e-4)
    assert np.allclose(cal.matrix[0], row0, atol=2e-4)
    assert cal.rms_residual == pytest.approx(rms, rel=0.02)


def test_published_gyro_matrices_eq_15_16_transposed_match_tables_iv_v():
    """Eq 15 (VN-100T) matches our fit to the printed 3 decimals; eq 16 differs in one sign (M_zx, digest section 5)."""
    vn = least_squares(*_paper("vn100t_gyro"))
    m_pub, _ = _published("vn100t_gyro")
    assert np.max(np.abs(vn.matrix - m_pub)) < 2e-3
    mpu = least_squares(*_paper("mpu9255_gyro"))
    m_pub, _ = _published("mpu9255_gyro")
    diff = np.abs(mpu.matrix - m_pub)
    assert np.unravel_index(np.argmax(diff), diff.shape) == (0, 2)  # printed (3,1) -> M_xz after transposing
    assert diff[0, 2] == pytest.approx(0.028, abs=1e-3)  # data +0.0141, published -0.014
    diff[0, 2] = 0.0
    assert diff.max() < 2e-3


def test_published_parameters_forward_residuals_documented():
    """Residuals of the published eqs 13-16 on Tables II-V (digest section 5): VN accel rms ~0.063 m/s^2, MPU ~0.047 g."""
    for case, expected in (("vn100t_accel", 0.063), ("mpu9255_accel", 0.047)):
        true, meas = _paper(case + "_printed_true")
        m, b = _published(case)
        res = meas - (true @ m.T + b)
        assert np.sqrt(np.mean(res**2)) == pytest.approx(expected, rel=0.1)


def test_cli_json_contract(tmp_path, capsys):
    csv = tmp_path / "six.csv"
    true = six_position_rates(100.0)
    meas = true @ TRUE_M.T + TRUE_B
    rows = ["true_x,true_y,true_z,meas_x,meas_y,meas_z"] + [",".join(repr(float(v)) for v in [*t, *m]) for t, m in zip(true, meas)]
    csv.write_text("\n".join(rows) + "\n")
    for method in ("turntable", "lsq"):
        assert main(["calibrate", str(csv), "--method", method, "--json"]) == 0
        out = json.loads(capsys.readouterr().out)
        assert np.allclose(out["matrix"], TRUE_M) and np.allclose(out["bias"], TRUE_B)
        assert len(out["residuals"]) == 6 and out["rms_residual"] < 1e-9 and out["method"] == method
    assert main(["calibrate", str(csv)]) == 0
    assert "matrix" in capsys.readouterr().out


@pytest.mark.parametrize(
    "text,match",
    [
        ("true_x,true_y,meas_x,meas_y,meas_z\n1,0,1,0,0\n", "missing column.*true_z"),
        ("true_x,true_y,true_z,meas_x,meas_y,meas_z\n1,0,0,abc,0,0\n", "line 2, column meas_x: 'abc'"),
        ("true_x,true_y,true_z,meas_x,meas_y,meas_z\n1,0,0,1,0\n", "line 2: 5 fields"),
        ("true_x,true_y,true_z,meas_x,meas_y,meas_z\n", "no data rows"),
        ("", "empty calibration data file"),
        ("true_x,true_y,true_z,meas_x,meas_y,meas_z\n1,0,0,1,0,0\n0,1,0,0,1,0\n0,0,1,0,0,1\n", "need >= 12"),
        ("true_x,true_y,true_z,meas_x,meas_y,meas_z\n" + "1,0,0,1,0,0\n" * 5, "do not determine"),
    ],
)
def test_bad_calibration_files_exit_2_with_a_clear_message(tmp_path, capsys, text, match):
    p = tmp_path / "bad.csv"
    p.write_text(text)
    assert main(["calibrate", str(p)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    import re

    assert re.search(match, err), err


def test_turntable_rejects_off_axis_and_unpaired_positions():
    with pytest.raises(NodesimError, match="row 2 .* not along one axis"):
        turntable([[1, 0, 0], [1, 1, 0], [0, 1, 0]], np.zeros((3, 3)))
    with pytest.raises(NodesimError, match="axis y needs a positive and a negative"):
        turntable([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, 0, 1], [0, 0, -1]], np.zeros((5, 3)))
    with pytest.raises(NodesimError, match="unknown method"):
        calibrate(np.eye(3), np.eye(3), "magic")


def test_missing_file_is_a_clear_error(tmp_path, capsys):
    assert main(["calibrate", str(tmp_path / "none.csv")]) == 2
    assert "cannot read calibration data" in capsys.readouterr().err
