"""Sensor adapter: the one place where the chain turns true motion into what a node and the encoder read.

Every node reads the sensor-rate MPU6500 count model of :mod:`nodesim.sensors.chain_imu` (int16 counts summed per
firmware tick: 3-axis gyro and accelerometer, full-scale clipping, misalignment, scale factor, biases, white noise,
residual tilt; ``sensor.sampling`` per_sample or tick_sum).  The fixed firmware reads the counts; the float filter
reads the same sensor, the sums converted to SI:  gyro[k] = gyro_counts[k, z] / n_k / S_g,
accel[k] = accel_counts[k] / n_k / S_a.  (The tick-averaged float stand-ins this adapter once fed the chain are
gone: issue 19.)
"""

from __future__ import annotations

import functools
import math
import weakref
from dataclasses import dataclass

import numpy as np
from numba import njit

from nodesim.motion.timelines import ChainMotion
from nodesim.rng.streams import RunStreams
from nodesim.scenario.schema import Scenario
from nodesim.sensors.chain_imu import ChainImu, node_counts
from nodesim.sensors.sample_truth import SampleTruth
from nodesim.sensors.encoder import RotaryEncoder


@dataclass(frozen=True)
class NodeSignals:
    """What one node reads at its ticks, and the truth behind it (arrays (R, K) unless noted)."""

    t_s: np.ndarray  # (K,) true tick times
    true_bias_rad_s: np.ndarray
    true_yaw_rad: np.ndarray  # (K,)
    true_inclination_rad: np.ndarray  # (K,)
    true_azimuth_rad: np.ndarray  # (K,)
    gyro_white_sigma_rad_s: float  # per-tick white-noise sigma (used in R of the next node)
    accel_sigma_m_s2: float  # per-tick, per-axis accelerometer noise sigma
    # per-tick integer sums of the int16 samples and their number (what the fixed firmware reads)
    gyro_counts: np.ndarray  # (R, K, 3) int64
    accel_counts: np.ndarray  # (R, K, 3) int64
    samples: np.ndarray  # (K,) int64
    gyro_clipped_samples: np.ndarray  # (R,) int64 gyro axis readings clipped at full scale
    accel_clipped_samples: np.ndarray  # (R,) int64 accelerometer axis readings clipped
    gyro_lsb_per_rad_s: float  # the count scales the float filter's SI readings are converted with
    accel_lsb_per_m_s2: float
    # (R, 2) rad: the static error of the reference tilt the metrics compare with (along, across the tilt;
    # metrics.reference_accuracy_pct, :func:`reference_error_rad`); None: the exact geometry
    reference_error_rad: np.ndarray | None = None

    @property
    def shape(self) -> tuple[int, int]:
        """(R, K): realizations and ticks."""
        return self.gyro_counts.shape[:2]

    @property
    def gyro_rad_s(self) -> np.ndarray:
        """(R, K) the z gyro's tick mean in rad/s (module docstring), converted when first read."""
        return self._si[0]

    @property
    def specific_force(self) -> np.ndarray:
        """(R, K, 3) the accelerometers' tick means in m/s^2, sensor frame (module docstring), converted when first
        read."""
        return self._si[1]

    @functools.cached_property
    def _si(self) -> tuple[np.ndarray, np.ndarray]:
        """Both SI readings, in one pass (:func:`_counts_to_si`): only the float filter, the 6-state filter and the
        replay logs read them; the fixed firmware reads the counts (the drilling day never converts them: ~1.5 ms
        and 5 MB a node)."""
        R, K = self.shape
        gyro, force = np.empty((R, K)), np.empty((R, K, 3))
        _counts_to_si(self.gyro_counts, self.accel_counts, self.samples, self.gyro_lsb_per_rad_s,
                      self.accel_lsb_per_m_s2, gyro, force)
        return gyro, force


