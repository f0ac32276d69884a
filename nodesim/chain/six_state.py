"""The chain's 6-state node filter (issue 24, ``filter.states = 6``, float): its input, its start, and the lanes the
SimPy engine drives (the compiled engine runs the same lane functions in its loop,
:mod:`nodesim.chain.compiled.six_state_float_kernel`).

Input: the three gyro axes in rad/s from the tick's count sums, as the 2-state filter converts its z axis
(:mod:`nodesim.chain.sensing`):  omega[k, i] = gyro_counts[k, i] / n_k / S_g.
Start (at the node's filter start, after its static window of n ticks, thesis 4.2.2-4.2.3):
  - gyro bias: the mean of each axis over the static window (the 2-state filter's z-bias rule on all three axes);
  - roll and pitch by levelling the mean specific force f of the window (nav z up, C_b^n = Rz(psi) Ry(theta) Rx(phi),
    so f / |f| = (-sin theta, cos theta sin phi, cos theta cos phi), the third row of C_b^n):
        phi_0 = atan2(f_y, f_z),   theta_0 = atan2(-f_x, sqrt(f_y^2 + f_z^2))
    the thesis resolves the accelerometers for inclination the same way at every survey (digest 2.7 step 4, eqs
    1.1-1.3, 4.3), and initialises the filter at the expected state (eqs 3.15-3.16); that the roll/pitch start is
    taken from the static window is our choice (docs/deviated_wells.md);
  - yaw: psi_0 = psi_enc - c(phi_0, theta_0), so that the twist the node reports starts at the encoder's angle
    (:mod:`nodesim.chain.compiled.six_state_float_kernel`);
  - P_0 of :class:`firmware_model.six_state_filter.SixStateFilterConfig`.
Without a static window (n = 0) the bias starts at 0 (as the 2-state filter's) and the levelling uses the first tick.
"""

from __future__ import annotations

import numpy as np

from nodesim.chain.compiled import six_state_float_kernel as ssk
from nodesim.chain.estimator import six_state_config
from nodesim.chain.sensing import NodeSignals
from nodesim.scenario.schema import Scenario
from nodesim.sensors.chain_imu import ChainImu


def gyro_rates_rad_s(scenario: Scenario, sig: NodeSignals) -> np.ndarray:
    """(R, K, 3) the tick-averaged gyro rates of every axis (module docstring)."""
    n = sig.samples.astype(float)
    return sig.gyro_counts / n[None, :, None] / ChainImu.from_scenario(scenario).gyro_lsb_per_rad_s


def _window_mean(x: np.ndarray, n: int) -> np.ndarray:
    """(R, 3) the mean over ticks 0 .. n - 1 of ``x`` (R, K, 3), added tick by tick (the static window's sum)."""
    acc = x[:, 0] * 0.0
    for k in range(n):
        acc = acc + x[:, k]
    return acc / n


def level_attitude(force_m_s2: np.ndarray, twist_rad) -> np.ndarray:
    """(R, 3) the Z-Y-X attitude (phi, theta, psi) whose gravity direction is ``force_m_s2`` (R, 3) and whose twist
    is ``twist_rad`` (module docstring)."""
    fx, fy, fz = force_m_s2[:, 0], force_m_s2[:, 1], force_m_s2[:, 2]
    phi = np.arctan2(fy, fz)
    theta = np.arctan2(-fx, np.hypot(fy, fz))
    c = np.arctan2(-np.sin(theta) * np.sin(phi), np.cos(theta) + np.cos(phi))  # six_state_float_kernel.twist_offset
    return np.stack([phi, theta, twist_rad - c], axis=1)


class SixStateLanes:
    """R lanes of the 6-state filter with the chain's filter interface (``predict``, ``update``, ``yaw_rad`` (the
    twist), ``yaw_variance_rad2`` (h P h^T, the twist's), ``bias_rad_s`` (the z bias), ``overflow_counts``) plus
    ``singular_ticks`` (R,), the ticks inside the singularity margin.  ``rates`` (R, K, 3) is its input."""

    def __init__(self, scenario: Scenario, sig: NodeSignals, k_start: int, yaw0_rad: float):
        self.config = six_state_config(scenario)
        self.params = ssk.kernel_params(self.config)
        self.rates = gyro_rates_rad_s(scenario, sig)
        R = self.rates.shape[0]
        bias0 = _window_mean(self.rates, k_start) if k_start else np.zeros((R, 3))
        force = _window_mean(sig.specific_force, max(k_start, 1))
        self.states = ssk.init_states(self.config, level_attitude(force, np.full(R, yaw0_rad)), bias0)
        self.singular_ticks = np.zeros(R, dtype=np.int64)
        self.realizations = R

    def __repr__(self) -> str:
        return (f"SixStateLanes(realizations={self.realizations}, discretisation={self.config.discretisation!r}, "
                f"singularity={self.config.singularity!r}, singular_ticks={int(self.singular_ticks.sum())})")

    def predict(self, rates_rad_s: np.ndarray, force_m_s2: np.ndarray | None = None) -> None:
        """Time update of every lane with the tick's rates (R, 3), then, given the tick's specific force (R, 3), the
        levelling update at a static tick (:func:`.six_state_float_kernel.level_update`; ``filter.levelling``)."""
        rates = np.ascontiguousarray(rates_rad_s)
        on = np.ones(self.realizations, dtype=np.bool_)
        ssk.predict_lanes(self.states, rates, self.params, self.singular_ticks, on)
        if force_m_s2 is not None:
            ssk.level_lanes(self.states, rates, np.ascontiguousarray(force_m_s2), self.params, on)

    def update(self, reference_yaw_rad, reference_variance_rad2, mask=None) -> None:
        """Twist update in the lanes of ``mask`` (all without one)."""
        R = self.realizations
        ref = np.broadcast_to(np.asarray(reference_yaw_rad, dtype=float), (R,)).copy()
        var = np.broadcast_to(np.asarray(reference_variance_rad2, dtype=float), (R,)).copy()
        on = np.ones(R, dtype=np.bool_) if mask is None else np.asarray(mask, dtype=np.bool_)
        ssk.update_lanes(self.states, ref, var, on)

    @property
    def yaw_rad(self) -> np.ndarray:
        out = np.empty(self.realizations)
        ssk.twist_lanes(self.states, out)
        return out

    @property
    def yaw_variance_rad2(self) -> np.ndarray:
        out = np.empty(self.realizations)
        ssk.twist_variance_lanes(self.states, out)
        return out

    @property
    def bias_rad_s(self) -> np.ndarray:
        return self.states[:, ssk.BIAS + 2].copy()

    @property
    def attitude_rad(self) -> np.ndarray:
        return self.states[:, ssk.ATT:ssk.ATT + 3].copy()

    @property
    def overflow_counts(self) -> dict[str, int]:
        return {}
