"""Tick-averaged sensor stand-ins used by the chain simulation (z gyro and accelerometer).

The stand-ins below are batched over realizations (leading axis R) and produced directly at the firmware
tick (the average over one tick interval), which is what the firmware reads after its own averaging; the
lab simulation uses this tick-averaged path.

Noise conventions (IEEE Std 952 / thesis appendix V): a white-noise density N (deg/sqrt(s) for a gyro,
ug/sqrt(Hz) for an accelerometer) averaged over T seconds has standard deviation N / sqrt(T); this is the
Allan deviation of white noise at tau = T.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nodesim.sensors import noise
from nodesim.sensors.magnetometer import specific_force_body


@dataclass(frozen=True)
class GyroZModel:
    """z gyro: (1 + scale-factor error) * true rate + turn-on bias + residual bias after motion starts + Gauss-Markov bias + white noise.

    Bias b(t) = b_on + b_res * [t >= t_motion] + b_gm(t), with the first-order Gauss-Markov process
    (thesis eqs 3.18-3.20) discretised exactly:  b_gm[k+1] = e^(-dt/tau) b_gm[k] + sigma sqrt(1 - e^(-2dt/tau)) w.
    """

    arw_rad_per_sqrt_s: float
    turn_on_bias_rad_s: float
    residual_bias_rad_s: float
    bias_instability_rad_s: float
    bias_tau_s: float
    scale_factor_error: float = 0.0

    def true_bias_rad_s(self, t_s: np.ndarray, motion_start_s: float, gm: np.ndarray) -> np.ndarray:
        """Total bias at tick times (R, K) given the Gauss-Markov part ``gm`` (R, K)."""
        return self.turn_on_bias_rad_s + self.residual_bias_rad_s * (t_s >= motion_start_s) + gm

    def normals_needed(self, n_ticks: int) -> int:
        """Standard normals per realization for :meth:`gauss_markov` then :meth:`white_noise` (the
        Gauss-Markov part draws nothing when its sigma is 0)."""
        return (n_ticks if self.bias_instability_rad_s != 0.0 else 0) + n_ticks

    def gauss_markov(self, normals: np.ndarray, n_ticks: int, dt_s: float) -> np.ndarray:
        """Stationary Gauss-Markov bias samples (R, K) from the first draws of each row of ``normals``."""
        if self.bias_instability_rad_s == 0.0:
            return np.zeros((normals.shape[0], n_ticks))
        return noise.gauss_markov_from_normals(normals[:, :n_ticks], self.bias_instability_rad_s, self.bias_tau_s,
                                               dt_s)

    def white_noise(self, normals: np.ndarray, n_ticks: int, dt_s: float) -> np.ndarray:
        """Rate noise averaged over one tick (R, K) from the last ``n_ticks`` draws of each row of ``normals``
        (scaled in place): sigma = ARW / sqrt(dt)."""
        return noise.white_from_normals(normals[:, normals.shape[1] - n_ticks:], self.arw_rad_per_sqrt_s, dt_s)


@dataclass(frozen=True)
class AccelModel:
    """Accelerometer triad: specific force of a tilted, rotating tube plus white noise.

    In the untwisted tilted frame f = g [sinI cosA, sinI sinA, cosI] (thesis digest 1.2, z up-hole); the
    sensor frame is rotated by yaw psi about z: f' = Rz(-psi) f, so that eq 1.1 (f = Rz(psi) f') recovers f.
    """

    noise_m_s2_per_sqrt_hz: float

    def specific_force(self, inclination_rad: float, azimuth_rad: float, yaw_rad: np.ndarray) -> np.ndarray:
        """Noise-free sensor-frame specific force, shape yaw.shape + (3,)."""
        return specific_force_body(inclination_rad, azimuth_rad, yaw_rad)

    def noise(self, normals: np.ndarray, n_ticks: int, dt_s: float) -> np.ndarray:
        """White noise averaged over one tick (R, K, 3) from 3 K standard normals per row of ``normals`` (drawn
        in the order of ``standard_normal((K, 3))``; scaled in place)."""
        return noise.white_from_normals(normals.reshape(-1, n_ticks, 3), self.noise_m_s2_per_sqrt_hz, dt_s)
