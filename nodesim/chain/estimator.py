"""Filter adapter: the one place where the chain builds and drives a node's yaw filter.

It builds the firmware model's filter named by ``filter.implementation`` (``float`` or the bit-exact
``fixed``, :func:`firmware_model.filter_factory.make_yaw_filter`; batched over realizations:
``predict(rate)``, ``update(reference, variance, mask)``, ``yaw_rad``, ``bias_rad_s``,
``yaw_variance_rad2``, ``overflow_counts``) and forms the node-to-node reference with the firmware
model's eq 3.29 helpers.  The reference is advanced in float for both implementations (the transfer
time differs per realization when packets are lost); the fixed filter quantises it on update.
"""

from __future__ import annotations

import numpy as np

from firmware_model.fixed_filter import FixedFormats
from firmware_model.filter_factory import make_yaw_filter
from firmware_model.yaw_filter import (
    YawFilter,
    YawFilterConfig,
    advance_reference,
    chain_reference_variance,
)
from nodesim.scenario.schema import Scenario
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


def fixed_formats(scenario: Scenario) -> FixedFormats | None:
    """The fixed filter's Q formats on a ``filter.fixed_word_bits`` word (None for the float filter)."""
    if scenario.filter.implementation != "fixed":
        return None
    return FixedFormats().with_word_length(scenario.filter.fixed_word_bits)


def new_filter(scenario: Scenario, realizations: int, initial_yaw_rad, initial_bias_rad_s) -> YawFilter:
    """A node's filter, started from the encoder yaw and the bias averaged over its static window."""
    return make_yaw_filter(
        scenario.filter.implementation, filter_config(scenario), realizations, initial_yaw_rad, initial_bias_rad_s,
        formats=fixed_formats(scenario),
    )


def rate_estimate(kf: YawFilter, gyro_rad_s: np.ndarray) -> np.ndarray:
    """The node's bias-corrected rate (R,): what it advances a forwarded estimate with (thesis eq 3.29)."""
    return gyro_rad_s - kf.bias_rad_s


def forwarded_reference(yaw_rad, variance_rad2, rate_rad_s, transfer_s, rate_sigma_rad_s, offset_sigma_rad):
    """(reference yaw, R) of a forwarded estimate used ``transfer_s`` after it was read (thesis eq 3.29,
    digest 2.6): psi_hat_(n-1) + omega_hat_n dt,  P_(n-1) + (dt sigma_rate)^2 + sigma_off^2."""
    ref = advance_reference(yaw_rad, rate_rad_s, transfer_s)
    return ref, chain_reference_variance(variance_rad2, transfer_s, rate_sigma_rad_s, offset_sigma_rad)
