"""Lab figures (thesis table 4.22 and 4.2.3): what our chain reproduces, and the measured gap explained.

The continuous-mode azimuth gap (ours ~0.10 deg vs the thesis's 0.029 deg) is accelerometer noise: with
the MPU-6500 datasheet PSD of 300 ug/sqrt(Hz) (one-sided), i.e. the two-sided density N = 300 / sqrt(2) the
models use, averaged over one 1.9 Hz tick and then by the 32-point MAF, the azimuth noise at inclination I is
N sqrt(f) / sqrt(32) / sin(I) (thesis eq 1.3: A = atan2(f_y, f_x), so a horizontal force error e moves A by
e / (g sin I)).
"""

import math
from pathlib import Path

import numpy as np
import pytest

from nodesim.chain.network import simulate_chain
from nodesim.chain.metrics import per_realization_metrics, summarize
from nodesim.scenario.schema import Scenario, load_scenario
from nodesim.validation.checks_lab import lab_metrics, lab_summary, median

QUIET_GYRO = {
    "sensor.gyro_arw_deg_per_sqrt_s": 0.0,
    "sensor.gyro_residual_bias_deg_s": 0.0,
    "sensor.gyro_scale_factor_error": 0.0,
    "sensor.gyro_bias_instability_deg_s": 0.0,
    "sensor.encoder_counts_per_rev": 1 << 24,
    "simulation.realizations": 16,
    "metrics.reference_accuracy_pct": 0.0,  # against the exact geometry (the default; the lab files model the rig's)
}


def _azimuth_rms(**over) -> float:
    s = Scenario().with_overrides(**{**QUIET_GYRO, **over})
    return summarize(per_realization_metrics(simulate_chain(s), s.metrics))["rms_azimuth_error_deg"]


UNTILTED = {"sensor.residual_tilt_sigma_deg": 0.0, "firmware.alignment": "none"}  # no static tilt, no alignment
NO_ACCEL_NOISE = {"sensor.accel_noise_ug_per_sqrt_hz": 0.0}


def _noise_part(**over) -> float:
    """The accelerometer-noise part of the untilted perfect-gyro azimuth error: the RMS with the noise, less (in
    quadrature) the same run without it.  What the noise-free run keeps is deterministic: the count model sums
    discrete 65 Hz samples whose mean time is not the tick window's middle, which the firmware's mid-window yaw
    assumes (at the 71 deg/s fast turns ~0.4 ms of offset on average: ~0.03 deg); the two are independent, so
    their squares add."""
    total, deterministic = _azimuth_rms(**UNTILTED, **over), _azimuth_rms(**{**UNTILTED, **over, **NO_ACCEL_NOISE})
    return math.sqrt(total**2 - deterministic**2)


def test_continuous_azimuth_floor_is_the_accelerometer_noise():
    density_ug = Scenario().sensor.accel_noise_ug_per_sqrt_hz
    assert density_ug == pytest.approx(300.0 / math.sqrt(2.0))  # the datasheet's one-sided 300 ug/sqrt(Hz)
    floor = math.degrees(density_ug * 1e-6 * math.sqrt(1.9) / math.sqrt(32) / math.sin(math.radians(2.0)))
    assert floor == pytest.approx(0.0849, abs=0.001)
    assert _noise_part() == pytest.approx(floor, rel=0.1)  # perfect gyro: the accelerometer's noise
    # halving the noise halves its part; a steeper hole shrinks it as 1 / sin(I)
    assert _noise_part(**{"sensor.accel_noise_ug_per_sqrt_hz": density_ug / 2}) == pytest.approx(floor / 2, rel=0.1)
    steep = _noise_part(**{"motion.inclination_deg": 8.0})
    assert steep == pytest.approx(floor * math.sin(math.radians(2.0)) / math.sin(math.radians(8.0)), rel=0.1)
    # the sensor as bundled adds the residual tilt (thesis table 4.20) less what the alignment offset removes, and
    # the real gyro: each adds on top of the floor; the gyro's part is the yaw error while the bias converges after
    # the stop (~66 s with B as process noise, filter.b_tuning: inside the 370-570 s window), gone once it has
    untilted, aligned = _azimuth_rms(**UNTILTED), _azimuth_rms()
    ours = _lab_continuous_azimuth_rms()
    assert floor < untilted < aligned < ours
    # the bundled case measures against the rig's measured truth (metrics.reference_accuracy_pct): larger again
    assert lab_summary("continuous")["rms_azimuth_error_deg"] > 2 * ours
    late = {"metrics.window_start_s": 450.0}
    ours_late, aligned_late = _lab_continuous_azimuth_rms(**late), _azimuth_rms(**late)
    assert math.sqrt(max(ours_late**2 - aligned_late**2, 0.0)) < 0.25 * math.sqrt(ours**2 - aligned**2)
    assert math.sqrt(max(ours_late**2 - aligned_late**2, 0.0)) < floor


