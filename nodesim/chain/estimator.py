"""Filter adapter: the one place where the chain builds and drives a node's yaw filter.

Today it wraps :class:`firmware_model.yaw_filter.FloatYawFilter` (batched over realizations:
``predict(rate)``, ``update(reference, variance, mask)``, ``yaw_rad``, ``bias_rad_s``,
``yaw_variance_rad2``); the fixed-point twin of the firmware issue plugs in here.
"""

from __future__ import annotations

import numpy as np

from firmware_model.yaw_filter import FloatYawFilter, YawFilterConfig
from nodesim.scenario import Scenario
from nodesim.units import DEG


def filter_config(scenario: Scenario) -> YawFilterConfig:
    """Filter tuning from the scenario: the thesis Allan values of the z gyro (table V.1) and A, B (eq 4.14)."""
    s, f = scenario.sensor, scenario.filter
    return YawFilterConfig(
        dt_s=1.0 / scenario.chain.firmware_rate_hz,
        arw_rad_per_sqrt_s=s.gyro_arw_deg_per_sqrt_s * DEG,
        bias_instability_rad_s=s.gyro_bias_instability_deg_s * DEG,
        bias_tau_s=f.bias_tau_s,
        tuning_a=f.tuning_a,
        tuning_b=f.tuning_b,
    )


def new_filter(scenario: Scenario, realizations: int, initial_yaw_rad, initial_bias_rad_s) -> FloatYawFilter:
    """A node's filter, started from the encoder yaw and the bias averaged over its static window."""
    return FloatYawFilter(
        filter_config(scenario), realizations, initial_yaw_rad=initial_yaw_rad, bias_offset_rad_s=initial_bias_rad_s
    )


def rate_estimate(kf: FloatYawFilter, gyro_rad_s: np.ndarray) -> np.ndarray:
    """The node's bias-corrected rate (R,): what it advances a forwarded estimate with (thesis eq 3.29)."""
    return gyro_rad_s - kf.bias_rad_s