def node_signals(
    scenario: Scenario, motion: ChainMotion, streams: RunStreams, node_index: int, t_s: np.ndarray, dt_s: float
) -> NodeSignals:
    """Sensor readings of node ``node_index`` (0-based) at true tick times ``t_s`` for every realization (module
    docstring)."""
    R = scenario.simulation.realizations
    imu = ChainImu.from_scenario(scenario)
    c = node_counts(imu, motion, streams, node_index, t_s, dt_s, R, shared_truth(scenario, motion, dt_s))
    att = motion.attitude(node_index, t_s)
    return NodeSignals(
        t_s=t_s,
        true_bias_rad_s=c.true_bias_rad_s,
        true_yaw_rad=att.yaw_rad,
        true_inclination_rad=att.inclination_rad,
        true_azimuth_rad=att.azimuth_rad,
        gyro_white_sigma_rad_s=imu.gyro_white_arw_rad_per_sqrt_s / np.sqrt(dt_s),
        accel_sigma_m_s2=imu.accel_density_m_s2_per_sqrt_hz / np.sqrt(dt_s),
        gyro_counts=c.gyro_counts,
        accel_counts=c.accel_counts,
        samples=c.samples,
        gyro_clipped_samples=c.gyro_clipped_samples,
        accel_clipped_samples=c.accel_clipped_samples,
        gyro_lsb_per_rad_s=imu.gyro_lsb_per_rad_s,
        accel_lsb_per_m_s2=imu.accel_lsb_per_m_s2,
        reference_error_rad=reference_error_rad(scenario, streams, node_index),
    )


@njit(cache=True, _nrt=False, nogil=True)
def _counts_to_si(gyro_counts, accel_counts, samples, gyro_lsb, accel_lsb, gyro_out, force_out) -> None:
    """gyro[r, k] = gyro_counts[r, k, z] / n_k / S_g and force[r, k, i] = accel_counts[r, k, i] / n_k / S_a (module
    docstring) in one pass: the same two IEEE divisions, in that order, as numpy's expressions (the int64 sums
    converted to float first, as numpy does), without their temporaries."""
    for r in range(gyro_out.shape[0]):
        for k in range(gyro_out.shape[1]):
            n = float(samples[k])
            gyro_out[r, k] = float(gyro_counts[r, k, 2]) / n / gyro_lsb
            for i in range(3):
                force_out[r, k, i] = float(accel_counts[r, k, i]) / n / accel_lsb


def reference_error_rad(scenario: Scenario, streams: RunStreams, node_index: int) -> np.ndarray | None:
    """(R, 2): node ``node_index``'s static error of the lab's measured truth, (along, across the tilt) in rad, or None.

    Thesis sec 4.2.3: before each run "the true inclination and azimuth is determined after the initial
    calibration", i.e. measured, once; the thesis gives the MPU6500's accuracy after calibration as "+/-1.126 % of
    the measured value" (table 4.20).  Each component is normal with sigma = ``metrics.reference_accuracy_pct`` % of
    the lab tube's inclination (2 deg: 0.0225 deg), per node and realization (stream ``reference``: 2 normals).
    The reference inclination is off by the along component, the reference azimuth by the across one / sin I
    (:func:`nodesim.chain.metrics.reference_attitude`).  The alignment offset cannot remove it (it is not in the
    sensor frame), unlike the residual sensor tilt."""
    pct = scenario.metrics.reference_accuracy_pct
    if scenario.motion.kind != "lab" or pct == 0.0:
        return None
    sigma = pct / 100.0 * math.radians(scenario.motion.inclination_deg)
    return streams.sensor_normals(scenario.simulation.realizations, node_index, "reference", 2) * sigma


_LAST_TRUTH: list = [None]  # (weakref to the motion, key, SampleTruth) of the latest run


def shared_truth(scenario: Scenario, motion: ChainMotion, dt_s: float) -> SampleTruth | None:
    """The per-sample truth every node shares (:attr:`ChainMotion.shared_attitude`: the lab's rigid string, a
    drilling string in a straight hole), computed once per run on the grid of every sample a tick in [0, duration]
    can read (nodes whose samples fall outside compute their own); None where the nodes differ."""
    if motion.shared_attitude is None:
        return None
    imu = ChainImu.from_scenario(scenario)
    key = (imu, dt_s, scenario.simulation.duration_s)
    last = _LAST_TRUTH[0]
    if last is not None and last[0]() is motion and last[1] == key:
        return last[2]
    rate = imu.sample_rate_hz
    truth = SampleTruth(imu, motion, math.floor(-dt_s * rate) + 1, math.floor(scenario.simulation.duration_s * rate) + 1,
                        shared=True, keep_readings=imu.sampling != "tick_sum")  # tick sums need only its sums
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
