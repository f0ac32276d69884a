"""The what-if scenarios of scenarios/whatif/: wetter soil -> stale updates -> azimuth error at the bottom
node, reported in summary.json (issue 7)."""

import csv
import json
from importlib import resources

from nodesim.api import simulate_scenario
from nodesim.scenario.schema import load_scenario


def _run(name, tmp_path):
    with resources.as_file(resources.files("scenarios") / "whatif" / name) as p:
        s, digest = load_scenario(p)
    s = s.with_overrides(**{"simulation.realizations": 3})
    out = simulate_scenario(s, digest).save(tmp_path / name, plots=False)
    return json.loads((out / "summary.json").read_text()), out


def test_wetter_soil_stales_the_updates_and_raises_the_bottom_azimuth_error(tmp_path):
    dry, dry_dir = _run("soil_vwc_0p20.toml", tmp_path)
    wet, _ = _run("soil_vwc_0p30.toml", tmp_path)
    assert dry["delivery_ratio"] > 0.99 and dry["max_time_since_update_s"] < 1.0
    assert wet["delivery_ratio"] < dry["delivery_ratio"] - 0.1
    assert wet["max_time_since_update_s"] > 60.0  # the bottom node coasts for minutes
    assert wet["update_fraction"] < 0.5 * dry["update_fraction"]
    assert wet["rms_azimuth_error_deg"] > 2 * dry["rms_azimuth_error_deg"]
    assert wet["retransmissions"] > 10 * max(dry["retransmissions"], 1.0)
    rows = list(csv.DictReader((dry_dir / "hops.csv").open()))
    assert [r["kind"] for r in rows] == ["cable", "soil", "soil", "soil", "soil"]
    assert abs(float(rows[1]["mean_path_loss_db"]) - 104.1) < 0.1  # 2 m, vwc 0.2 (nodesim link soil)


def test_soil_water_rising_within_one_run_ends_stale(tmp_path):
    s, _ = _run("soil_water_rising.toml", tmp_path)
    assert s["max_time_since_update_s"] > 60.0 and s["rms_azimuth_error_deg"] is not None