def _lab_continuous_azimuth_rms(**over) -> float:
    """RMS azimuth error of the bundled continuous lab scenario (16 realizations) with ``over``, against the exact
    geometry (metrics.reference_accuracy_pct = 0: the gyro's part is what is measured here)."""
    s, _ = load_scenario(Path(__file__).resolve().parents[3] / "scenarios" / "lab" / "continuous.toml")
    s = s.with_overrides(**{"simulation.realizations": 16, "metrics.reference_accuracy_pct": 0.0, **over})
    return summarize(per_realization_metrics(simulate_chain(s), s.metrics))["rms_azimuth_error_deg"]


def test_azimuth_error_grows_with_timeout_length_thesis_table_4_22():
    """Thesis table 4.22 trend (0.25 deg at 5 s up to 0.565 deg at 60 s; irregular at 50 s in the thesis): our
    medians grow along the chain; the yaw error, which the static reference error does not touch, grows > 3x from
    5 s to 60 s timeouts."""
    chain = ("continuous", "windowed_20s_5s", "windowed_20s_30s", "windowed_20s_60s")
    azi = [median(n, "rms_azimuth_error_deg") for n in chain]
    yaw = [median(n, "rms_yaw_error_deg") for n in chain]
    assert azi == sorted(azi) and yaw == sorted(yaw) and yaw[-1] > 3 * yaw[1]
    # the irregular 50 s figure (1.0 deg) falls inside our band (a distribution row of nodesim validate)
    values = lab_metrics("windowed_20s_50s")["rms_azimuth_error_deg"]
    assert np.percentile(values, 5) <= 1.0 <= np.percentile(values, 95)


def test_bias_convergence_times_thesis_4_2_3():
    """Thesis 4.2.3: ~46 s continuous, ~156 s with 60 s timeouts, ~120 s / ~165 s with single updates at
    0.05 / 0.0167 Hz: each within a factor of two, and longer timeouts converge later."""
    t = {n: lab_summary(n)["bias_convergence_time_s"] for n in
         ("continuous", "windowed_20s_60s", "single_0p05hz", "single_0p0167hz")}
    for name, published in (("continuous", 46.0), ("windowed_20s_60s", 156.0), ("single_0p05hz", 120.0),
                            ("single_0p0167hz", 165.0)):
        assert published / 2 <= t[name] <= 2 * published
    assert t["continuous"] < t["windowed_20s_60s"] and t["single_0p05hz"] < t["single_0p0167hz"]


def test_two_nodes_node_b_inherits_node_a_error():
    """Thesis two-node experiment: node B (fed by A) is worse than A; ours on the yaw error (the azimuth
    difference, ~0.003 deg, is below the accelerometer noise of each node)."""
    s = lab_summary("two_nodes_0p8hz")
    assert s["node2_rms_yaw_error_deg"] > s["node1_rms_yaw_error_deg"]
    assert s["node1_update_fraction"] == pytest.approx(0.8 / 1.9, rel=0.02)
    assert s["node2_update_fraction"] == pytest.approx(s["node1_update_fraction"], rel=0.01)
