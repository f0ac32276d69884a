"""Indirect (error-state) Kalman yaw filter of the node, feed-forward chain configuration; float implementation.

State (thesis eq 3.23 reduced to the near-vertical 2-state form, thesis digest 2.4):
    dx = [d_psi, b_z]      d_psi = psi_INS - psi_true (rad),  b_z = uncompensated z-gyro bias (rad/s)
Continuous model (eqs 3.22, 3.24-3.26):   d_psi' = b_z + n_v,   b_z' = -b_z / tau + n_b   (Gauss-Markov bias)
Euler discretisation at dt = 1 / f_firmware (digest 2.5):
    Phi = [[1, dt], [0, 1 - dt/tau]],   Q_d = G Q G^T dt,   G = diag(G_C, G_D)   (tuning factors A, B; eqs 4.14-4.15)
    Q = diag(sigma_v^2, 2 sigma_b^2 / tau)      sigma_v = angle random walk, sigma_b = bias instability
    G_C = A;  G_D = B ("noise_gain": Q_bb x B^2) or G_D = sqrt(B) ("process_noise": Q_bb x B), the two readings
    of eqs 4.14-4.15 (the equations themselves are lost in the thesis text; :attr:`YawFilterConfig.b_tuning`)
Strapdown (digest 2.5):  psi_INS += dt (omega_measured - b_hat)
Measurement (eqs 3.27-3.31):  z = wrap(psi_INS - psi_ref),  H = [1, 0],  R = reference variance
    (encoder quantisation variance, or the previous node's P_psi_psi plus its delay terms, digest 2.6)
Update (eqs 3.11-3.14):  K = P H^T / (H P H^T + R);  dx = K z;  P = (I - K H) P, symmetrised.
Closed-loop reset (digest 2.7):  psi_INS -= d_psi;  b_hat += b_z;  dx = 0;  P kept.

Two implementations share the :class:`YawFilter` interface: :class:`FloatYawFilter` (float64, checked step
by step against filterpy's ``KalmanFilter`` in the tests) and
:class:`firmware_model.fixed_filter.FixedYawFilter` (the MCU's fixed-point arithmetic).  Both advance R
independent filters per call (arrays with a leading realization axis).
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass

import numpy as np

from firmware_model.errors import FirmwareError


B_TUNINGS = ("noise_gain", "process_noise")


@dataclass(frozen=True)
class YawFilterConfig:
    """Tuning of the yaw filter; SI units (rad, s).  Defaults of the thesis digest 4.1/2.4: tau = 500 s,
    A = 1, B = 5; sigma_v and sigma_b come from the Allan variance (thesis table V.1).

    ``b_tuning`` says how B enters the bias process noise (thesis eqs 4.14-4.15 give the noise gain
    G = blkdiag(G_C, G_D) with the tuning factors, but the equations are lost in the extraction, digest 2.4):

    - ``"noise_gain"``:    G_D = B,        Q_d[b, b] = B^2 (2 sigma_b^2 / tau) dt   (B scales the noise gain);
    - ``"process_noise"``: G_D = sqrt(B),  Q_d[b, b] = B   (2 sigma_b^2 / tau) dt   (B scales the process noise).

    A always enters as a noise gain: Q_d[psi, psi] = A^2 sigma_v^2 dt.  :attr:`q_d` is the one place Q is formed,
    for the float filter and for the fixed-point build (whose constants are this Q quantised).  The default,
    ``"process_noise"``, is the reading whose lab simulations come closer to the thesis's 8 published bias convergence
    times (log-RMS error 0.21 against 0.40 for ``"noise_gain"``; ``nodesim validate``, issue 21)."""

    dt_s: float
    arw_rad_per_sqrt_s: float
    bias_instability_rad_s: float
    bias_tau_s: float
    tuning_a: float = 1.0
    tuning_b: float = 5.0
    b_tuning: str = "process_noise"
    initial_yaw_sigma_rad: float = math.radians(1.0)
    initial_bias_sigma_rad_s: float = math.radians(0.05)

    def __post_init__(self) -> None:
        if self.b_tuning not in B_TUNINGS:
            raise FirmwareError(f"YawFilterConfig.b_tuning = {self.b_tuning!r}: allowed {' | '.join(B_TUNINGS)}")
        for name in ("dt_s", "bias_tau_s", "tuning_a", "tuning_b"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise FirmwareError(f"YawFilterConfig.{name} = {v}: allowed finite values > 0")
        for name in ("arw_rad_per_sqrt_s", "bias_instability_rad_s", "initial_yaw_sigma_rad", "initial_bias_sigma_rad_s"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0):
                raise FirmwareError(f"YawFilterConfig.{name} = {v}: allowed finite values >= 0")
        if self.dt_s >= self.bias_tau_s:
            raise FirmwareError(f"YawFilterConfig.dt_s = {self.dt_s}: must be < bias_tau_s = {self.bias_tau_s}")

    @property
    def phi(self) -> np.ndarray:
        """Euler transition matrix Phi = I + F dt."""
        return np.array([[1.0, self.dt_s], [0.0, 1.0 - self.dt_s / self.bias_tau_s]])

    @property
    def q_d(self) -> np.ndarray:
        """Discrete process noise G Q G^T dt with G = diag(A, G_D) (eqs 4.14-4.15; G_D per :attr:`b_tuning`)."""
        q_rate = (self.tuning_a * self.arw_rad_per_sqrt_s) ** 2
        b_gain2 = self.tuning_b**2 if self.b_tuning == "noise_gain" else self.tuning_b
        q_bias = b_gain2 * 2.0 * self.bias_instability_rad_s**2 / self.bias_tau_s
        return np.diag([q_rate, q_bias]) * self.dt_s

    @property
    def p0(self) -> np.ndarray:
        return np.diag([self.initial_yaw_sigma_rad**2, self.initial_bias_sigma_rad_s**2])


def wrap_pi(x):
    """Angle wrapped into [-pi, pi)."""
    return np.remainder(np.asarray(x, dtype=float) + math.pi, 2.0 * math.pi) - math.pi


def check_finite(name: str, x) -> np.ndarray:
    """Reject NaN/inf input (sensor samples, references) with the offending index in the message."""
    x = np.asarray(x, dtype=float)
    bad = ~np.isfinite(x)
    if bad.any():
        idx = tuple(int(i) for i in np.argwhere(bad)[0])
        raise FirmwareError(f"{name}: non-finite value {x[idx]} at index {idx}; allowed finite numbers")
    return x


def batch_arg(name: str, x, realizations: int, dtype=float) -> np.ndarray:
    """Broadcast a scalar or (R,) argument to (R,), naming the argument when the shape does not fit."""
    x = np.asarray(x, dtype=dtype)
    if x.shape == (realizations,):  # already (R,): skip the broadcast (a per-tick call in the chain)
        return x
    try:
        return np.broadcast_to(x, (realizations,))
    except ValueError:
        raise FirmwareError(f"{name}: shape {x.shape} does not fit {realizations} realizations (allowed: () or ({realizations},))") from None


def check_realizations(realizations) -> int:
    """The batch size R of a filter: an integer >= 1."""
    if not (isinstance(realizations, (int, np.integer)) and not isinstance(realizations, bool) and realizations >= 1):
        raise FirmwareError(f"realizations = {realizations!r}: allowed integers >= 1")
    return int(realizations)


def advance_reference(yaw_rad, rate_rad_s, delay_s):
    """Delay-compensated reference (thesis eq 3.29): psi_ref = psi_hat_prev + rate * dt_transfer."""
    if np.any(np.asarray(delay_s) < 0):
        raise FirmwareError(f"advance_reference: delay_s = {delay_s}: allowed >= 0")
    return check_finite("reference yaw", yaw_rad) + check_finite("reference rate", rate_rad_s) * delay_s


def chain_reference_variance(prev_variance_rad2, delay_s, rate_sigma_rad_s=0.0, offset_sigma_rad=0.0):
    """R for a node-to-node update (thesis digest 2.6 [A]): P_psi_psi,n-1 + dt_n^2 sigma_rate^2 + sigma_off^2."""
    return check_finite("reference variance", prev_variance_rad2) + (delay_s * rate_sigma_rad_s) ** 2 + offset_sigma_rad**2


class YawFilter(ABC):
    """The interface both implementations share (filterpy style: ``predict`` then ``update``)."""

    config: YawFilterConfig
    realizations: int

    @abstractmethod
    def predict(self, measured_rate_rad_s) -> None:
        """Time update over one tick with the tick-averaged gyro rate, shape (R,) or scalar."""

    @abstractmethod
    def update(self, reference_yaw_rad, reference_variance_rad2, mask=None) -> None:
        """Measurement update with a reference yaw; ``mask`` (R,) selects the realizations that got one."""

    @property
    @abstractmethod
    def yaw_rad(self) -> np.ndarray:
        """Yaw estimate (R,), what a node transmits."""

    @property
    @abstractmethod
    def bias_rad_s(self) -> np.ndarray:
        """Total z-gyro bias estimate (R,): initial static bias plus the filter's corrections."""

    @property
    @abstractmethod
    def covariance(self) -> np.ndarray:
        """Error covariance P (R, 2, 2) in rad and rad/s."""

    @property
    def yaw_variance_rad2(self) -> np.ndarray:
        """P_psi_psi: what a node transmits with its estimate."""
        return self.covariance[:, 0, 0]

    @property
    def overflow_counts(self) -> dict[str, int]:
        """Saturation/overflow events per site (always empty for the float filter)."""
        return {}

    def _mask(self, mask) -> np.ndarray:
        if mask is None:
            return np.ones(self.realizations, dtype=bool)
        return batch_arg("update mask", mask, self.realizations, dtype=bool)


