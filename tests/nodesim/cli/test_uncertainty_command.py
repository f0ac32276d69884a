"""``nodesim uncertainty``: text, JSON contract, plot, and clear errors (exit 2, naming row/key)."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from nodesim.cli.main import main

REPO = Path(__file__).resolve().parents[3]
WB1 = REPO / "scenarios" / "field" / "thesis_wellbore1_survey.csv"


def test_text_output(capsys):
    assert main(["uncertainty", str(WB1), "--tool", "vn100t", "--sigma", "2"]) == 0
    out = capsys.readouterr().out
    assert "2 sigma" in out and len(out.splitlines()) == 13


def test_json_contract_and_plot(tmp_path, capsys):
    png = tmp_path / "u.png"
    assert main(["uncertainty", str(WB1), "--tool", "mpu6500_filtered", "--json", "--plot", str(png)]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["tool"] == "mpu6500_filtered"
    assert {s["code"] for s in data["sources"]} >= {"AZ-FILTER", "ABXY-TI1S"}
    st = data["stations"]
    assert len(st) == 11
    for key in ("md_m", "n_m", "e_m", "tvd_m", "cov_nev_m2"):
        assert key in st[0]
    cov = np.array(st[-1]["cov_nev_m2"])
    assert cov.shape == (3, 3) and np.allclose(cov, cov.T)
    assert st[-1]["sigma_n_m"] == pytest.approx(np.sqrt(cov[0, 0]))
    assert png.stat().st_size > 1000


def test_sigma_95_and_time_column(tmp_path, capsys):
    p = tmp_path / "s.csv"
    p.write_text("md_m,inc_deg,azi_deg,time_s\n0,0,0,0\n10,5,45,100\n20,10,45,400\n")
    assert main(["uncertainty", str(p), "--tool", "stim300", "--json", "--sigma", "95"]) == 0
    a = json.loads(capsys.readouterr().out)
    assert a["scale"] == pytest.approx(1.96, abs=1e-3)
    assert main(["uncertainty", str(p), "--tool", "stim300", "--json", "--sigma", "1", "--seconds-per-station", "1"]) == 0
    b = json.loads(capsys.readouterr().out)  # time_s in the file wins over --seconds-per-station
    assert a["stations"][-1]["sigma_n_m"] == pytest.approx(1.959964 * b["stations"][-1]["sigma_n_m"], rel=1e-5)


@pytest.mark.parametrize(
    "text, args, pattern",
    [
        ("md_m,inc_deg,azi_deg\n0,0,0\n10,5,0\n5,5,0\n", [], "line 4: md_m 5 is decreasing"),
        ("md_m,inc_deg,azi_deg\n0,0,0\n10,5,0\n10,5,0\n", [], "line 4: md_m 10 is duplicate"),
        ("md_m,inc_deg,azi_deg\n0,0,0\n10,190,0\n", [], r"line 3: inc_deg 190 is outside \[0, 180\]"),
        ("md_m,inc_deg,azi_deg\n0,0,0\n10,nan,0\n", [], "line 3: inc_deg is not a finite number"),
        ("md_m,inc_deg,azi_deg\n0,0,0\n10,5,0\n", ["--tool", "gyro9000"], "unknown tool 'gyro9000'"),
        # "line N" is the file's line as an editor numbers it: comments and blank lines count
        ("# well A\n\nmd_m,inc_deg,azi_deg\n# tie-in\n0,0,0\n10,5,0\n5,5,0\n", [], "line 7: md_m 5 is decreasing"),
        ("md_m,inc_deg,azi_deg\n0,0,0\n10,5,-400\n", [], r"line 3: azi_deg -400 is outside \[0, 360\]"),
        ("md_m,inc_deg,azi_deg,sigma_azimuth\n0,0,0,1\n10,5,0,1\n", [], r"line 1: unknown column\(s\) \['sigma_azimuth'\]"),
    ],
)
def test_bad_input_exits_2_with_one_line(tmp_path, text, args, pattern, capsys):
    import re

    p = tmp_path / "bad.csv"
    p.write_text(text)
    argv = ["uncertainty", str(p)] + (args or ["--tool", "dip"])
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and re.search(pattern, err), err


def test_console_script_json_only_on_stdout():
    proc = subprocess.run(
        [sys.executable, "-m", "nodesim.cli.main", "uncertainty", str(WB1), "--tool", "dip", "--json"],
        capture_output=True, text=True, check=False,
    )  # fmt: skip
    assert proc.returncode == 0
    json.loads(proc.stdout)


def test_sigma_columns_become_sources(tmp_path, capsys):
    p = tmp_path / "s.csv"
    p.write_text("md_m,inc_deg,azi_deg,sigma_azi_deg\n0,0,0,0\n10,5,45,0.25\n20,10,45,0.25\n")
    assert main(["uncertainty", str(p), "--tool", "mpu6500_filtered", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert "SURVEY-AZ" in {s["code"] for s in data["sources"]}


def test_propagation_thesis(capsys):
    """--propagation thesis: the replica's numbers (table 4.14 iPST-RQH A at SS10: 0.574 cm, 2 sigma), the rules
    in the JSON, and the same uncertainties on either wellpath method."""
    out = {}
    for method in ("minimum_curvature", "balanced_tangential"):
        assert main(["uncertainty", str(WB1), "--tool", "ipst_rqh", "--json", "--sigma", "2", "--propagation", "thesis",
                     "--method", method]) == 0  # fmt: skip
        out[method] = json.loads(capsys.readouterr().out)
    data = out["minimum_curvature"]
    assert data["propagation"] == "thesis" and data["method"] == "minimum_curvature"
    assert data["thesis_rules"]["sensor_mode"] == "R"
    assert {"code": "ABXY-TI2S", "why": "the table's one accelerometer x/y bias, already counted as ABXY-TI1S"} in (
        data["thesis_rules"]["folded"])
    last = data["stations"][-1]
    assert 100 * last["sigma_e_m"] == pytest.approx(0.5855, abs=1e-3)
    assert 100 * last["sigma_e_m"] == pytest.approx(0.574, rel=0.05)
    cov = np.array(last["cov_nev_m2"])
    assert np.allclose(cov, np.diag(np.diag(cov)))  # per-axis sums: no cross terms
    bt = out["balanced_tangential"]["stations"][-1]
    assert bt["sigma_e_m"] == last["sigma_e_m"] and bt["e_m"] != last["e_m"]
    assert main(["uncertainty", str(WB1), "--tool", "ipst_rqh", "--json", "--sigma", "2"]) == 0
    iscwsa = json.loads(capsys.readouterr().out)
    assert iscwsa["propagation"] == "iscwsa"
    assert iscwsa["stations"][-1]["sigma_e_m"] > 3 * last["sigma_e_m"]  # 1.92 cm under ISCWSA
    assert main(["uncertainty", str(WB1), "--tool", "ipst_rqh", "--propagation", "thesis"]) == 0
    assert "thesis-replica (per-axis running sums) uncertainties at 1 sigma" in capsys.readouterr().out


@pytest.mark.parametrize(
    "args, message",
    [
        (["--propagation", "bogus"], "argument --propagation: invalid choice: 'bogus' (choose from 'iscwsa', 'thesis')"),
        (["--method", "thesis"], "invalid wellpath method 'thesis'; choose from minimum_curvature, balanced_tangential "
                                 "('thesis' is a propagation: use --propagation thesis)"),
        (["--method", "spline"], "invalid wellpath method 'spline'; choose from minimum_curvature, balanced_tangential"),
    ],
)
def test_bad_propagation_or_method_exits_2(args, message, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["uncertainty", str(WB1), "--tool", "dip"] + args)
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert message in err, err


def test_thesis_propagation_of_a_tool_without_thesis_rules_is_a_clear_error(tmp_path, capsys):
    tool = tmp_path / "mag.toml"
    tool.write_text('name = "mag"\n[[sources]]\ncode = "MBZ"\nweight = "MBZ"\nmagnitude = 70.0\nunit = "nT"\n'
                    'propagation = "S"\n')  # fmt: skip
    assert main(["uncertainty", str(WB1), "--tool", str(tool), "--propagation", "thesis"]) == 2
    assert "error source MBZ (weight MBZ) has no thesis rule" in capsys.readouterr().err
