"""The chain's fixed firmware resolves its surveys as the MCU does (firmware_model.node_survey.fixed_surveys: integer
CORDIC or float32, integer moving average), and they agree with the float survey of the same run (issue 19 goal:
RMS azimuth difference < 0.005 deg at 2 deg inclination on the lab profile)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from firmware_model.config import FirmwareConfig
from firmware_model.errors import FirmwareError
from nodesim.api import simulate
from nodesim.chain.compiled.surveys import averaged_surveys
from nodesim.chain.estimator import alignment_ticks, alignment_window_s, firmware_config
from nodesim.errors import NodesimError
from nodesim.scenario.schema import load_scenario

ROOT = Path(__file__).resolve().parents[3]
LAB = ROOT / "scenarios" / "lab" / "continuous.toml"
POINTS = 32


def survey_difference_rms_deg(survey_math: str = "cordic", iterations: int = 24, realizations: int = 4):
    """(azimuth, inclination) RMS difference [deg] between the fixed firmware's surveys and the float survey
    (nodesim.chain.compiled.surveys) of the same run's specific force and yaw, over full windows after the
    filter start."""
    run = simulate(LAB, realizations=realizations, **{"filter.implementation": "fixed",
                                                      "sensor.model": "mpu6500_counts",  # tilt + alignment
                                                      "firmware.survey_math": survey_math,
                                                      "firmware.cordic_iterations": iterations})
    window = alignment_window_s(run.scenario)
    assert window is not None  # the lab profile's alignment offset is in both surveys
    d_azi, d_inc = [], []
    for n in run.chain.nodes:
        first = int(np.searchsorted(n.t_s, n.filter_start_s))
        R, K = n.yaw_est_rad.shape
        inc, azi = np.zeros((R, K - first)), np.zeros((R, K - first))
        lo, hi = alignment_ticks(window, n.t_s[first:])
        averaged_surveys(np.ascontiguousarray(n.specific_force[:, first:]), np.ascontiguousarray(n.yaw_est_rad[:, first:]),
                         lo, hi, POINTS, inc, azi)
        d_azi.append(np.angle(np.exp(1j * (n.azimuth_rad[:, first + POINTS:] - azi[:, POINTS:]))).ravel())
        d_inc.append((n.inclination_rad[:, first + POINTS:] - inc[:, POINTS:]).ravel())
    rms = lambda d: float(np.degrees(np.sqrt(np.mean(np.concatenate(d) ** 2))))  # noqa: E731
    return rms(d_azi), rms(d_inc)


def test_cordic_survey_meets_the_goal_on_the_lab_profile():
    """Measured (4 realizations, default 24 iterations): azimuth 6.0e-4 deg RMS, inclination 1.5e-5 deg RMS (2026-12-03);
    float32 ("fpu"): 1.6e-4 and 4.8e-6 deg (the count quantisation and the averaging of wrapped differences
    instead of unit vectors dominate, not the trigonometry).  Goal (issue 19): azimuth < 0.005 deg."""
    azi, inc = survey_difference_rms_deg("cordic", 24)
    assert azi < 0.005
    assert inc < 0.001
    assert azi > 0.0  # the fixed path really ran (not the float survey)


def test_fewer_iterations_are_worse():
    """At 8 iterations the residual angle (~2^-7 rad) dominates: the difference grows well beyond 24's."""
    azi8, inc8 = survey_difference_rms_deg("cordic", 8, realizations=1)
    azi24, inc24 = survey_difference_rms_deg("cordic", 24, realizations=1)
    assert azi8 > 5 * azi24 and inc8 > 5 * inc24


def test_survey_keys_reach_the_build_and_are_validated(tmp_path):
    scenario, _ = load_scenario(LAB)
    cfg = firmware_config(scenario.with_overrides(**{"firmware.survey_math": "fpu", "firmware.cordic_iterations": 12}))
    assert (cfg.survey_math, cfg.cordic_iterations, cfg.survey_points) == ("fpu", 12, 32)
    header = cfg.c_header()
    assert "#define NF_SURVEY_MODE 1" in header and "#define NF_CORDIC_ITERATIONS 12" in header
    for key, bad in (("firmware.survey_math", "double"), ("firmware.cordic_iterations", 31),
                     ("firmware.cordic_iterations", 7)):
        with pytest.raises(NodesimError, match=key.split(".")[1]):
            scenario.with_overrides(**{key: bad})
    with pytest.raises(FirmwareError, match="cordic_iterations"):
        FirmwareConfig(filter=cfg.filter, formats=cfg.formats, cordic_iterations=40)
    with pytest.raises(FirmwareError, match="survey_math"):
        FirmwareConfig(filter=cfg.filter, formats=cfg.formats, survey_math="soft")
