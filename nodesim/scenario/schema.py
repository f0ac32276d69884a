"""Scenario files: TOML in, a frozen, validated :class:`Scenario` out.

Every field has a default, so a scenario file only states what differs from the defaults.  Unknown keys,
wrong types and out-of-range values raise :class:`nodesim.errors.ScenarioError` with one message naming
the file, the key path and the allowed range.  Units are in the field names wherever they are not SI;
degrees appear only here, at the edge, and are converted by the consumers through :mod:`nodesim.units`.
"""

from __future__ import annotations

import hashlib
import json
import math
import tomllib
from pathlib import Path
from typing import Any, Literal

from pydantic import Field, ValidationError, field_validator, model_validator

from nodesim.errors import ScenarioError
from nodesim.scenario.section_base import _Section
from nodesim.scenario.output_section import OutputSection
from nodesim.scenario.radio_sections import FaultsSection, MacSection, RadioSection, check_indices


class SimulationSection(_Section):
    """Run length and Monte Carlo size."""

    duration_s: float = Field(620.0, gt=0.0, le=30 * 24 * 3600.0, description="simulated time")
    realizations: int = Field(1, ge=1, le=1_000_000, description="independent Monte Carlo realizations")
    first_realization: int = Field(
        0, ge=0, le=1_000_000_000,
        description="index of the first realization: the run covers realizations first .. first + R - 1 of the "
        "root seed, so realization r alone is first_realization = r, realizations = 1")
    engine: Literal["auto", "event", "compiled"] = Field(
        "auto", description="chain engine: 'event' (SimPy, every feature), 'compiled' (numba, lab motion; same "
        "numbers, much faster), 'auto' (compiled where it covers the scenario, else event)")


class NodeClockSection(_Section):
    """Per-node clock override (one ``[[chain.node]]`` table per node that differs from the default)."""

    id: int = Field(..., ge=1, description="node id, 1 = top of the final chain")
    clock_offset_s: float | None = Field(None, ge=0.0, le=10.0, description="tick phase (default: stagger)")
    clock_drift_ppm: float | None = Field(None, ge=-1000.0, le=1000.0, description="clock rate error")


class ChainSection(_Section):
    """The sensor chain: number of nodes, firmware rate, simple links (a fixed delay and a loss probability),
    clocks (node n ticks at offset_n + k dt / (1 + drift_n 1e-6)) and the feed-forward packet rules."""

    nodes: int = Field(1, ge=1, le=100_000, description="sensor nodes, one per drill tube (1 = top)")
    firmware_rate_hz: float = Field(1.9, gt=0.0, le=1000.0, description="node filter rate")
    link_delay_s: float = Field(0.015, ge=0.0, le=10.0, description="transfer time of one hop")
    link_loss_probability: float = Field(0.0, ge=0.0, le=1.0, description="per-transmission loss")
    processing_s: float = Field(0.005, ge=0.0, le=10.0, description="filter time before a node transmits")
    clock_stagger_s: float = Field(0.06, ge=0.0, le=10.0, description="default tick offset of node n: (n-1) x this")
    clock_drift_ppm: float = Field(0.0, ge=-1000.0, le=1000.0, description="default clock rate error of every node")
    max_update_age_s: float = Field(1.5, gt=0.0, le=3600.0, description="older forwarded estimates are stale")
    offset_sigma_deg: float = Field(0.0, ge=0.0, le=90.0, description="node-to-node yaw offset sigma added to R")
    forward: Literal["after_update", "every_tick"] = Field(
        "after_update",
        description="when a node forwards its estimate down: only in ticks where it applied an update, or every "
        "tick its filter runs (its post-time-update estimate when it had no reference)",
    )
    rate_compensation: Literal["tick_mean", "extrapolated"] = Field(
        "tick_mean",
        description="rate advancing a forwarded estimate: the last tick's mean gyro rate (thesis eq 3.29) or that "
        "rate extrapolated linearly to the middle of the transfer (removes the lag in rate ramps)",
    )
    node: list[NodeClockSection] = Field(default_factory=list, description="per-node clock overrides")