class FloatYawFilter(YawFilter):
    """R independent 2-state yaw filters in float64.  P is symmetric and kept as its three distinct
    elements (R,) each; Phi P Phi^T and (I - K H) P are written out element by element (same algebra as
    the matrix form checked against filterpy, without batched 2x2 matrix products)."""

    def __init__(self, config: YawFilterConfig, realizations: int, initial_yaw_rad=0.0, bias_offset_rad_s=0.0):
        self.config = config
        self.realizations = R = check_realizations(realizations)
        self._yaw = batch_arg("initial_yaw_rad", check_finite("initial_yaw_rad", initial_yaw_rad), R).copy()
        self._bias = batch_arg("bias_offset_rad_s", check_finite("bias_offset_rad_s", bias_offset_rad_s), R).copy()
        p0 = config.p0
        self.p_yy, self.p_yb, self.p_bb = np.full(R, p0[0, 0]), np.full(R, p0[0, 1]), np.full(R, p0[1, 1])
        dt = config.dt_s
        f = 1.0 - dt / config.bias_tau_s
        q = config.q_d
        self._c = (2.0 * dt, dt * dt, q[0, 0], dt, f, f * f, q[1, 1])

    @property
    def yaw_rad(self) -> np.ndarray:
        return self._yaw

    @property
    def bias_rad_s(self) -> np.ndarray:
        return self._bias

    @property
    def covariance(self) -> np.ndarray:
        return np.stack([np.stack([self.p_yy, self.p_yb], -1), np.stack([self.p_yb, self.p_bb], -1)], -2)

    @property
    def yaw_variance_rad2(self) -> np.ndarray:
        return self.p_yy

    def predict(self, measured_rate_rad_s) -> None:
        rate = batch_arg("gyro rate", check_finite("gyro rate", measured_rate_rad_s), self.realizations)
        self._yaw = self._yaw + self.config.dt_s * (rate - self._bias)
        two_dt, dt2, q_y, dt, f, f2, q_b = self._c
        yy, yb, bb = self.p_yy, self.p_yb, self.p_bb
        self.p_yy = yy + two_dt * yb + dt2 * bb + q_y  # Phi P Phi^T + Q_d, Phi = [[1, dt], [0, f]]
        self.p_yb = f * (yb + dt * bb)
        self.p_bb = f2 * bb + q_b

    def update(self, reference_yaw_rad, reference_variance_rad2, mask=None) -> None:
        ref = batch_arg("reference yaw", check_finite("reference yaw", reference_yaw_rad), self.realizations)
        r = batch_arg("reference variance", check_finite("reference variance", reference_variance_rad2), self.realizations)
        if np.any(r < 0):
            raise FirmwareError("reference variance: negative value; allowed >= 0 (rad^2)")
        innovation = wrap_pi(self._yaw - ref)
        yy, yb, bb = self.p_yy, self.p_yb, self.p_bb
        inv_s = np.where(self._mask(mask), 1.0 / (yy + r), 0.0)  # K = 0 where no reference arrived
        k_y, k_b = yy * inv_s, yb * inv_s
        self._yaw = self._yaw - k_y * innovation
        self._bias = self._bias + k_b * innovation
        self.p_yy = yy - k_y * yy  # (I - K H) P, symmetric: K_b P_yy = K_y P_yb
        self.p_yb = yb - k_y * yb
        self.p_bb = bb - k_b * yb
