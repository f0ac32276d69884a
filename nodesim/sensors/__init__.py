"""Sensor stand-ins for the walking skeleton: z gyro, accelerometer triad, incremental encoder.

Everything is batched over realizations (leading axis R) and produced directly at the firmware tick
(the average over one tick interval), which is what the firmware reads after its own averaging.  The
full IMU model (scale/misalignment, quantisation to int16 counts at the sensor rate, decimation) replaces
this module in the sensor issue; the interface (arrays per tick) stays.

Noise conventions (IEEE Std 952 / thesis appendix V): a white-noise density N (deg/sqrt(s) for a gyro,
ug/sqrt(Hz) for an accelerometer) averaged over T seconds has standard deviation N / sqrt(T); this is the
Allan deviation of white noise at tau = T.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from nodesim.kinematics import LabRotationProfile
from nodesim.units import G0_M_S2


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

    def gauss_markov(self, rng_per_realization: list[np.random.Generator], n_ticks: int, dt_s: float) -> np.ndarray:
        """Stationary Gauss-Markov bias samples, shape (R, K)."""
        phi = math.exp(-dt_s / self.bias_tau_s)
        drive = self.bias_instability_rad_s * math.sqrt(1.0 - phi * phi)
        w = np.stack([rng.standard_normal(n_ticks) for rng in rng_per_realization])
        out = np.empty_like(w)
        out[:, 0] = self.bias_instability_rad_s * w[:, 0]
        for k in range(1, n_ticks):  # recursion over ticks, vectorised over realizations
            out[:, k] = phi * out[:, k - 1] + drive * w[:, k]
        return out

    def white_noise(self, rng_per_realization: list[np.random.Generator], n_ticks: int, dt_s: float) -> np.ndarray:
        """Rate noise averaged over one tick, shape (R, K): sigma = ARW / sqrt(dt)."""
        sigma = self.arw_rad_per_sqrt_s / math.sqrt(dt_s)
        return np.stack([sigma * rng.standard_normal(n_ticks) for rng in rng_per_realization])


@dataclass(frozen=True)
class AccelModel:
    """Accelerometer triad: specific force of a tilted, rotating tube plus white noise.

    In the untwisted tilted frame f = g [sinI cosA, sinI sinA, cosI] (thesis digest 1.2, z up-hole); the
    sensor frame is rotated by yaw psi about z: f' = Rz(-psi) f, so that eq 1.1 (f = Rz(psi) f') recovers f.
    """

    noise_m_s2_per_sqrt_hz: float

    def specific_force(self, inclination_rad: float, azimuth_rad: float, yaw_rad: np.ndarray) -> np.ndarray:
        """Noise-free sensor-frame specific force, shape yaw.shape + (3,)."""
        fx = G0_M_S2 * math.sin(inclination_rad) * math.cos(azimuth_rad)
        fy = G0_M_S2 * math.sin(inclination_rad) * math.sin(azimuth_rad)
        fz = G0_M_S2 * math.cos(inclination_rad)
        c, s = np.cos(yaw_rad), np.sin(yaw_rad)
        return np.stack([c * fx + s * fy, -s * fx + c * fy, np.full_like(c, fz)], axis=-1)

    def noise(self, rng_per_realization: list[np.random.Generator], n_ticks: int, dt_s: float) -> np.ndarray:
        """White noise averaged over one tick, shape (R, K, 3)."""
        sigma = self.noise_m_s2_per_sqrt_hz / math.sqrt(dt_s)
        return np.stack([sigma * rng.standard_normal((n_ticks, 3)) for rng in rng_per_realization])


@dataclass(frozen=True)
class Encoder:
    """Incremental rotary encoder at the top of the string: yaw quantised to whole counts.

    Quantisation step q = 2 pi / counts_per_rev; a uniform quantisation error has sigma = q / sqrt(12)
    (0.1015 deg for 1024 counts/rev, thesis digest 2.6).  The rate it sends is the true rate (its own
    differencing noise is below the gyro noise and is modelled in the sensor issue).
    """

    counts_per_rev: int

    @property
    def step_rad(self) -> float:
        return 2.0 * math.pi / self.counts_per_rev

    @property
    def quantisation_sigma_rad(self) -> float:
        return self.step_rad / math.sqrt(12.0)

    def read_rad(self, true_yaw_rad) -> np.ndarray:
        """Quantised yaw: the nearest whole count times the step."""
        return np.round(np.asarray(true_yaw_rad) / self.step_rad) * self.step_rad


def lab_tick_signals(profile: LabRotationProfile, t_start_s: np.ndarray, dt_s: float):
    """True yaw at tick start and true mean rate over each tick [t, t+dt) for the lab profile."""
    return profile.yaw_rad(t_start_s), profile.mean_rate_rad_s(t_start_s, t_start_s + dt_s)