class MotionSection(_Section):
    """True motion.  ``kind = "lab"``: the thesis lab rotation profile (thesis 4.2.2-4.2.3): static, slow
    rotation, pause, fast rotation, static.  ``kind = "drilling"``: :class:`nodesim.motion.drilling.DrillingProcess`
    after ``initial_static_s`` at rest: per tube, drill ``tube_length_m`` at ``rate_of_penetration_m_s``
    rotating at ``drill_rate_deg_s`` (ramps of ``ramp_s``), a survey stop of ``survey_stop_s``, then the next
    tube's insertion (``insertion_s``, string in the slips), along ``wellpath`` rows [MD m, inclination deg,
    azimuth deg] (default: a straight hole at inclination_deg / azimuth_deg), with ``initial_tubes`` tubes in the
    hole at the start (the programme drills the top one of them first) and ``survey_nodes`` surveying at each stop."""

    kind: Literal["lab", "drilling"] = "lab"
    inclination_deg: float = Field(2.0, ge=0.0, le=180.0)
    azimuth_deg: float = Field(45.0, ge=0.0, lt=360.0)
    stationary_s: float = Field(50.0, ge=0.0, description="initial static window (bias estimation)")
    slow_rate_deg_s: float = Field(3.6, gt=0.0, le=2000.0, description="calibration rotation rate")
    slow_turns: float = Field(2.0, ge=0.0, le=1e6)
    pause_s: float = Field(10.0, ge=0.0, description="static time between slow and fast rotation")
    fast_rate_deg_s: float = Field(71.0, gt=0.0, le=2000.0)
    fast_turns: float = Field(20.0, ge=0.0, le=1e6)
    tube_length_m: float = Field(2.0, gt=0.0, le=100.0, description="drilling: tube length = survey spacing")
    rate_of_penetration_m_s: float = Field(2.0 / 120.0, gt=0.0, le=10.0, description="drilling: advance rate")
    drill_rate_deg_s: float = Field(60.0, gt=0.0, le=2000.0, description="drilling: string rotation rate")
    ramp_s: float = Field(5.0, ge=0.0, le=3600.0, description="drilling: rotation ramp up/down time")
    insertion_s: float = Field(60.0, gt=0.0, le=3600.0, description="drilling: tube insertion (in the slips)")
    survey_stop_s: float = Field(40.0, gt=0.0, le=3600.0, description="drilling: static survey stop per tube")
    survey_settle_s: float = Field(20.0, ge=0.0, le=3600.0, description="drilling: wait before surveying")
    initial_static_s: float = Field(60.0, gt=0.0, le=3600.0, description="drilling: rest before the first tube")
    node_offset_m: float = Field(1.0, ge=0.0, le=100.0, description="drilling: node height above its tube's end")
    wellpath: list[list[float]] = Field(default_factory=list, description="drilling: [MD m, inc deg, azi deg] rows")
    initial_tubes: int = Field(
        1, ge=1, le=100_000, description="drilling: tubes already in the hole at t = 0 (1 <= initial_tubes <= "
        "chain.nodes): their nodes (ids N - initial_tubes + 1 .. N) average their gyros over [0, initial_static_s) "
        "and start their filters then, the top one is the encoder-aided top node until the first insertion; the "
        "bit starts (initial_tubes - 1) tube lengths below the first wellpath station")
    survey_nodes: Literal["bottom", "all"] = Field(
        "bottom", description="drilling: who surveys at a survey stop: the bottom node (the station's survey), or "
        "every node present (each at its own MD, all sent up; the ground survey and the metric windows still "
        "use the bottom node's, one per station)")

    def drilling_duration_s(self, tubes: int) -> float:
        """Length of the drilling programme of ``tubes`` tubes, ``initial_tubes`` = M of them in the hole at the
        start (:class:`nodesim.motion.drilling.DrillingProcess`): T = initial_static_s + (N - M + 1)
        (L / ROP + survey_stop_s) + (N - M) insertion_s, a tube taking its drilling at the rate of penetration,
        its survey stop and the insertion of the next."""
        drill = self.tube_length_m / self.rate_of_penetration_m_s
        drilled = tubes - self.initial_tubes + 1
        return self.initial_static_s + drilled * (drill + self.survey_stop_s) + (drilled - 1) * self.insertion_s

    @model_validator(mode="after")
    def _drilling_consistent(self) -> "MotionSection":
        if self.kind != "drilling":
            if self.wellpath:
                raise ValueError("wellpath is only used with kind = 'drilling'")
            if self.initial_tubes != 1:
                raise ValueError(f"initial_tubes ({self.initial_tubes}) is only used with kind = 'drilling'")
            if self.survey_nodes != "bottom":
                raise ValueError(f"survey_nodes = {self.survey_nodes!r} is only used with kind = 'drilling'")
            return self
        if self.survey_settle_s >= self.survey_stop_s:
            raise ValueError(
                f"survey_settle_s ({self.survey_settle_s}) must be less than survey_stop_s ({self.survey_stop_s})"
            )
        drill = self.tube_length_m / self.rate_of_penetration_m_s
        if 2.0 * self.ramp_s >= drill:
            raise ValueError(f"ramp_s ({self.ramp_s}): two ramps must fit in one tube's drilling time "
                             f"(allowed: < {drill / 2:.4g} s)")
        if self.node_offset_m > self.tube_length_m:
            raise ValueError(f"node_offset_m ({self.node_offset_m}) must not exceed tube_length_m ({self.tube_length_m})")
        for i, row in enumerate(self.wellpath):
            if len(row) != 3:
                raise ValueError(f"wellpath[{i}] must be [md_m, inclination_deg, azimuth_deg] (got {len(row)} numbers)")
            md, inc, azi = row
            if not 0.0 <= inc <= 180.0 or not 0.0 <= azi < 360.0:
                raise ValueError(f"wellpath[{i}] = {row}: inclination must be in [0, 180] and azimuth in [0, 360) deg")
            if i and md <= self.wellpath[i - 1][0]:
                raise ValueError(f"wellpath[{i}] = {row}: MD must increase (previous {self.wellpath[i - 1][0]} m)")
        return self


