"""Float indirect (error-state) Kalman yaw filter, batched over realizations (walking-skeleton version).

State (thesis eq 3.23 reduced to the near-vertical 2-state form, thesis digest 2.4):
    dx = [d_psi, b_z]      d_psi = psi_INS - psi_true (rad),  b_z = uncompensated z-gyro bias (rad/s)
Continuous model (eqs 3.22, 3.24-3.26):   d_psi' = b_z + n_v,   b_z' = -b_z / tau + n_b
Euler discretisation at dt = 1 / f_firmware (digest 2.5):
    Phi = [[1, dt], [0, 1 - dt/tau]],   Q_d = G Q G^T dt,   G = diag(A, B)   (tuning, eq 4.14)
    Q = diag(sigma_v^2, 2 sigma_b^2 / tau)
Measurement (eqs 3.27-3.31):  z = wrap(psi_INS - psi_ref),  H = [1, 0],  R = reference variance.
Update (eqs 3.11-3.14):  K = P H^T / (H P H^T + R);  dx = K z;  P = (I - K H) P, symmetrised.
Closed-loop reset (digest 2.7): psi_INS -= d_psi;  b_hat += b_z;  dx = 0;  P kept.

The full filter (fixed-point twin, 6-state option, checks against filterpy) is the firmware issue's work;
this class is the interface it keeps: ``predict(rate)`` and ``update(reference, variance, mask)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class YawFilterConfig:
    """Tuning of the yaw filter; SI units (rad, s)."""

    dt_s: float
    arw_rad_per_sqrt_s: float
    bias_instability_rad_s: float
    bias_tau_s: float
    tuning_a: float = 1.0
    tuning_b: float = 5.0
    initial_yaw_sigma_rad: float = math.radians(1.0)
    initial_bias_sigma_rad_s: float = math.radians(0.05)

    def __post_init__(self) -> None:
        for name in ("dt_s", "bias_tau_s", "tuning_a", "tuning_b"):
            if not getattr(self, name) > 0:
                raise ValueError(f"YawFilterConfig.{name} must be > 0, got {getattr(self, name)}")


def _wrap_pi(x: np.ndarray) -> np.ndarray:
    return np.remainder(x + math.pi, 2.0 * math.pi) - math.pi


class FloatYawFilter:
    """R independent 2-state yaw filters advanced together (arrays of shape (R,) and (R, 2, 2))."""

    def __init__(self, config: YawFilterConfig, realizations: int, initial_yaw_rad=0.0, bias_offset_rad_s=0.0):
        self.config = config
        dt = config.dt_s
        self.phi = np.array([[1.0, dt], [0.0, 1.0 - dt / config.bias_tau_s]])
        q_rate = (config.tuning_a * config.arw_rad_per_sqrt_s) ** 2
        q_bias = config.tuning_b**2 * 2.0 * config.bias_instability_rad_s**2 / config.bias_tau_s
        self.q_d = np.diag([q_rate, q_bias]) * dt
        self.yaw_rad = np.broadcast_to(np.asarray(initial_yaw_rad, float), (realizations,)).copy()
        self.bias_rad_s = np.broadcast_to(np.asarray(bias_offset_rad_s, float), (realizations,)).copy()
        p0 = np.diag([config.initial_yaw_sigma_rad**2, config.initial_bias_sigma_rad_s**2])
        self.p = np.broadcast_to(p0, (realizations, 2, 2)).copy()

    @property
    def yaw_variance_rad2(self) -> np.ndarray:
        """P_psi_psi: what a node transmits with its estimate."""
        return self.p[:, 0, 0]

    def predict(self, measured_rate_rad_s: np.ndarray) -> None:
        """Time update over one tick with the tick-averaged gyro rate (R,)."""
        self.yaw_rad = self.yaw_rad + self.config.dt_s * (measured_rate_rad_s - self.bias_rad_s)
        self.p = self.phi @ self.p @ self.phi.T + self.q_d

    def update(self, reference_yaw_rad: np.ndarray, reference_variance_rad2, mask=None) -> None:
        """Measurement update with a reference yaw; ``mask`` (R,) selects the realizations that got one."""
        innovation = _wrap_pi(self.yaw_rad - reference_yaw_rad)
        s = self.p[:, 0, 0] + reference_variance_rad2
        gain = self.p[:, :, 0] / s[:, None]  # (R, 2)
        if mask is not None:
            gain = np.where(np.asarray(mask)[:, None], gain, 0.0)
        dx = gain * innovation[:, None]
        self.yaw_rad = self.yaw_rad - dx[:, 0]
        self.bias_rad_s = self.bias_rad_s + dx[:, 1]
        kh = np.zeros_like(self.p)
        kh[:, :, 0] = gain
        p = self.p - kh @ self.p
        self.p = 0.5 * (p + np.swapaxes(p, 1, 2))
