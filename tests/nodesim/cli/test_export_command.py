"""`nodesim export` (nodesim.interop): welleng and LAS round trips, feet, and the errors."""

import json
from pathlib import Path

import numpy as np
import pytest

from nodesim.cli.main import main
from nodesim.interop import FT_M, export_table, read_welleng_csv, to_welleng

REPO = Path(__file__).resolve().parents[3]
WB1 = REPO / "scenarios" / "field" / "thesis_wellbore1_survey.csv"
# a 3D survey with a build, a turn and a drop: minimum curvature differs from the tangential methods here
SURVEY = "md_m,inc_deg,azi_deg\n0,0,0\n300,0.5,20\n600,8,35\n900,25,60\n1200,42,75\n1500,55,71\n1800,48,90\n2100,30,110\n"


@pytest.fixture
def survey_csv(tmp_path):
    p = tmp_path / "well.csv"
    p.write_text(SURVEY)
    return p


@pytest.mark.parametrize("units", ["m", "ft"])
def test_welleng_computes_our_positions_from_the_export(survey_csv, tmp_path, units, capsys):
    """welleng's own minimum curvature (welleng.survey.Survey) on the exported file agrees with our N, E, TVD to
    1e-6 m, in metres and in feet (converted back with 1 ft = 0.3048 m)."""
    welleng_survey = pytest.importorskip("welleng.survey")
    out = tmp_path / f"well.{units}.csv"
    assert main(["export", str(survey_csv), "--to", "welleng", "--units", units, "-o", str(out)]) == 0
    md, inc, azi, unit = read_welleng_csv(out)
    assert unit == {"m": "meters", "ft": "feet"}[units]
    s = welleng_survey.Survey(md=md, inc=inc, azi=azi, header=welleng_survey.SurveyHeader(depth_unit=unit), unit=unit)
    scale = FT_M if units == "ft" else 1.0
    ours = export_table(survey_csv)
    assert abs(ours.n_m[-1]) > 100 and abs(ours.e_m[-1]) > 500  # a real 3D wellpath
    for theirs, mine in ((s.n, ours.n_m), (s.e, ours.e_m), (s.tvd, ours.tvd_m)):
        assert np.max(np.abs(np.asarray(theirs) * scale - mine)) < 1e-6
    w = to_welleng(survey_csv, units=units)  # the Python helper gives welleng the same survey
    assert np.max(np.abs(np.asarray(w.tvd) * scale - ours.tvd_m)) < 1e-6


def test_las_round_trip_reads_back_what_we_wrote(survey_csv, tmp_path, capsys):
    lasio = pytest.importorskip("lasio")
    out = tmp_path / "well.las"
    assert main(["export", str(survey_csv), "--to", "las", "--units", "ft", "--tool", "dip", "-o", str(out)]) == 0
    las = lasio.read(str(out))
    t = export_table(survey_csv, tool="dip")
    assert las.version["VERS"].value == 2.0
    assert las.curves["DEPT"].unit == "FT" and las.curves["INC"].unit == "DEG"
    np.testing.assert_allclose(las.index, t.md_m / FT_M, rtol=1e-9)
    np.testing.assert_allclose(las["TVD"], t.tvd_m / FT_M, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(las["AZI"], t.azi_deg, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(las["SIGMA1_MAJOR"], t.axes_1sigma_m[:, 0] / FT_M, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(las["SIGMA2_HMAJOR"], 2 * t.horizontal_1sigma_m[:, 0] / FT_M, rtol=1e-9, atol=1e-12)
    assert np.all(np.diff(las["SIGMA1_MAJOR"]) >= 0) and las["SIGMA1_MAJOR"][-1] > 0  # uncertainty grows


def test_csv_export_of_a_run_directory_and_of_the_uncertainty_command_agree(tmp_path, capsys):
    """A run directory exports its ground_survey.csv; the semi-axes equal `nodesim uncertainty`'s per-axis figures."""
    run = tmp_path / "run"
    run.mkdir()
    (run / "ground_survey.csv").write_text(WB1.read_text())
    out = tmp_path / "wb1.csv"
    assert main(["export", str(run), "--to", "csv", "--tool", "dip", "-o", str(out)]) == 0
    capsys.readouterr()
    lines = [ln for ln in out.read_text().splitlines() if not ln.startswith("#")]
    header = lines[0].split(",")
    assert header[:3] == ["md_m", "inc_deg", "azi_deg"] and "sigma2_hmajor_m" in header
    data = np.array([[float(v) for v in ln.split(",")] for ln in lines[1:]])
    assert main(["uncertainty", str(WB1), "--tool", "dip", "--json"]) == 0
    ref = json.loads(capsys.readouterr().out)["stations"]
    np.testing.assert_allclose(data[:, header.index("tvd_m")], [s["tvd_m"] for s in ref], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(data[:, header.index("sigma1_hmajor_m")], [s["horizontal_semi_major_m"] for s in ref],
                               rtol=1e-9, atol=1e-15)


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--to", "csv"], "no ground_survey.csv"),
        (["--to", "csv", "--tool", "gyro9000"], "unknown tool"),
    ],
)
def test_export_errors_exit_2(tmp_path, capsys, argv, message):
    (tmp_path / "lab-run").mkdir()
    src = tmp_path / "lab-run" if "--tool" not in argv else tmp_path / "s.csv"
    (tmp_path / "s.csv").write_text(SURVEY)
    assert main(["export", str(src), *argv, "-o", str(tmp_path / "x")]) == 2
    assert message in capsys.readouterr().err and not (tmp_path / "x").exists()


def test_uncertainty_reads_feet_and_las_and_gives_the_metric_answer(survey_csv, tmp_path, capsys):
    """The same well as md_ft CSV (--units ft) and as our LAS export in feet: the same metre positions."""
    pytest.importorskip("lasio")
    assert main(["uncertainty", str(survey_csv), "--tool", "dip", "--json"]) == 0
    ref = json.loads(capsys.readouterr().out)["stations"]
    lines = SURVEY.splitlines()
    ft = tmp_path / "well_ft.csv"
    ft.write_text("\n".join(["md_ft,inc_deg,azi_deg"] + [
        f"{float(r.split(',')[0]) / FT_M!r},{r.split(',', 1)[1]}" for r in lines[1:]]) + "\n")
    las = tmp_path / "well.las"
    assert main(["export", str(survey_csv), "--to", "las", "--units", "ft", "-o", str(las)]) == 0
    capsys.readouterr()
    for src in (ft, las):
        assert main(["uncertainty", str(src), "--tool", "dip", "--units", "ft", "--json"]) == 0
        got = json.loads(capsys.readouterr().out)["stations"]
        np.testing.assert_allclose([s["tvd_m"] for s in got], [s["tvd_m"] for s in ref], rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose([s["sigma_n_m"] for s in got], [s["sigma_n_m"] for s in ref], rtol=1e-7)
    assert main(["uncertainty", str(las), "--tool", "dip", "--units", "m"]) == 2
    assert "depth unit is FT but --units m" in capsys.readouterr().err
    assert main(["uncertainty", str(survey_csv), "--tool", "dip", "--units", "ft"]) == 2
    assert "md_ft" in capsys.readouterr().err