MPU6500_ACCEL_DATASHEET_PSD_UG = 300.0
"""MPU6500 datasheet accelerometer noise power spectral density [ug/sqrt(Hz)], one-sided as datasheets give it
(RMS noise = n sqrt(bandwidth)); a boxcar average over T has a noise bandwidth of 1/(2T), hence n / sqrt(2T)."""


class SensorSection(_Section):
    """The node IMU every chain node reads (the MPU6500 count model of nodesim.sensors.chain_imu: 3-axis gyro and
    accelerometer, int16 counts summed per firmware tick) and the incremental encoder."""

    gyro_arw_deg_per_sqrt_s: float = Field(7.38e-3, ge=0.0, le=10.0, description="thesis table V.1, z axis")
    gyro_turn_on_bias_deg_s: float = Field(0.5, ge=-250.0, le=250.0, description="removed by the static window")
    gyro_residual_bias_deg_s: float = Field(
        -0.02, ge=-250.0, le=250.0, description="bias left after motion starts (thesis 4.2.3: about -0.02 deg/s)"
    )
    gyro_scale_factor_error: float = Field(
        0.001, gt=-0.5, lt=0.5,
        description="residual z-gyro scale-factor error after calibration (fraction): thesis table 4.16 "
        "(MPU6500 scale factor error 1e-3)",
    )
    gyro_bias_instability_deg_s: float = Field(3.33e-3, ge=0.0, le=10.0, description="Gauss-Markov sigma")
    gyro_bias_tau_s: float = Field(500.0, gt=0.0, le=1e7, description="Gauss-Markov correlation time")
    accel_noise_ug_per_sqrt_hz: float = Field(
        MPU6500_ACCEL_DATASHEET_PSD_UG / math.sqrt(2.0),
        ge=0.0,
        le=1e6,
        description=(
            "white-noise density in the two-sided (Allan, IEEE 952) convention of every noise density here: a "
            "T-second average has sigma = value / sqrt(T); a datasheet's one-sided PSD n gives n / sqrt(2) "
            "(MPU6500: 300 ug/sqrt(Hz) -> 212.1)"
        ),
    )
    encoder_counts_per_rev: int = Field(1024, ge=1, le=1 << 24)
    gyro_full_scale_dps: Literal[250, 500, 1000, 2000] = Field(
        250, description="MPU6500 gyro full-scale range (+/- deg/s): 131 / 65.5 / 32.8 / 16.4 LSB per deg/s "
        "(MPU-6500 product specification 6.1); the reading clips there (counted as adc_clipped_samples)")
    accel_full_scale_g: Literal[2, 4, 8, 16] = Field(
        2, description="MPU6500 accelerometer full-scale range (+/- g): 16384 / 8192 / 4096 / 2048 LSB per g "
        "(MPU-6500 product specification 6.2)")
    sampling: Literal["tick_sum", "per_sample"] = Field(
        "tick_sum", description="per_sample: every int16 sample at sample_rate_hz, quantised, clipped and summed "
        "per tick as the MCU reads the FIFO; tick_sum (fast): the tick's integer count sum drawn directly from "
        "the distribution per_sample produces, falling back to per_sample for a tick where that is not valid "
        "(nodesim.sensors.tick_counts)")
    sample_rate_hz: float = Field(
        65.0, gt=0.0, le=8000.0, description="IMU output data rate: thesis logging rate 65 Hz (MPU6500 gyro "
        "ODR up to 8 kHz); must give every firmware tick at least one sample")
    residual_tilt_sigma_deg: float = Field(
        0.0422, ge=0.0, le=10.0, description="per node and realization, residual static tilt of the sensor frame "
        "about each transverse axis after calibration (sigma): thesis table 4.20, MPU6500 turn-table "
        "calibration, standard deviation 0.0422 deg")
    model: Literal["mpu6500_counts"] = Field(
        "mpu6500_counts", description="what the chain's nodes read: the sensor-rate MPU6500 count model of "
        "nodesim.sensors.chain_imu (3 axes, int16 counts, clipping, residual tilt; the one model since issue 19 "
        "removed the tick-averaged float stand-ins)")


