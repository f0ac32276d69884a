"""Filter adapter: the one place where the chain builds and drives a node's yaw filter (and, for the fixed-point
implementation, the whole node firmware of :mod:`firmware_model.node_firmware`).

It builds the firmware model's filter named by ``filter.implementation`` (``float`` or the bit-exact
``fixed``, :func:`firmware_model.filter_factory.make_yaw_filter`; batched over realizations:
``predict(rate)``, ``update(reference, variance, mask)``, ``yaw_rad``, ``bias_rad_s``,
``yaw_variance_rad2``, ``overflow_counts``) and forms the node-to-node reference with the firmware
model's eq 3.29 helpers.  The float implementation is the reference path: the chain forms its
reference in float (:func:`forwarded_reference`).  The fixed implementation runs the firmware pipeline on integers
from the sensor counts on (:class:`FirmwareLanes`, the same njit code as the compiled engine).
"""

from __future__ import annotations

import functools
import math

import numpy as np

from firmware_model import fixed_kernel as fk
from firmware_model import node_firmware as nf
from firmware_model.config import FirmwareConfig
from firmware_model.errors import FirmwareError
from firmware_model.fixed_filter import FixedFormats
from firmware_model.filter_factory import make_yaw_filter
from firmware_model.six_state_filter import SixStateFilterConfig
from firmware_model.fixedpoint import QFormat
from firmware_model.six_state_fixed import SixStateFixedConfig, SixStateFixedFormats
from firmware_model.six_state_firmware import check_formats as check_six_state_formats
from firmware_model.yaw_filter import (
    YawFilter,
    YawFilterConfig,
    advance_reference,
    chain_reference_variance,
)
from nodesim.errors import NodesimError
from nodesim.motion.chain_motion import lab_profile
from nodesim.scenario.schema import Scenario
from nodesim.sensors.chain_imu import ChainImu
from nodesim.units import DEG


def require_engine_filter(scenario: Scenario) -> None:
    """Check the node filter a run will drive: for ``filter.states = 6`` (both chain engines run it, the float filter
    of :mod:`nodesim.chain.six_state` or, with ``filter.implementation = "fixed"``, the fixed-point node firmware of
    :mod:`firmware_model.six_state_firmware`; issue 24) its 6-state tuning and, fixed, its build, so a bad one is reported
    before any work."""
    if scenario.filter.states == 6:
        six_state_config(scenario)
        if scenario.filter.implementation == "fixed":
            six_state_firmware_config(scenario)


def six_state_config(scenario: Scenario) -> SixStateFilterConfig:
    """The 6-state filter's tuning (thesis eqs 3.24-3.26, 4.14-4.15): the 2-state tuning on all three gyro axes
    (the chain's IMU model gives one Allan pair) and ``filter.singularity_margin_deg``, ``singularity``,
    ``discretisation``, ``levelling`` (its force sigma: the accelerometer's noise density over a tick,
    sigma_f = N_a / sqrt(dt), as nodesim.chain.sensing gives the node's tick mean)."""
    f = scenario.filter
    try:
        return SixStateFilterConfig.from_yaw_config(
            _yaw_filter_config(scenario), singularity_margin_rad=f.singularity_margin_deg * DEG,
            singularity=f.singularity, discretisation=f.discretisation, levelling=f.levelling_mode == "static",
            levelling_rate_rad_s=f.levelling_rate_deg_s * DEG,
            levelling_force_sigma_m_s2=ChainImu.from_scenario(scenario).accel_density_m_s2_per_sqrt_hz
            * math.sqrt(scenario.chain.firmware_rate_hz))
    except FirmwareError as err:
        raise NodesimError(f"filter (states = 6): {err}") from None


def filter_config(scenario: Scenario) -> YawFilterConfig:
    """The 2-state filter's tuning from the scenario: the thesis Allan values of the z gyro (table V.1), A, B and how
    B enters the bias process noise (``filter.b_tuning``, eqs 4.14-4.15).  Refuses ``filter.states = 6``: whatever
    builds a 2-state filter or firmware build comes through here (the replayer too, which does not run the 6-state
    filter); the chain engines build the 6-state one from :func:`six_state_config`."""
    if scenario.filter.states != 2:
        raise NodesimError(
            f"filter.states = {scenario.filter.states}: only the chain engines run the 6-state filter "
            "(nodesim.chain.six_state); the 2-state filter, the fixed-point firmware and replay need filter.states = 2")
    return _yaw_filter_config(scenario)


