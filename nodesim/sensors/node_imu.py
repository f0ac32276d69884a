"""True IMU inputs of one node along a drilling process, and its simulated sensor-rate IMU record.

Composition of :mod:`nodesim.motion.drilling` (truth) and :mod:`nodesim.sensors.imu` (errors): the z gyro sees
the string spin, the transverse gyros see nothing (the path-curvature rates at drilling speeds, ROP x
dogleg rate, are below 1e-5 rad/s and neglected), the accelerometers see the specific force of the tube
at its inclination, azimuth and yaw (thesis eqs 1.1-1.3 frame).  Before a node is inserted it is at the
surface at rest and its inputs are those of its insertion instant.  Random streams: pass the node's
``gyro`` and ``accel`` generators from :class:`nodesim.rng.streams.RunStreams`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nodesim.motion.drilling import DrillingProcess
from nodesim.errors import NodesimError
from nodesim.sensors.imu import ImuSpec, TriadSamples
from nodesim.sensors.magnetometer import specific_force_body


@dataclass(frozen=True)
class NodeImuRecord:
    t_s: np.ndarray
    true_rate_rad_s: np.ndarray  # (K, 3)
    true_force_m_s2: np.ndarray  # (K, 3)
    gyro: TriadSamples
    accel: TriadSamples


def node_true_inputs(process: DrillingProcess, node: int, t_s) -> tuple[np.ndarray, np.ndarray]:
    """(true body rate (K, 3) rad/s, true specific force (K, 3) m/s^2) of ``node`` at times ``t_s``."""
    if not 0 <= node < process.tubes:
        raise NodesimError(f"node {node} does not exist (allowed: 0..{process.tubes - 1})")
    t = np.asarray(t_s, dtype=float)
    t_in = process.insertion_times_s()[node]
    truth = process.node_truth(node, np.maximum(t, t_in))
    rate = np.zeros(t.shape + (3,))
    rate[..., 2] = np.where(t >= t_in, truth.spin_rate_rad_s, 0.0)
    force = specific_force_body(truth.inclination_rad, truth.azimuth_rad, truth.yaw_rad)
    return rate, force


def simulate_node_imu(
    process: DrillingProcess, imu: ImuSpec, node: int, t0_s: float, duration_s: float, gyro_rng, accel_rng, temperature_c=None
) -> NodeImuRecord:
    """Sensor-rate IMU record of ``node`` over [t0, t0 + duration]: counts and SI values."""
    t = imu.sample_times(duration_s, t0_s)
    rate, force = node_true_inputs(process, node, t)
    gyro, accel = imu.measure(rate, force, gyro_rng, accel_rng, temperature_c)
    return NodeImuRecord(t, rate, force, gyro, accel)