class FilterSection(_Section):
    """Node yaw filter settings (thesis 4.2.2; tuning factors A and B of eqs 4.14-4.15).

    The process noise is Q_d = G Q G^T dt with Q = diag(sigma_v^2, 2 sigma_b^2 / tau) (eq 3.26) and the noise
    gain G = diag(G_C, G_D) (eq 4.15): G_C = A, and G_D by ``b_tuning`` (the thesis's eq 4.14 is lost in the
    text, so both readings are kept): ``noise_gain`` G_D = B, Q_bb = B^2 2 sigma_b^2 / tau; ``process_noise``
    G_D = sqrt(B), Q_bb = B 2 sigma_b^2 / tau (firmware_model.yaw_filter.YawFilterConfig.q_d).  The bounds of
    ``tuning_a``, ``tuning_b`` and ``bias_tau_s`` (> 0) are what keeps Q >= 0 (and sqrt(B) real) for both filters.

    ``states`` picks the filter: 2 (yaw, z bias: the near-vertical form) or 6 (the thesis's roll, pitch, yaw and
    three biases, eqs 3.22-3.26: firmware_model.six_state_filter, issue 24).  The 6-state filter exists in float
    (both chain engines run it) and in fixed point (firmware_model.six_state_fixed: "rotation" only, 32-bit words),
    both chain engines run as the node firmware of firmware_model.six_state_firmware with ``implementation = "fixed"``.
    ``singularity_margin_deg``, ``singularity``, ``discretisation``, ``levelling`` and ``levelling_rate_deg_s``
    are its settings (only with 6)."""

    states: Literal[2, 6] = Field(
        2, description="node filter states: 2 = (yaw, z-gyro bias), the near-vertical form; 6 = the thesis's (roll, "
        "pitch, yaw, 3 gyro biases): float (run by both chain engines) or fixed ('rotation' only; a run with it is "
        "refused: the chain engines do not run the fixed 6-state filter yet)")
    singularity_margin_deg: float = Field(
        5.0, gt=0.0, lt=90.0, description="states = 6: how close to pitch +/-90 deg (horizontal) the Euler-rate "
        "terms (1/cos pitch) are treated as singular; such ticks are counted")
    singularity: Literal["hold", "decouple"] = Field(
        "hold", description="states = 6, inside the singularity margin: 'hold' evaluates the Euler-rate terms at "
        "the margin, 'decouple' propagates the 2-state form (firmware_model.six_state_filter)")
    discretisation: Literal["rotation", "euler"] = Field(
        "rotation", description="states = 6: 'rotation' = the exact tick at a constant rate (direction cosine "
        "strapdown, Phi its Jacobian); 'euler' = Phi = I + F dt (thesis digest 2.5), unstable under string "
        "rotation (roll/pitch errors grow sqrt(1 + (w dt)^2) per tick)")
    levelling: Literal["static", "off"] | None = Field(
        None, description="states = 6: 'static' = at every tick the node is static (gyro rate minus its start bias "
        "below levelling_rate_deg_s) its accelerometer's roll and pitch update the filter (thesis eqs 3.27-3.31 on "
        "the roll/pitch rows, resolved from gravity as at a survey station, eqs 1.1-1.3; docs/deviated_wells.md); "
        "'off' = yaw-only references, with which roll, pitch and the x, y biases are unobservable and run away in "
        "a long string. Default: 'static' (float and fixed; the fixed firmware's is "
        "firmware_model.six_state_kernel.level_raw, bit-exact with its C twin)")
    levelling_rate_deg_s: float = Field(
        0.5, gt=0.0, le=100.0, description="states = 6, levelling = 'static': a tick is static when the norm of "
        "the gyro rates minus the start bias (the static window's) is below this")
    implementation: Literal["float", "fixed"] = "float"
    fixed_word_bits: int = Field(
        32, ge=12, le=32, description="fixed: MCU word length; fewer bits keep each variable's range, lose "
        "resolution (below 12 bits the filter's 1 / S division needs a shift beyond the 30 bits the firmware allows)"
    )
    tuning_a: float = Field(1.0, gt=0.0, le=1e3)
    tuning_b: float = Field(5.0, gt=0.0, le=1e3)
    b_tuning: Literal["noise_gain", "process_noise"] = Field(
        "process_noise", description="how B of thesis eqs 4.14-4.15 enters the bias process noise: 'noise_gain' "
        "G_D = B, so Q_bb = B^2 (2 sigma_b^2 / tau) dt; 'process_noise' G_D = sqrt(B), so Q_bb = B (2 sigma_b^2 / "
        "tau) dt (the same for the float and the fixed-point filter). Default process_noise: the lower log-RMS error "
        "over the thesis's 8 bias convergence times (nodesim validate, issue 21)")
    bias_tau_s: float = Field(500.0, gt=0.0, le=1e7)
    moving_average_points: int = Field(32, ge=1, le=10_000)

    @field_validator("states", mode="before")
    @classmethod
    def _states_integer(cls, value):
        if isinstance(value, bool) or not isinstance(value, int):
            raise ValueError(f"Input should be 2 or 6 (an integer; got {value!r})")
        return value

    @model_validator(mode="after")
    def _six_state_settings(self) -> "FilterSection":
        if self.states == 6 and self.implementation == "fixed":
            if self.discretisation != "rotation":
                raise ValueError(f"filter.discretisation = {self.discretisation!r} with filter.states = 6 and "
                                 "filter.implementation = 'fixed': the fixed-point 6-state filter implements only "
                                 "'rotation' (firmware_model.six_state_fixed); allowed: discretisation = 'rotation'")
            if self.fixed_word_bits != 32:
                raise ValueError(f"filter.fixed_word_bits = {self.fixed_word_bits} with filter.states = 6 and "
                                 "filter.implementation = 'fixed': the fixed-point 6-state filter is built for "
                                 "32-bit words; allowed: 32")
        if self.states == 2:
            for key in ("singularity_margin_deg", "singularity", "discretisation", "levelling", "levelling_rate_deg_s"):
                value, default = getattr(self, key), type(self).model_fields[key].default
                if value != default:
                    raise ValueError(f"filter.{key} = {value!r} is only used with filter.states = 6 "
                                     f"(filter.states is 2)")
        return self

    @property
    def levelling_mode(self) -> str:
        """``levelling`` with its default resolved: 'static' (both implementations: without it a long string's
        6-state filters run away, docs/deviated_wells.md)."""
        return self.levelling if self.levelling is not None else "static"


