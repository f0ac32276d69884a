"""Sensor adapter: the one place where the chain turns true motion into what a node and the encoder read.

``sensor.model = "tick_averaged"`` (default): the tick-averaged stand-ins of :mod:`nodesim.sensors.tick_averaged`;
``"mpu6500_counts"``: the sensor-rate MPU6500 count model of :mod:`nodesim.sensors.chain_imu` (docs/firmware.md,
"Sensor model", says why it is not yet the default).  Stand-ins, per node n with true tick times T_n[k]:
    gyro[k]  = (1 + s) * mean true rate over [T_n[k-1], T_n[k]) + b_n(T_n[k]) + white noise   (k = 0: rate 0)
    b_n(t)   = turn-on bias + residual bias after the node's filter start (motion) + Gauss-Markov bias
    accel[k] = sensor-frame specific force averaged over the tick (:func:`_tick_mean_force`) + white noise
(the z gyro sees the string spin; the node's yaw may differ from the spin angle by the wellpath twist)
Random streams: node n's "gyro" and "accel" streams (nodesim.rng.streams), one generator per realization.
"""

from __future__ import annotations

import math
import weakref
from dataclasses import dataclass

import numpy as np

from nodesim.motion.timelines import ChainMotion
from nodesim.rng.streams import RunStreams
from nodesim.scenario.schema import Scenario
from nodesim.sensors.chain_imu import ChainImu, SharedTruth, node_counts
from nodesim.sensors.tick_averaged import AccelModel, GyroZModel
from nodesim.sensors.encoder import RotaryEncoder
from nodesim.units import DEG, G0_M_S2, wrap_pi


@dataclass(frozen=True)
class NodeSignals:
    """What one node reads at its ticks, and the truth behind it (arrays (R, K) unless noted)."""

    t_s: np.ndarray  # (K,) true tick times
    gyro_rad_s: np.ndarray
    true_bias_rad_s: np.ndarray
    true_yaw_rad: np.ndarray  # (K,)
    true_inclination_rad: np.ndarray  # (K,)
    true_azimuth_rad: np.ndarray  # (K,)
    specific_force: np.ndarray  # (R, K, 3) sensor frame
    gyro_white_sigma_rad_s: float  # per-tick white-noise sigma (used in R of the next node)
    accel_sigma_m_s2: float  # per-tick, per-axis accelerometer noise sigma
    # per-tick integer sums of the int16 samples and their number: the count model's, or (stand-ins, fixed
    # firmware only) the tick means requantised as 34 samples at the configured ranges' sensitivities
    gyro_counts: np.ndarray | None = None  # (R, K, 3) int64
    accel_counts: np.ndarray | None = None  # (R, K, 3) int64
    samples: np.ndarray | None = None  # (K,) int64
    gyro_clipped_samples: np.ndarray | None = None  # (R,) int64 gyro axis readings clipped (count model only)
    accel_clipped_samples: np.ndarray | None = None  # (R,) int64 accelerometer axis readings clipped


def gyro_model(scenario: Scenario) -> GyroZModel:
    s = scenario.sensor
    return GyroZModel(
        arw_rad_per_sqrt_s=s.gyro_arw_deg_per_sqrt_s * DEG,
        turn_on_bias_rad_s=s.gyro_turn_on_bias_deg_s * DEG,
        residual_bias_rad_s=s.gyro_residual_bias_deg_s * DEG,
        bias_instability_rad_s=s.gyro_bias_instability_deg_s * DEG,
        bias_tau_s=s.gyro_bias_tau_s,
        scale_factor_error=s.gyro_scale_factor_error,
    )


