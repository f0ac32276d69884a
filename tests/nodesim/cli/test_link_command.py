"""``nodesim link soil|pipe``: JSON contract, sweeps, plots, max distance, and bad input (exit 2, one line)."""

import json

import numpy as np
import pytest

from nodesim.cli.main import main

QUALITY = {"noise_floor_dbm", "snr_db", "ber", "packet_error_rate"}
SOIL_KEYS = {"path_loss_db", "rss_dbm", "margin_db", "alpha_np_per_m", "beta_rad_per_m", "max_distance_m"} | QUALITY
PIPE_KEYS = {"cutoff_hz", "attenuation_db_per_m", "loss_db", "margin_db", "max_length_m", "propagating_modes"} | QUALITY


def run_json(capsys, *argv):
    assert main(["link", *argv, "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def test_soil_json_keys_and_thesis_defaults(capsys):
    out = run_json(capsys, "soil", "--vwc", "0.01")
    assert SOIL_KEYS <= set(out)
    assert out["inputs"]["frequency_hz"] == 868e6 and out["inputs"]["distance_m"] == 0.3
    assert out["rss_dbm"] == pytest.approx(2.0 - out["path_loss_db"])
    assert out["margin_db"] == pytest.approx(out["rss_dbm"] + 110.0)


def test_pipe_json_keys(capsys):
    out = run_json(capsys, "pipe")
    assert PIPE_KEYS <= set(out)
    assert {"TE11", "TM01", "TE21"} <= set(out["cutoff_hz"])
    assert out["cutoff_hz"]["TE11"] == pytest.approx(2.928e9, rel=0.005)
    assert out["propagating_modes"] == ["TE11", "TM01", "TE21"]
    assert out["loss_db"] == pytest.approx(out["attenuation_db_per_m"] * 3.0)
    assert out["margin_db"] == pytest.approx(110.0 - out["loss_db"])


def test_max_distance_keeps_the_target_margin(capsys):
    soil = run_json(capsys, "soil", "--target-margin-db", "20")
    again = run_json(capsys, "soil", "--distance-m", str(soil["max_distance_m"]))
    assert again["margin_db"] == pytest.approx(20.0, abs=1e-6)
    pipe = run_json(capsys, "pipe", "--target-margin-db", "0")
    again = run_json(capsys, "pipe", "--length-m", str(pipe["max_length_m"]))
    assert again["margin_db"] == pytest.approx(0.0, abs=1e-6)


def test_soil_sweep_is_monotonic_in_water_content(capsys):
    out = run_json(capsys, "soil", "--sweep", "vwc=0.01:0.8:20")
    assert out["sweep"]["key"] == "vwc" and len(out["sweep"]["values"]) == 20
    assert np.all(np.diff(out["rss_dbm"]) < 0)


def test_pipe_sweep_across_cutoff_reports_null_not_a_number(capsys):
    out = run_json(capsys, "pipe", "--sweep", "radius=0.01:0.05:5")
    assert out["sweep"]["key"] == "radius_m"
    assert out["attenuation_db_per_m"][0] is None and out["margin_db"][0] is None
    assert all(v is not None for v in out["attenuation_db_per_m"][1:])
    assert len(out["cutoff_hz"]["TE11"]) == 5


def test_pipe_resistivity_grade_and_filling_options(capsys):
    base = run_json(capsys, "pipe")
    hot = run_json(capsys, "pipe", "--temperature-c", "200")
    assert hot["attenuation_db_per_m"] > base["attenuation_db_per_m"]
    given = run_json(capsys, "pipe", "--resistivity-ohm-m", "1.12e-7")
    assert given["attenuation_db_per_m"] == pytest.approx(0.034, rel=0.01)
    graded = run_json(capsys, "pipe", "--grade", "X46 SMLS")
    assert graded["inputs"]["carbon_wt_pct"] == 0.31
    wet = run_json(capsys, "pipe", "--filling", "water")
    assert wet["attenuation_db_per_m"] > 100 * base["attenuation_db_per_m"]


def test_table_output(capsys):
    assert main(["link", "pipe"]) == 0
    out = capsys.readouterr().out
    assert "TE11 2.928 GHz" in out and "attenuation_db_per_m" in out and "max_length_m" in out


def test_plot_is_written_atomically(tmp_path, capsys):
    png = tmp_path / "soil.png"
    assert main(["link", "soil", "--sweep", "vwc=0.01:0.8:10", "--plot", str(png)]) == 0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    capsys.readouterr()
    png2 = tmp_path / "pipe.png"
    assert main(["link", "pipe", "--plot", str(png2), "--json"]) == 0
    json.loads(capsys.readouterr().out)  # --json still prints only JSON
    assert png2.exists()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]


@pytest.mark.parametrize("argv, words", [
    (["soil", "--distance-m", "-0.3"], "distance_m"),
    (["soil", "--sand", "1.2"], "sand"),
    (["soil", "--clay", "-0.1"], "clay"),
    (["soil", "--sand", "0.7", "--clay", "0.5"], "sand + clay"),
    (["soil", "--vwc", "0"], "vwc"),
    (["soil", "--frequency-hz", "0"], "frequency_hz"),
    (["pipe", "--frequency-hz=-5e9"], "frequency_hz"),
    (["pipe", "--radius-m", "0"], "radius_m"),
    (["pipe", "--frequency-hz", "2.4e9"], "no mode propagates"),
    (["pipe", "--length-m", "-1"], "length_m"),
    (["pipe", "--grade", "X99"], "grade"),
    (["pipe", "--filling", "water", "--temperature-c", "100"], "water temperature"),
    (["pipe", "--carbon-wt-pct", "1.0"], "carbon_wt_pct"),
    (["soil", "--radius-m", "0.03"], "do not apply"),
    (["soil", "--sweep", "moisture=0:1:3"], "allowed"),
    (["soil", "--sweep", "vwc=0:1"], "START:STOP:N"),
    (["soil", "--sweep", "vwc=0.01:0.8:1"], "N must be"),
])
def test_bad_input_exits_2_with_one_clear_line(argv, words, capsys):
    assert main(["link", *argv]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and words in err


def test_packet_error_rate_follows_the_margin(capsys):
    """End to end: wetter soil at 1.2 m -> less margin -> higher PER; a pipe sweep past max length -> PER -> 1."""
    out = run_json(capsys, "soil", "--distance-m", "1.2", "--sweep", "vwc=0.2:0.8:7", "--frame-bits", "256")
    assert np.all(np.diff(out["margin_db"]) < 0)
    assert np.all(np.diff(out["packet_error_rate"]) >= 0) and out["packet_error_rate"][-1] > out["packet_error_rate"][0]
    pipe = run_json(capsys, "pipe", "--sweep", "length_m=100:4000:40")
    assert pipe["packet_error_rate"][0] == 0.0 and pipe["packet_error_rate"][-1] == 1.0
    below = run_json(capsys, "pipe", "--sweep", "frequency_hz=2e9:5e9:4")
    assert below["packet_error_rate"][0] == pytest.approx(1.0) and below["snr_db"][0] is None


def test_water_filled_pipe_swept_over_temperature(capsys):
    """Water's permittivity follows the swept temperature: the attenuation is a curve, the mode list is
    per point (null), and nothing crashes (it raised 'truth value of an array is ambiguous')."""
    out = run_json(capsys, "pipe", "--filling", "water", "--sweep", "temperature_c=5:35:3")
    assert out["propagating_modes"] is None and len(out["attenuation_db_per_m"]) == 3
    assert len(set(out["attenuation_db_per_m"])) == 3