class FirmwareSection(_Section):
    """Node firmware build settings (docs/firmware.md; firmware_model.config.FirmwareConfig): how the MCU does
    the survey's trigonometry (issue 19: integer CORDIC, or single-precision float on an MCU with an FPU)."""

    survey_math: Literal["cordic", "fpu"] = Field(
        "cordic", description="survey trigonometry: integer CORDIC (firmware_model.cordic) or float32 ('fpu')")
    cordic_iterations: int = Field(24, ge=8, le=30, description="CORDIC iterations (angle error ~ 2^-(n-1) rad)")
    alignment: Literal["auto", "slow_rotation", "none"] = Field(
        "auto", description="the lab procedure's alignment offset (thesis sec 4.2.3; firmware_model.node_survey): "
        "'slow_rotation' takes (max + min) / 2 of the moving-averaged transverse accelerometer axes over the lab "
        "profile's slow calibration rotation (motion.kind = 'lab', motion.slow_turns >= 1) and subtracts it from "
        "every later reading; 'none' leaves the residual tilt (sensor.residual_tilt_sigma_deg) as an error; "
        "'auto': slow_rotation where the lab profile has at least one slow turn, else none (drilling: none, the "
        "drilling programme has no calibration rotation). Applies to the float and the fixed implementation")


class ScheduleSection(_Section):
    """Reference-update schedule (thesis 4.2.2 update modes); ``arbitrary`` takes ``windows``, a list of
    ``[start_s, stop_s, rate_hz]`` (non-negative, ordered, not overlapping, rate > 0)."""

    mode: Literal["continuous", "windowed", "single", "arbitrary", "none"] = "continuous"
    update_s: float = Field(20.0, gt=0.0, description="windowed: length of an update window")
    timeout_s: float = Field(30.0, ge=0.0, description="windowed: length of a timeout")
    single_rate_hz: float = Field(0.2, gt=0.0, le=1000.0, description="single: update frequency")
    windows: list[list[float]] = Field(default_factory=list, description="arbitrary: [start_s, stop_s, rate_hz]")

    @model_validator(mode="after")
    def _windows_valid(self) -> "ScheduleSection":
        if self.mode != "arbitrary":
            if self.windows:
                raise ValueError(f"windows is only used with mode = 'arbitrary' (mode is {self.mode!r})")
            return self
        if not self.windows:
            raise ValueError("mode = 'arbitrary' needs windows = [[start_s, stop_s, rate_hz], ...] (got none)")
        previous_stop = None
        for i, w in enumerate(self.windows):
            if len(w) != 3:
                raise ValueError(f"windows[{i}] must be [start_s, stop_s, rate_hz] (got {len(w)} numbers)")
            start, stop, rate = w
            if start < 0 or stop < 0:
                raise ValueError(f"windows[{i}] = {w}: start_s and stop_s must be >= 0")
            if stop <= start:
                raise ValueError(f"windows[{i}] = {w}: stop_s must be greater than start_s")
            if not 0 < rate <= 1000:
                raise ValueError(f"windows[{i}] = {w}: rate_hz must be in (0, 1000]")
            if previous_stop is not None and start < previous_stop:
                raise ValueError(
                    f"windows[{i}] = {w} overlaps or precedes windows[{i - 1}] (ending at {previous_stop}): "
                    "windows must be in time order and not overlap"
                )
            previous_stop = stop
        return self