def node_signals(
    scenario: Scenario, motion: ChainMotion, streams: RunStreams, node_index: int, t_s: np.ndarray, dt_s: float
) -> NodeSignals:
    """Sensor readings of node ``node_index`` (0-based) at true tick times ``t_s`` for every realization
    (``sensor.model``: the tick-averaged stand-ins, or the MPU6500 count model)."""
    if scenario.sensor.model == "mpu6500_counts":
        return _count_model_signals(scenario, motion, streams, node_index, t_s, dt_s)
    R = scenario.simulation.realizations
    K = t_s.size
    fixed = scenario.filter.implementation == "fixed"
    imu = ChainImu.from_scenario(scenario)  # its ranges give the stand-in's count sensitivities
    gyro = gyro_model(scenario)
    accel = AccelModel(noise_m_s2_per_sqrt_hz=scenario.sensor.accel_noise_ug_per_sqrt_hz * 1e-6 * G0_M_S2)
    timeline = motion.timelines[node_index]
    rot = motion.rotation
    gyro_normals = streams.sensor_normals(R, node_index, "gyro", gyro.normals_needed(K))
    gm = gyro.gauss_markov(gyro_normals, K, dt_s)
    true_bias = gyro.true_bias_rad_s(t_s[None, :], timeline.filter_start_s, gm)
    true_rate = np.zeros(K)
    if K > 1:
        true_rate[1:] = rot.mean_rate_rad_s(t_s[:-1], t_s[1:])
    meas = (1.0 + gyro.scale_factor_error) * true_rate[None, :] + true_bias
    meas += gyro.white_noise(gyro_normals, K, dt_s)
    att = motion.attitude(node_index, t_s)
    f = accel.noise(streams.sensor_normals(R, node_index, "accel", 3 * K), K, dt_s)
    f += _tick_mean_force(accel, att)[None]  # noise-free tick mean + noise
    return NodeSignals(
        t_s=t_s,
        gyro_rad_s=meas,
        true_bias_rad_s=true_bias,
        true_yaw_rad=att.yaw_rad,
        true_inclination_rad=att.inclination_rad,
        true_azimuth_rad=att.azimuth_rad,
        specific_force=f,
        gyro_white_sigma_rad_s=gyro.arw_rad_per_sqrt_s / np.sqrt(dt_s),
        accel_sigma_m_s2=accel.noise_m_s2_per_sqrt_hz / np.sqrt(dt_s),
        # only the fixed firmware reads counts (the float filter reads gyro_rad_s / specific_force)
        gyro_counts=_stand_in_gyro_counts(meas, imu.gyro_lsb_per_deg_s) if fixed else None,
        accel_counts=np.rint(f / G0_M_S2 * imu.accel_lsb_per_g * 34).astype(np.int64) if fixed else None,
        samples=np.full(K, 34, dtype=np.int64) if fixed else None,
    )


def _tick_mean_force(accel: AccelModel, att) -> np.ndarray:
    """(K, 3) noise-free specific force averaged over each tick's window [T[k-1], T[k]], as the summed counts of the
    sensor see it.  The transverse components rotate with the yaw about the tube axis (f_xy = g sin I (cos, sin) of
    the yaw plus a constant), so at a constant rate over the tick their mean is the vector at the window's middle
    yaw, psi_mid = psi_k - d/2, shortened by sin(d/2) / (d/2), d = wrap(psi_k - psi_(k-1)); f_z = g cos I is
    unchanged (inclination and azimuth taken at T[k]; the first tick, with no window before it, at psi_0).  The
    firmware pairs this mean with its own mid-window yaw (firmware_model.node_survey.mid_yaw)."""
    yaw = np.asarray(att.yaw_rad, dtype=float)
    d = np.zeros_like(yaw)
    d[1:] = wrap_pi(np.diff(yaw))
    f = accel.specific_force(att.inclination_rad, att.azimuth_rad, yaw)
    # f_xy(psi - d/2) = R_z(d/2) f_xy(psi) (the body frame turns with the yaw), times sin(d/2) / (d/2)
    half = 0.5 * d
    gain = np.sinc(half / np.pi)  # numpy's sinc(x) = sin(pi x) / (pi x)
    c, s = np.cos(half) * gain, np.sin(half) * gain
    fx, fy = f[..., 0].copy(), f[..., 1].copy()
    f[..., 0] = c * fx - s * fy
    f[..., 1] = s * fx + c * fy
    return f


def _stand_in_gyro_counts(gyro_z_rad_s: np.ndarray, lsb_per_deg_s: float) -> np.ndarray:
    """(R, K, 3) int64: 34 samples of the z rate at ``lsb_per_deg_s``, nothing on x and y (the stand-in's counts)."""
    counts = np.zeros(gyro_z_rad_s.shape + (3,), dtype=np.int64)
    counts[..., 2] = np.rint(gyro_z_rad_s / DEG * lsb_per_deg_s * 34)
    return counts