def _yaw_filter_config(scenario: Scenario) -> YawFilterConfig:
    s, f = scenario.sensor, scenario.filter
    return YawFilterConfig(
        dt_s=1.0 / scenario.chain.firmware_rate_hz,
        arw_rad_per_sqrt_s=ChainImu.from_scenario(scenario).gyro_white_arw_rad_per_sqrt_s,
        bias_instability_rad_s=s.gyro_bias_instability_deg_s * DEG,
        bias_tau_s=f.bias_tau_s,
        tuning_a=f.tuning_a,
        tuning_b=f.tuning_b,
        b_tuning=f.b_tuning,
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


def tick_gyro_sigma_rad_s(scenario: Scenario) -> float:
    """The per-tick gyro white-noise sigma ARW / sqrt(dt) (the transfer term of R; the chain's sensing computes
    the same double for ``NodeSignals.gyro_white_sigma_rad_s``)."""
    dt_s = 1.0 / scenario.chain.firmware_rate_hz
    return float(ChainImu.from_scenario(scenario).gyro_white_arw_rad_per_sqrt_s / np.sqrt(dt_s))


def firmware_config(scenario: Scenario) -> FirmwareConfig:
    """The fixed-point firmware build of ``scenario``: what a run simulates and ``nodesim firmware export-config``
    writes as a C header."""
    return _firmware_build(scenario, filter_config(scenario))


def _firmware_build(scenario: Scenario, yaw_config: YawFilterConfig) -> FirmwareConfig:
    c = scenario.chain
    sigma_rate_rad_s = tick_gyro_sigma_rad_s(scenario)
    return FirmwareConfig(
        filter=yaw_config,
        formats=FixedFormats().with_word_length(scenario.filter.fixed_word_bits),
        gyro_full_scale_dps=getattr(scenario.sensor, "gyro_full_scale_dps", 250),
        sigma_rate_rad_s=float(sigma_rate_rad_s),
        offset_sigma_rad=c.offset_sigma_deg * DEG,
        encoder_counts_per_rev=scenario.sensor.encoder_counts_per_rev,
        extrapolate_rate=c.rate_compensation == "extrapolated",
        survey_math=scenario.firmware.survey_math,
        cordic_iterations=scenario.firmware.cordic_iterations,
        survey_points=scenario.filter.moving_average_points,
    )


CHAIN_SIX_STATE_FORMATS = SixStateFixedFormats(gain_angle=QFormat(32, 24))
"""The chain's 6-state build: the default formats but the angle gains in Q8.24 (+/- 128): under the twist update the
roll and pitch gains K = P h^T / S reach tens (the float chain's, 4 nodes at 2 deg, lab profile, 3 realizations:
35.5 and 44.3, the yaw's 2.25; the roll/pitch variances are far larger than the twist's), beyond Q2.30's +/- 2."""


def six_state_firmware_config(scenario: Scenario) -> tuple[FirmwareConfig, SixStateFixedConfig]:
    """The builds a fixed-point 6-state node runs (:mod:`firmware_model.six_state_firmware`): the 2-state firmware's
    (its reference advance, R, the estimate frame's and the survey's words, on the z-axis tuning) and the 6-state
    filter's (:class:`firmware_model.six_state_fixed.SixStateFixedConfig` of :func:`six_state_config`, with the
    ``firmware.cordic_iterations`` the survey uses: one CORDIC build, and the accelerometer's counts per m/s^2, the
    levelling's noise in the count sums' units); errors name the key."""
    f = scenario.filter
    if f.fixed_word_bits != 32:
        raise NodesimError(f"filter.fixed_word_bits = {f.fixed_word_bits} with filter.states = 6: the fixed-point "
                           "6-state filter is built for 32-bit words; allowed: 32")
    try:
        build6 = SixStateFixedConfig.from_filter_config(
            six_state_config(scenario), formats=CHAIN_SIX_STATE_FORMATS,
            cordic_iterations=scenario.firmware.cordic_iterations,
            accel_counts_per_m_s2=ChainImu.from_scenario(scenario).accel_lsb_per_m_s2)
        firmware = _firmware_build(scenario, _yaw_filter_config(scenario))
        check_six_state_formats(_firmware_params(firmware)[1], six_state_params(build6)[0])
    except FirmwareError as err:
        raise NodesimError(f"filter (states = 6, implementation = 'fixed'): {err}") from None
    return firmware, build6


@functools.lru_cache(maxsize=8)
def six_state_params(build: SixStateFixedConfig) -> tuple[np.ndarray, np.ndarray]:
    """``build.params()`` and its initial lane (P0: :meth:`SixStateFixedConfig.initial_state`), built once per
    build (a chain's nodes share one); callers take copies."""
    return build.params(), build.initial_state()


def alignment_window_s(scenario: Scenario) -> tuple[float, float] | None:
    """The alignment window [t0, t1) of ``firmware.alignment`` (thesis sec 4.2.3, :mod:`firmware_model.node_survey`):
    the lab profile's slow calibration rotation, or None (no alignment offset; ``auto``: the slow rotation where the
    lab profile has at least one slow turn, so that the extremes of a full turn are seen)."""
    m, mode = scenario.motion, scenario.firmware.alignment
    if mode == "none" or m.kind != "lab":
        return None
    if mode == "auto" and m.slow_turns < 1.0:
        return None
    slow = next(p for p in lab_profile(scenario).phases if p.name == "slow_rotation")
    return slow.start_s, slow.end_s


def alignment_ticks(window_s: tuple[float, float] | None, t_s: np.ndarray) -> tuple[int, int]:
    """(lo, hi): the ticks t0 <= t_s[k] < t1 of the alignment window (0, 0 without one)."""
    if window_s is None:
        return 0, 0
    lo, hi = np.searchsorted(t_s, window_s, side="left")
    return int(lo), int(hi)


def timer_us(interval_s) -> np.ndarray:
    """An interval as the node's microsecond timer measures it (round to nearest: ``rint(x * 1e6)``; the compiled
    engine computes the same expression)."""
    return np.rint(np.asarray(interval_s, dtype=float) * 1e6).astype(np.int64)


@functools.lru_cache(maxsize=8)
def _firmware_params(config: FirmwareConfig) -> tuple[np.ndarray, np.ndarray]:
    """``config.params(), config.filter_params()`` built once per build (a chain's nodes share one, and each
    builds two reference filters); callers take copies."""
    return config.params(), config.filter_params()


class FirmwareLanes:
    """One node's fixed-point firmware in every realization (:func:`firmware_model.node_firmware.node_tick` per
    lane); the SimPy engine's view of what the compiled engine runs in its loop."""

    SITES = nf.SITES  # the names of ``counts``
    INPUTS = nf.INPUTS  # the columns of ``inputs``
    STATE_SIZE = nf.STATE_SIZE  # a lane's words
    init_lane = staticmethod(nf.init_lane)  # a lane at power-up

    def __init__(self, config: FirmwareConfig, realizations: int):
        self.config = config
        params, fparams = _firmware_params(config)
        self.params, self.fparams = params.copy(), fparams.copy()
        self.states = np.zeros((realizations, self.STATE_SIZE), dtype=np.int64)
        for r in range(realizations):
            self.init_lane(self.states[r])
        self.counts = np.zeros(len(self.SITES), dtype=np.int64)
        self.inputs = np.zeros((realizations, len(self.INPUTS)), dtype=np.int64)
        self.outputs = np.zeros((realizations, len(nf.OUTPUTS)), dtype=np.int64)

    def read_sensors(self, sig, k: int) -> None:
        """The tick's sensor inputs beyond the z gyro sum :meth:`tick` takes: none for the 2-state firmware (the
        6-state node's reads its other axes, :class:`nodesim.chain.six_state_firmware_lanes.SixStateFirmwareLanes`)."""

    def tick(self, phase: int, gyro_z_sum, n, yaw0_raw=0, ref=None, ref_yaw_raw=0, ref_aux_raw=0, transfer_us=0):
        """One firmware tick of every lane; ``ref`` (R,) the kind of reference per lane (NO_REF where None)."""
        x = self.inputs
        x[:, nf.IN_PHASE] = phase
        x[:, nf.IN_GZ] = gyro_z_sum
        x[:, nf.IN_N] = n
        x[:, nf.IN_YAW0] = yaw0_raw
        x[:, nf.IN_REF] = nf.NO_REF if ref is None else ref
        x[:, nf.IN_REF_YAW] = ref_yaw_raw
        x[:, nf.IN_REF_AUX] = ref_aux_raw
        x[:, nf.IN_TRANSFER] = transfer_us
        self._step()
        return self.outputs

    def _step(self) -> None:
        nf.node_tick_lanes(self.states, self.params, self.fparams, self.counts, self.inputs, self.outputs)

    @property
    def yaw_raw(self) -> np.ndarray:
        return self.states[:, fk.I_YAW].copy()

    @property
    def var_raw(self) -> np.ndarray:
        return self.states[:, fk.I_PYY].copy()

    @property
    def yaw_rad(self) -> np.ndarray:
        return yaw_rad_of_raw(self.states[:, fk.I_YAW], self.fparams)

    @property
    def yaw_variance_rad2(self) -> np.ndarray:
        return np.ldexp(self.states[:, fk.I_PYY].astype(float), -int(self.fparams[fk.W_YY + 1])) / fk.RAD2_TO_DEG2

    @property
    def bias_rad_s(self) -> np.ndarray:
        return np.ldexp(self.states[:, fk.I_BIAS].astype(float), -int(self.fparams[fk.W_BIAS + 1])) / fk.RAD_TO_DEG

    def rate_rad_s(self, rate_raw) -> np.ndarray:
        return np.ldexp(np.asarray(rate_raw).astype(float), -int(self.fparams[fk.W_RATE + 1])) / fk.RAD_TO_DEG

    @property
    def overflow_counts(self) -> dict[str, int]:
        return {self.SITES[i]: int(c) for i, c in enumerate(self.counts) if c}


def yaw_rad_of_raw(yaw_raw, fparams) -> np.ndarray:
    """A binary angle as radians in [-pi, pi) (fixed_kernel.yaw_rad on arrays: the same double operations)."""
    return np.ldexp(np.asarray(yaw_raw).astype(float), -int(fparams[fk.W_YAW + 1])) * fk.TURN_RAD