class MetricsSection(_Section):
    """Where and how the headline metrics are measured."""

    window_start_s: float = Field(370.0, ge=0.0, description="start of the RMS error window")
    window_end_s: float = Field(570.0, gt=0.0, description="end of the RMS error window")
    bias_tolerance_deg_s: float = Field(0.002, gt=0.0, description="bias convergence band")
    bias_hold_s: float = Field(10.0, ge=0.0, description="time the bias must stay in the band")
    output_moving_average_points: int = Field(
        1, ge=1, le=10_000, description="extra moving average on the reported I and A before the RMS (1 = none)"
    )
    reference_accuracy_pct: float = Field(
        0.0, ge=0.0, le=100.0, description="lab profile: the true inclination and azimuth the errors are measured "
        "against are themselves a measurement, made once per run after the initial calibration (thesis sec 4.2.3: "
        "'the true inclination and azimuth is determined after the initial calibration'), with this accuracy: per "
        "node and realization a static error of the reference tilt, along and across the tilt, each normal with sigma "
        "= this percentage of the inclination (the reference inclination is off by the first, the reference azimuth "
        "by the second / sin I). The thesis rig (scenarios/lab): 1.126, the MPU6500's accuracy after calibration, "
        "'+/-1.126 % of the measured value' (thesis table 4.20). 0: the exact geometry (drilling: always; the errors "
        "are against the well path itself)"
    )

    @model_validator(mode="after")
    def _window_ordered(self) -> "MetricsSection":
        if self.window_end_s <= self.window_start_s:
            raise ValueError(
                f"window_end_s ({self.window_end_s}) must be greater than window_start_s ({self.window_start_s})"
            )
        return self