def _count_model_signals(scenario: Scenario, motion: ChainMotion, streams: RunStreams, node_index: int,
                         t_s: np.ndarray, dt_s: float) -> NodeSignals:
    """``sensor.model = "mpu6500_counts"``: every node reads the sensor-rate count model of
    :mod:`nodesim.sensors.chain_imu` (MPU6500 int16 counts, full-scale clipping, misalignment, scale factor,
    biases, white noise, residual tilt; ``sensor.sampling`` per_sample or tick_sum); the float path reads the
    same sensor, the sums converted to SI:  gyro[k] = gyro_counts[k, z] / n_k / S_g,
    accel[k] = accel_counts[k] / n_k / S_a."""
    R = scenario.simulation.realizations
    imu = ChainImu.from_scenario(scenario)
    c = node_counts(imu, motion, streams, node_index, t_s, dt_s, R, _shared_truth(scenario, imu, motion, dt_s))
    att = motion.attitude(node_index, t_s)
    n = c.samples.astype(float)
    return NodeSignals(
        t_s=t_s,
        gyro_rad_s=c.gyro_counts[:, :, 2] / n / imu.gyro_lsb_per_rad_s,
        true_bias_rad_s=c.true_bias_rad_s,
        true_yaw_rad=att.yaw_rad,
        true_inclination_rad=att.inclination_rad,
        true_azimuth_rad=att.azimuth_rad,
        specific_force=c.accel_counts / n[None, :, None] / imu.accel_lsb_per_m_s2,
        gyro_white_sigma_rad_s=imu.gyro_arw_rad_per_sqrt_s / np.sqrt(dt_s),
        accel_sigma_m_s2=imu.accel_density_m_s2_per_sqrt_hz / np.sqrt(dt_s),
        gyro_counts=c.gyro_counts,
        accel_counts=c.accel_counts,
        samples=c.samples,
        gyro_clipped_samples=c.gyro_clipped_samples,
        accel_clipped_samples=c.accel_clipped_samples,
    )


_LAST_TRUTH: list = [None]  # (weakref to the motion, key, SharedTruth) of the latest run


def _shared_truth(scenario: Scenario, imu: ChainImu, motion: ChainMotion, dt_s: float) -> SharedTruth | None:
    """The lab's per-sample truth, the same for every node (a rigid string), computed once per run on the grid of
    every sample a tick in [0, duration] can read (nodes whose samples fall outside compute their own)."""
    if scenario.motion.kind != "lab":
        return None
    key = (imu, dt_s, scenario.simulation.duration_s)
    last = _LAST_TRUTH[0]
    if last is not None and last[0]() is motion and last[1] == key:
        return last[2]
    rate = imu.sample_rate_hz
    truth = SharedTruth(imu, motion, math.floor(-dt_s * rate) + 1, math.floor(scenario.simulation.duration_s * rate) + 1)
    _LAST_TRUTH[0] = (weakref.ref(motion), key, truth)
    return truth


@dataclass(frozen=True)
class EncoderReader:
    """The rotary encoder at the top of the string (:class:`nodesim.sensors.encoder.RotaryEncoder`): the
    count nearest the string angle and the rate it sends with it (count difference over its rate window)."""

    encoder: RotaryEncoder
    motion: ChainMotion

    @classmethod
    def from_scenario(cls, scenario: Scenario, motion: ChainMotion) -> "EncoderReader":
        return cls(RotaryEncoder(counts_per_rev=scenario.sensor.encoder_counts_per_rev), motion)

    @property
    def variance_rad2(self) -> float:
        """Quantisation variance (q^2 / 12): the R of an encoder update (thesis digest 2.6)."""
        return self.encoder.quantisation_sigma_rad**2

    def read(self, t_s: float) -> tuple[float, float]:
        """(quantised yaw, differenced rate) read at true time ``t_s``."""
        r = self.encoder.read(self.motion.rotation.yaw_rad, np.asarray(t_s, dtype=float))
        return float(r.yaw_rad), float(r.rate_rad_s)

    def read_many(self, t_s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(quantised yaw, differenced rate) read at true times ``t_s`` (one per realization)."""
        r = self.encoder.read(self.motion.rotation.yaw_rad, np.asarray(t_s, dtype=float))
        return np.asarray(r.yaw_rad, dtype=float), np.asarray(r.rate_rad_s, dtype=float)
