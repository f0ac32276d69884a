"""scenarios/whatif/gyro_full_scale.toml (issue 19 must-show): a string spinning at 360 deg/s past the gyro's
250 deg/s range clips (adc_clipped_samples > 0 in summary.json) and has a larger yaw error than the same run with
a 500 deg/s range; the bundled lab scenarios clip nothing."""

import json
from importlib import resources

from nodesim.api import simulate_scenario
from nodesim.chain.metrics import per_realization_metrics, summarize
from nodesim.chain.network import simulate_chain
from nodesim.scenario.schema import load_scenario


def _scenario(folder, name):
    with resources.as_file(resources.files("scenarios") / folder / name) as p:
        return load_scenario(p)


def test_gyro_past_full_scale_clips_and_loses_yaw(tmp_path):
    s, digest = _scenario("whatif", "gyro_full_scale.toml")
    s = s.with_overrides(**{"simulation.realizations": 2})
    out = simulate_scenario(s, digest).save(tmp_path / "fs250", plots=False)
    clipped = json.loads((out / "summary.json").read_text())
    wide = s.with_overrides(**{"sensor.gyro_full_scale_dps": 500})
    inside = summarize(per_realization_metrics(simulate_chain(wide), wide.metrics))
    # 100 s at 360 deg/s: every z-gyro sample of the fast rotation clips (65 per second)
    assert clipped["adc_clipped_samples"] > 0.9 * 100 * 65
    assert inside["adc_clipped_samples"] == 0
    assert clipped["rms_yaw_error_deg"] > 10 * inside["rms_yaw_error_deg"]


def test_bundled_lab_scenarios_clip_nothing():
    """Read through the count model (sensor.model = "mpu6500_counts"), the lab profile stays inside the ranges."""
    folder = resources.files("scenarios") / "lab"
    names = sorted(p.name for p in folder.iterdir() if p.name.endswith(".toml"))
    assert len(names) == 11
    for name in names:
        s, _ = _scenario("lab", name)
        s = s.with_overrides(**{"sensor.model": "mpu6500_counts"})
        m = summarize(per_realization_metrics(simulate_chain(s), s.metrics))
        assert m["adc_clipped_samples"] == 0, name