class Scenario(_Section):
    """A whole scenario.  Built once from a file; frozen afterwards."""

    name: str = Field("scenario", min_length=1, max_length=100, pattern=r"^[A-Za-z0-9_.-]+$")
    description: str = ""
    seed: int = Field(0, ge=0, le=2**63 - 1, description="root seed of every random stream")
    simulation: SimulationSection = SimulationSection()
    chain: ChainSection = ChainSection()
    motion: MotionSection = MotionSection()
    sensor: SensorSection = SensorSection()
    filter: FilterSection = FilterSection()
    firmware: FirmwareSection = FirmwareSection()
    schedule: ScheduleSection = ScheduleSection()
    metrics: MetricsSection = MetricsSection()
    radio: RadioSection = RadioSection()
    mac: MacSection = MacSection()
    faults: FaultsSection = FaultsSection()
    output: OutputSection = OutputSection()

    @model_validator(mode="after")
    def _metrics_inside_run(self) -> "Scenario":
        if self.metrics.window_end_s > self.simulation.duration_s:
            raise ValueError(
                f"metrics.window_end_s ({self.metrics.window_end_s}) must not exceed "
                f"simulation.duration_s ({self.simulation.duration_s})"
            )
        seen: set[int] = set()
        for i, node in enumerate(self.chain.node):
            if node.id > self.chain.nodes:
                raise ValueError(
                    f"chain.node[{i}].id = {node.id}: unknown node id (allowed: 1..{self.chain.nodes}, chain.nodes)"
                )
            if node.id in seen:
                raise ValueError(f"chain.node[{i}].id = {node.id}: node id given twice")
            seen.add(node.id)
        check_indices(self.chain.nodes, self.radio, self.faults)
        dt = 1.0 / self.chain.firmware_rate_hz
        if 2.0 * self.chain.link_delay_s + self.chain.processing_s >= dt:
            raise ValueError(
                f"chain.link_delay_s ({self.chain.link_delay_s}) and chain.processing_s ({self.chain.processing_s}): "
                f"the encoder request, reply and processing must fit in one firmware tick "
                f"(allowed: 2 x link_delay_s + processing_s < {dt:.4g} s at {self.chain.firmware_rate_hz} Hz)"
            )
        if self.firmware.alignment == "slow_rotation" and (self.motion.kind != "lab" or self.motion.slow_turns < 1.0):
            raise ValueError(
                f"firmware.alignment = 'slow_rotation' needs the lab profile's slow rotation of at least one turn "
                f"(motion.kind = {self.motion.kind!r}, motion.slow_turns = {self.motion.slow_turns}); allowed: "
                "'auto', 'none', or a lab motion with slow_turns >= 1")
        if self.mac.bit_errors and (self.radio.model != "channel" or self.filter.implementation != "fixed"):
            raise ValueError(
                f"mac.bit_errors = true needs radio.model = 'channel' (the bit error rate comes from its link "
                f"budget; got {self.radio.model!r}) and filter.implementation = 'fixed' (the frames with bytes; "
                f"got {self.filter.implementation!r})")
        if self.motion.kind == "drilling":
            if self.metrics.reference_accuracy_pct != 0.0:
                raise ValueError(
                    f"metrics.reference_accuracy_pct = {self.metrics.reference_accuracy_pct} models the lab's measured "
                    "truth (thesis sec 4.2.3); a drilling run's errors are against the well path itself (allowed: 0)")
            if self.motion.initial_tubes > self.chain.nodes:
                raise ValueError(
                    f"motion.initial_tubes = {self.motion.initial_tubes}: more tubes in the hole than the chain has "
                    f"nodes (allowed: 1 <= motion.initial_tubes <= chain.nodes = {self.chain.nodes})")
            needed = self.motion.drilling_duration_s(self.chain.nodes)
            if self.simulation.duration_s < needed:
                raise ValueError(
                    f"simulation.duration_s ({self.simulation.duration_s}) must cover the drilling programme of "
                    f"{self.chain.nodes} tubes, {self.motion.initial_tubes} of them in the hole at the start "
                    f"(motion.initial_tubes): motion.initial_static_s + {self.chain.nodes - self.motion.initial_tubes + 1} "
                    f"x (tube_length_m / rate_of_penetration_m_s + survey_stop_s) + "
                    f"{self.chain.nodes - self.motion.initial_tubes} x insertion_s (allowed: >= {needed:.6g} s)"
                )
        return self

    def with_overrides(self, **top_level: Any) -> "Scenario":
        """A copy with dotted-key overrides, re-validated: ``with_overrides(seed=3)`` or ``{'simulation.realizations': 4}``."""
        data = self.model_dump()
        for dotted, value in top_level.items():
            _set_dotted(data, dotted.split("."), value)
        return parse_scenario(data, source="<overrides>")


def _set_dotted(data: dict, keys: list[str], value: Any) -> None:
    for depth, key in enumerate(keys[:-1]):
        data = data.setdefault(key, {})
        if not isinstance(data, dict):
            where = ".".join(keys[: depth + 1])
            raise ScenarioError(f"<overrides>: {'.'.join(keys)}: {where} is a value, not a section")
    data[keys[-1]] = value


def _format_error(source: str, err: ValidationError) -> str:
    """One clear line per problem: file, key path, what is allowed, what was given."""
    lines = []
    for e in err.errors():
        path = ".".join(str(p) for p in e["loc"]) or "<top level>"
        msg = e["msg"]
        if e["type"] == "extra_forbidden":
            msg = "unknown key"
        given = e.get("input")
        shown = "" if e["type"] in ("extra_forbidden", "missing") or isinstance(given, dict) else f" (got {given!r})"
        lines.append(f"{source}: {path}: {msg}{shown}")
    return "\n".join(lines)


def parse_scenario(data: dict[str, Any], source: str = "<scenario>") -> Scenario:
    """Validate a scenario given as a dict (e.g. parsed TOML)."""
    try:
        return Scenario.model_validate(data)
    except ValidationError as err:
        raise ScenarioError(_format_error(source, err)) from None


def load_scenario(path: str | Path) -> tuple[Scenario, str]:
    """Read and validate a TOML scenario.  Returns the scenario and the SHA-256 of the file bytes."""
    path = Path(path)
    try:
        raw = path.read_bytes()
    except OSError as err:
        raise ScenarioError(f"{path}: cannot read scenario file ({err.strerror})") from None
    return _parse_toml(raw, str(path))


def _parse_toml(raw: bytes, source: str) -> tuple[Scenario, str]:
    try:
        data = tomllib.loads(raw.decode("utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as err:
        raise ScenarioError(f"{source}: not valid TOML ({err})") from None
    return parse_scenario(data, source=source), hashlib.sha256(raw).hexdigest()


def read_scenario(source: "str | Path | dict | Scenario") -> tuple[Scenario, str | None]:
    """A scenario from a file path, a TOML string, a dict (parsed TOML) or a :class:`Scenario`.

    Returns the scenario and the SHA-256 of its source bytes (the file or the TOML text; for a dict or a
    Scenario, of its canonical JSON, sorted keys).  A string is a TOML text when it spans several lines or
    contains ``=``; otherwise it is a path, and a missing file is a clear error.
    """
    if isinstance(source, Scenario):
        return source, _canonical_sha256(source.model_dump())
    if isinstance(source, dict):
        return parse_scenario(source), _canonical_sha256(source)
    if isinstance(source, Path):
        return load_scenario(source)
    if isinstance(source, str):
        if "\n" in source or "=" in source:
            return _parse_toml(source.encode("utf-8"), "<scenario text>")
        return load_scenario(Path(source))
    raise ScenarioError(
        f"scenario: expected a path, a TOML string, a dict or a Scenario (got {type(source).__name__})"
    )


def _canonical_sha256(data: dict) -> str:
    return hashlib.sha256(json.dumps(data, sort_keys=True, default=str).encode()).hexdigest()
