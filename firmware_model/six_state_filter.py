"""The thesis's full 6-state indirect (error-state) Kalman filter of a node, float implementation (issue 24).

State (thesis eq 3.23, digest 2.4):
    dx = [d_phi, d_theta, d_psi, b_x, b_y, b_z]
    d_Theta = Theta_INS - Theta_true (rad),  b = uncompensated gyro bias b_true - b_hat (rad/s)
Euler kinematics (eq 3.21, App. II eq II.16 inverted; rotation order Z(psi) -> Y(theta) -> X(phi), digest 2.3):
    Theta' = E(phi, theta) omega,   E = [[1, s_phi t_theta, c_phi t_theta],
                                         [0, c_phi,         -s_phi       ],
                                         [0, s_phi / c_theta, c_phi / c_theta]]
Gyro model (eqs 3.17-3.20):  omega_meas = omega_true + b + n_v,  b' = -b / tau + n_b,  Q_nb = 2 sigma_b^2 / tau
Error dynamics (eqs 3.22, 3.24-3.25), linearised about the strapdown solution with omega_hat = omega_meas - b_hat:
    dx' = F dx + G w,   w = [n_v; n_b]
    F = [[F11, E], [0, -diag(1/tau)]],   F11 = d(E omega_hat) / d Theta   (psi column zero: E has no psi)
        row phi:   [(w_y c_phi - w_z s_phi) t_theta,   (w_y s_phi + w_z c_phi) / c_theta^2,            0]
        row theta: [-w_y s_phi - w_z c_phi,             0,                                             0]
        row psi:   [(w_y c_phi - w_z s_phi) / c_theta,  (w_y s_phi + w_z c_phi) s_theta / c_theta^2,   0]
    G = [[G_C, 0], [0, G_D]]  with the tuning of eqs 4.14-4.15:  G_C = A E,  G_D = B I3 ("noise_gain") or
        sqrt(B) I3 ("process_noise"): the two readings of the lost eq 4.14 that the 2-state filter keeps
        (:class:`firmware_model.yaw_filter.YawFilterConfig`, ``b_tuning``)
    Q = diag(sigma_vx^2, sigma_vy^2, sigma_vz^2, 2 sigma_bx^2/tau_x, 2 sigma_by^2/tau_y, 2 sigma_bz^2/tau_z) (3.26)
Checked against first principles: the digest's F11 and E (digest 2.3-2.4, [R/D]) are the Jacobian of the inverted
II.16 (tests/firmware_model/test_six_state_filter.py differentiates it numerically and rebuilds E from the
rotation matrices C1, C2, C3).  The derivation: Theta_true' = E(Theta_true)(omega_hat - b - n_v), so
d_Theta' = E(Theta_INS) omega_hat - E(Theta_INS - d_Theta)(omega_hat - b - n_v) = F11 d_Theta + E b + E n_v to
first order; the sign of n_v is immaterial, hence G_C = +A E and F12 = +E (the digest's sign convention; the
opposite error sign gives -E, digest 2.4).  The bias row keeps the 2-state filter's -b/tau (the decay of b_hat
itself, -b_hat/tau, is left out, as there).
Discretisation over a tick dt = 1 / f_firmware, two forms (:attr:`SixStateFilterConfig.discretisation`):
  "euler" (digest 2.5 [A], the thesis says only "Euler"; the 2-state filter's form):
    strapdown  Theta_INS += dt E(Theta_INS) omega_hat;   Phi = I + F dt;   Q_d = G Q G^T dt
    with F, G at the prior attitude.  It is unstable under string rotation: spinning about z at rate w, the
    (phi, theta) block of F is the rotation [[0, w], [-w, 0]] and I + F dt has eigenvalues 1 +/- i w dt, modulus
    sqrt(1 + (w dt)^2) > 1: at the drilling 60 deg/s and 1.9 Hz (w dt = 0.55 rad) the roll/pitch errors, and
    the strapdown tilt itself, grow 14 % a tick (tests show it);
  "rotation" (the default; first principles, thesis eqs 3.1 and 3.5: x_k = f(x_k-1, u), F = df/dx of the
    discrete model): the tick's exact strapdown at a constant compensated rate, through the direction cosine
    matrix (App. II eq II.8, C' = C Omega):  C+ = C_b^n(Theta) Exp(rho),  rho = omega_hat dt,  Theta+ = the Z-Y-X
    angles of C+ (phi and psi continued from the prior's branch, theta in [-90, 90] deg; the yaw advances by the
    increment read in the prior's yaw-free frame, so a tick must turn less than 180 deg: 340 deg/s at 1.9 Hz);
    its Jacobians
        Phi_11 = E(Theta+) Exp(-rho) E(Theta)^-1        (a nav-frame attitude error is kept by the tick)
        Phi_12 = dt E(Theta+) J_r(rho)                  (J_r the right Jacobian of Exp)
        Phi_22 = diag(1 - dt/tau)                       (as the 2-state filter)
        Q_d    = blkdiag(G_C' diag(sigma_v^2) G_C'^T, G_D^2 diag(2 sigma_b^2/tau)) dt,  G_C' = A E(Theta+) Exp(-rho/2)
    (the rate noise's rotation over the tick taken at mid-tick; exact when the three sigma_v are equal).  To
    first order in dt these are I + F dt, G dt of eqs 3.24-3.25 (tests check the O(dt^2) agreement and the
    numeric Jacobian of the tick map); the rotation block stays a rotation, so nothing grows that should not.
  Either way P = Phi P Phi^T + Q_d (eqs 3.8, 4.12), symmetrised; at theta = phi = 0 with rates about z only both
  reduce exactly to the 2-state filter's (psi, b_z) model.
Measurement (eqs 3.27-3.31, digest 2.6):  z = wrap(Theta_INS - Theta_ref) into (-pi, pi] on the measured axes;
    yaw only by default (encoder, or the forwarded yaw: tubes differ in roll and pitch), H = e3^T (1 x 6) and R =
    the reference variance (as the 2-state filter forms it: encoder quantisation, or P_psi_psi of the previous
    node plus its delay terms); optionally roll and pitch too (forwarded, or accelerometer-derived at a survey
    stop), H = [I3 0] (3 x 6), R = diag(var_phi, var_theta, var_psi).
Update (eqs 3.11-3.14):  K = P H^T (H P H^T + R)^-1;  dx = K z;  P = (I - K H) P (I - K H)^T + K R K^T (Joseph
    form, equal to eq 3.14's P - K H P for this K and kept symmetric positive semi-definite in float), symmetrised.
Closed-loop reset (digest 2.7):  Theta_INS -= dx[:3];  b_hat += dx[3:];  dx = 0;  P kept.

The pitch singularity (theta = +/-90 deg, horizontal drilling): E carries 1/cos(theta) (the direction cosine
matrix itself has no singularity; only the Euler angles lose psi - phi apart at gimbal lock).  A tick whose
Euler-rate terms would be evaluated at |cos(theta)| < sin(margin) (|theta| within ``singularity_margin_rad`` of
+/-90 deg: the posterior pitch for "rotation", the prior for "euler") counts in
:attr:`SixStateFilter.singular_ticks` and :attr:`SixStateFilterConfig.singularity` decides what it uses:
    "hold":     E (and F11) at the margin: cos(theta) -> sign(cos theta) sin(margin), sin(theta) ->
                sign(sin theta) cos(margin), so every Euler-rate term stays bounded by 1/sin(margin);
    "decouple": Phi_11 = I, Phi_12 = dt I, G_C = A I for the tick (the near-vertical form of digest 2.4: the
                (psi, b_z) block propagates exactly as the 2-state filter's, roll and pitch likewise per axis).
Neither is exact there; both keep every number finite and the count says how often a run relied on it.  The
"rotation" strapdown keeps the attitude itself exact through the singularity; the "euler" one uses the same E as
its Phi (held, or I3 with "decouple").
Outside the margin the filter is the thesis's.

Levelling (``levelling``, issue 24 item 2; used by the chain lanes, nodesim.chain.compiled.six_state_float_kernel):
at a tick where the node is static, its accelerometer's roll and pitch are measurements of the filter's roll and
pitch, the thesis's attitude measurement of eqs 3.27-3.31 (H = [I3 0] on the roll and pitch rows) with the roll
and pitch taken from gravity the way the thesis resolves the accelerometers at every survey station (sec 3.5,
eqs 1.1-1.3, 4.3) instead of from the node above (tubes differ in roll and pitch).  Static: the rate compensated by the
start bias (the static window's) |omega_meas - b_0| < ``levelling_rate_rad_s``.  With f the tick's mean specific force (sensor frame, nav z up):
    phi_m = atan2(f_y, f_z),   theta_m = atan2(-f_x, sqrt(f_y^2 + f_z^2))
    R_phi = sigma_f^2 / (f_y^2 + f_z^2),   R_theta = sigma_f^2 / |f|^2   (first-order propagation of independent
    per-axis noise sigma_f = ``levelling_force_sigma_m_s2``; the two errors are uncorrelated)
applied as two scalar updates (rows e1, e2; equal to the joint update with diagonal R).  The roll is skipped where
sqrt(f_y^2 + f_z^2) < |f| sin(singularity margin) (near horizontal it is undefined).  Without it, yaw-only
references leave roll, pitch and the x, y biases unobservable in a static string, and the EKF, linearised at its
own drifting estimate, lets them run away (docs/deviated_wells.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from firmware_model.errors import FirmwareError
from firmware_model.yaw_filter import B_TUNINGS, YawFilterConfig, batch_arg, check_finite, check_realizations

SINGULARITY_MODES = ("hold", "decouple")
DISCRETISATIONS = ("rotation", "euler")
N_STATES = 6
YAW = 2
ATTITUDE = (0, 1, 2)
_SMALL_ANGLE = 1e-4  # |rho| below which Exp and J_r use their Taylor series (error < 1e-17)


def _axes(name: str, value) -> tuple[float, float, float]:
    """A per-axis (x, y, z) parameter from a scalar or a 3-sequence."""
    v = np.asarray(value, dtype=float)
    if v.ndim > 1 or v.size not in (1, 3):
        raise FirmwareError(f"SixStateFilterConfig.{name} = {value!r}: allowed a number or 3 numbers (x, y, z)")
    return tuple(float(x) for x in np.broadcast_to(v.reshape(-1), (3,)))


def wrap_pi_closed(x):
    """Angle wrapped into (-pi, pi] (digest 2.6: innovations into (-180, 180] deg).  The 2-state filter's
    :func:`firmware_model.yaw_filter.wrap_pi` maps into [-pi, pi); the two differ only at exactly +/-pi."""
    return math.pi - np.remainder(math.pi - np.asarray(x, dtype=float), 2.0 * math.pi)


@dataclass(frozen=True)
class SixStateFilterConfig:
    """Tuning of the 6-state filter; SI units (rad, s).  Per-axis parameters take a number (all three gyro axes)
    or (x, y, z).  Defaults as the 2-state filter (thesis digest 4.1/2.4: tau = 500 s, A = 1, B = 5); the gyro
    Allan values come from thesis table V.1.  :meth:`from_yaw_config` builds it from a 2-state configuration.
    ``discretisation`` and ``singularity``: see the module docstring."""

    dt_s: float
    arw_rad_per_sqrt_s: tuple[float, float, float]
    bias_instability_rad_s: tuple[float, float, float]
    bias_tau_s: tuple[float, float, float] = (500.0, 500.0, 500.0)
    tuning_a: float = 1.0
    tuning_b: float = 5.0
    b_tuning: str = "process_noise"
    initial_angle_sigma_rad: tuple[float, float, float] = (math.radians(1.0),) * 3
    initial_bias_sigma_rad_s: tuple[float, float, float] = (math.radians(0.05),) * 3
    singularity_margin_rad: float = math.radians(5.0)
    singularity: str = "hold"
    discretisation: str = "rotation"
    levelling: bool = False
    levelling_rate_rad_s: float = math.radians(0.5)
    levelling_force_sigma_m_s2: float = 0.0

    def __post_init__(self) -> None:
        for name in ("arw_rad_per_sqrt_s", "bias_instability_rad_s", "bias_tau_s", "initial_angle_sigma_rad",
                     "initial_bias_sigma_rad_s"):
            object.__setattr__(self, name, _axes(name, getattr(self, name)))
        for name, allowed in (("b_tuning", B_TUNINGS), ("singularity", SINGULARITY_MODES),
                              ("discretisation", DISCRETISATIONS)):
            if getattr(self, name) not in allowed:
                raise FirmwareError(f"SixStateFilterConfig.{name} = {getattr(self, name)!r}: allowed {' | '.join(allowed)}")
        for name in ("dt_s", "tuning_a", "tuning_b"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise FirmwareError(f"SixStateFilterConfig.{name} = {v}: allowed finite values > 0")
        for name in ("bias_tau_s", "arw_rad_per_sqrt_s", "bias_instability_rad_s", "initial_angle_sigma_rad",
                     "initial_bias_sigma_rad_s"):
            positive = name == "bias_tau_s"
            for axis, v in zip("xyz", getattr(self, name)):
                if not (math.isfinite(v) and (v > 0 if positive else v >= 0)):
                    raise FirmwareError(f"SixStateFilterConfig.{name} ({axis}) = {v}: allowed finite values "
                                        f"{'> 0' if positive else '>= 0'}")
        for axis, tau in zip("xyz", self.bias_tau_s):
            if self.dt_s >= tau:
                raise FirmwareError(f"SixStateFilterConfig.dt_s = {self.dt_s}: must be < bias_tau_s ({axis}) = {tau}")
        for name in ("levelling_rate_rad_s", "levelling_force_sigma_m_s2"):
            v = getattr(self, name)
            if self.levelling and not (math.isfinite(v) and v > 0):
                raise FirmwareError(f"SixStateFilterConfig.{name} = {v} with levelling: allowed finite values > 0")
        m = self.singularity_margin_rad
        if not (math.isfinite(m) and 0.0 < m < math.pi / 2):
            raise FirmwareError(f"SixStateFilterConfig.singularity_margin_rad = {m}: allowed 0 < margin < pi/2")
        with np.errstate(over="ignore"):
            q = np.concatenate([self.q_continuous * self.dt_s, self.q_continuous[3:] * self.bias_gain**2 * self.dt_s])
        if not np.all(np.isfinite(q)):
            raise FirmwareError("SixStateFilterConfig: the process noise Q_d = G Q G^T dt overflows (arw_rad_per_sqrt_s, "
                                "bias_instability_rad_s, bias_tau_s, tuning_b)")

    @classmethod
    def from_yaw_config(cls, cfg: YawFilterConfig, **six_state) -> "SixStateFilterConfig":
        """The 6-state tuning with the 2-state filter's numbers on all three axes (its z-gyro Allan values, tau,
        A, B, b_tuning, initial sigmas); ``six_state`` overrides any field (per-axis values, singularity)."""
        base = dict(dt_s=cfg.dt_s, arw_rad_per_sqrt_s=cfg.arw_rad_per_sqrt_s,
                    bias_instability_rad_s=cfg.bias_instability_rad_s, bias_tau_s=cfg.bias_tau_s,
                    tuning_a=cfg.tuning_a, tuning_b=cfg.tuning_b, b_tuning=cfg.b_tuning,
                    initial_angle_sigma_rad=cfg.initial_yaw_sigma_rad, initial_bias_sigma_rad_s=cfg.initial_bias_sigma_rad_s)
        base.update(six_state)
        return cls(**base)

    @property
    def q_continuous(self) -> np.ndarray:
        """diag(Q) of eq 3.26: sigma_v^2 per axis, then 2 sigma_b^2 / tau per axis (>= 0 by the checks above)."""
        arw = np.array(self.arw_rad_per_sqrt_s)
        sb, tau = np.array(self.bias_instability_rad_s), np.array(self.bias_tau_s)
        return np.concatenate([arw**2, 2.0 * sb**2 / tau])

    @property
    def bias_gain(self) -> float:
        """G_D / I3 of eqs 4.14-4.15: B ("noise_gain") or sqrt(B) ("process_noise")."""
        return self.tuning_b if self.b_tuning == "noise_gain" else math.sqrt(self.tuning_b)

    @property
    def p0(self) -> np.ndarray:
        return np.diag(np.concatenate([np.array(self.initial_angle_sigma_rad) ** 2,
                                       np.array(self.initial_bias_sigma_rad_s) ** 2]))


# --- attitude kinematics (thesis eq 3.21, App. II; digest 2.3) ---------------------------------------------------

def pitch_trig(theta, margin_rad: float, hold: bool = True):
    """(sin, cos) of the pitch the Euler-rate terms use, and the singular mask |cos theta| < sin(margin): the true
    ones outside the margin; inside it with ``hold``, theta moved to the margin on its own side (signs kept)."""
    s, c = np.sin(theta), np.cos(theta)
    near = np.abs(c) < math.sin(margin_rad)
    if hold and np.any(near):
        c = np.where(near, np.where(c < 0.0, -1.0, 1.0) * math.sin(margin_rad), c)
        s = np.where(near, np.where(s < 0.0, -1.0, 1.0) * math.cos(margin_rad), s)
    return s, c, near


def euler_rate_matrix(phi, s_theta, c_theta) -> np.ndarray:
    """E(phi, theta) (..., 3, 3) of eq 3.21: Theta' = E omega (digest 2.3), from sin/cos of the pitch."""
    sp, cp = np.sin(phi), np.cos(phi)
    t = s_theta / c_theta
    zero, one = np.zeros_like(sp), np.ones_like(sp)
    return np.stack([np.stack([one, sp * t, cp * t], -1),
                     np.stack([zero, cp, -sp], -1),
                     np.stack([zero, sp / c_theta, cp / c_theta], -1)], -2)


def inverse_euler_rate_matrix(phi, theta) -> np.ndarray:
    """E^-1 (..., 3, 3), eq II.16 itself: omega = [phi', 0, 0] + C3 [0, theta', 0] + C3 C2 [0, 0, psi'] (no
    singularity)."""
    sp, cp, st, ct = np.sin(phi), np.cos(phi), np.sin(theta), np.cos(theta)
    zero, one = np.zeros_like(sp), np.ones_like(sp)
    return np.stack([np.stack([one, zero, -st], -1),
                     np.stack([zero, cp, sp * ct], -1),
                     np.stack([zero, -sp, cp * ct], -1)], -2)


def attitude_jacobian(phi, s_theta, c_theta, omega) -> np.ndarray:
    """F11 = d(E(phi, theta) omega) / d(phi, theta, psi) (..., 3, 3) (eq 3.24, digest 2.4; psi column zero)."""
    sp, cp = np.sin(phi), np.cos(phi)
    wy, wz = omega[..., 1], omega[..., 2]
    a = wy * cp - wz * sp  # d(w_y s_phi + w_z c_phi) / d phi
    b = wy * sp + wz * cp
    t, c2 = s_theta / c_theta, c_theta * c_theta
    zero = np.zeros_like(a)
    return np.stack([np.stack([a * t, b / c2, zero], -1),
                     np.stack([-b, zero, zero], -1),
                     np.stack([a / c_theta, b * s_theta / c2, zero], -1)], -2)


def body_to_nav(attitude) -> np.ndarray:
    """C_b^n (..., 3, 3) = (C3(phi) C2(theta) C1(psi))^T (digest 2.3, the Z-Y-X sequence)."""
    a = np.asarray(attitude, dtype=float)
    sp, cp = np.sin(a[..., 0]), np.cos(a[..., 0])
    st, ct = np.sin(a[..., 1]), np.cos(a[..., 1])
    ss, cs = np.sin(a[..., 2]), np.cos(a[..., 2])
    c_nb = np.stack([np.stack([ct * cs, ct * ss, -st], -1),
                     np.stack([sp * st * cs - cp * ss, sp * st * ss + cp * cs, sp * ct], -1),
                     np.stack([cp * st * cs + sp * ss, cp * st * ss - sp * cs, cp * ct], -1)], -2)
    return np.swapaxes(c_nb, -1, -2)


def euler_angles(c_bn) -> np.ndarray:
    """(phi, theta, psi) (..., 3) of C_b^n: theta = -asin(C_n^b[0, 2]) in [-pi/2, pi/2], phi and psi by atan2
    (finite at gimbal lock, where only their sum or difference is defined)."""
    c_nb = np.swapaxes(c_bn, -1, -2)
    theta = -np.arcsin(np.clip(c_nb[..., 0, 2], -1.0, 1.0))
    phi = np.arctan2(c_nb[..., 1, 2], c_nb[..., 2, 2])
    psi = np.arctan2(c_nb[..., 0, 1], c_nb[..., 0, 0])
    return np.stack([phi, theta, psi], -1)


def _skew(v) -> np.ndarray:
    x, y, z = v[..., 0], v[..., 1], v[..., 2]
    zero = np.zeros_like(x)
    return np.stack([np.stack([zero, -z, y], -1), np.stack([z, zero, -x], -1), np.stack([-y, x, zero], -1)], -2)


def _so3_coefficients(rho):
    """sin(a)/a, (1 - cos a)/a^2, (a - sin a)/a^3 of a = |rho| (Taylor series below 1e-4 rad)."""
    a = np.linalg.norm(rho, axis=-1)
    small = a < _SMALL_ANGLE
    a_safe = np.where(small, 1.0, a)
    a2 = a * a
    c1 = np.where(small, 1.0 - a2 / 6.0, np.sin(a_safe) / a_safe)
    c2 = np.where(small, 0.5 - a2 / 24.0, (1.0 - np.cos(a_safe)) / a_safe**2)
    c3 = np.where(small, 1.0 / 6.0 - a2 / 120.0, (a_safe - np.sin(a_safe)) / a_safe**3)
    return c1, c2, c3


def so3_exp(rho) -> np.ndarray:
    """Exp(rho) = I + sin(a)/a [rho x] + (1 - cos a)/a^2 [rho x]^2 (Rodrigues): the body rotation of one tick."""
    k = _skew(rho)
    c1, c2, _ = _so3_coefficients(rho)
    return np.eye(3) + c1[..., None, None] * k + c2[..., None, None] * (k @ k)


def so3_right_jacobian(rho) -> np.ndarray:
    """J_r(rho) = I - (1 - cos a)/a^2 [rho x] + (a - sin a)/a^3 [rho x]^2: Exp(rho + d) = Exp(rho) Exp(J_r d)."""
    k = _skew(rho)
    _, c2, c3 = _so3_coefficients(rho)
    return np.eye(3) - c2[..., None, None] * k + c3[..., None, None] * (k @ k)


# --- the tick's model ---------------------------------------------------------------------------------------------

def continuous_model(config: SixStateFilterConfig, attitude, omega_hat, hold: bool = True):
    """(F, G, singular mask) of eqs 3.24-3.25 with the tuning of eqs 4.14-4.15, (R, 6, 6) each, at ``attitude``
    (R, 3) and the compensated rate ``omega_hat`` (R, 3) (the pitch held at the margin with ``hold``)."""
    attitude, omega_hat = np.asarray(attitude, float), np.asarray(omega_hat, float)
    R = attitude.shape[0]
    s, c, near = pitch_trig(attitude[:, 1], config.singularity_margin_rad, hold)
    e = euler_rate_matrix(attitude[:, 0], s, c)
    f = np.zeros((R, 6, 6))
    f[:, :3, :3] = attitude_jacobian(attitude[:, 0], s, c, omega_hat)
    f[:, :3, 3:] = e
    f[:, 3:, 3:] = np.diag(-1.0 / np.array(config.bias_tau_s))
    g = np.zeros((R, 6, 6))
    g[:, :3, :3] = config.tuning_a * e
    g[:, 3:, 3:] = config.bias_gain * np.eye(3)
    return f, g, near


def discrete_model(config: SixStateFilterConfig, attitude, omega_hat):
    """(Phi, Q_d, posterior attitude, singular mask) of one tick from ``attitude`` (R, 3) at the compensated rate
    ``omega_hat`` (R, 3), per :attr:`SixStateFilterConfig.discretisation` (module docstring)."""
    attitude, omega_hat = np.asarray(attitude, float), np.asarray(omega_hat, float)
    R, dt, margin = attitude.shape[0], config.dt_s, config.singularity_margin_rad
    hold, decouple = config.singularity == "hold", config.singularity == "decouple"
    q = config.q_continuous
    phi = np.zeros((R, 6, 6))
    phi[:, 3:, 3:] = np.diag(1.0 - dt / np.array(config.bias_tau_s))
    if config.discretisation == "euler":
        f, g, near = continuous_model(config, attitude, omega_hat, hold)
        e = np.where(near[:, None, None], np.eye(3), f[:, :3, 3:]) if decouple else f[:, :3, 3:]
        posterior = attitude + dt * np.einsum("rij,rj->ri", e, omega_hat)
        phi[:, :3, :] = np.eye(3, 6) + f[:, :3, :] * dt
        gc = g[:, :3, :3]
    else:
        rho = omega_hat * dt
        exp_rho = so3_exp(rho)
        # C_b^n(phi, theta, psi) = Rz(psi) C_b^n(phi, theta, 0): the tick in the prior's yaw-free frame gives the yaw
        # increment itself (psi+ = psi + d_psi, one rounding, as the 2-state filter's psi + dt omega)
        angles = euler_angles(body_to_nav(np.c_[attitude[:, :2], np.zeros(R)]) @ exp_rho)
        posterior = np.stack([attitude[:, 0] + wrap_pi_closed(angles[:, 0] - attitude[:, 0]), angles[:, 1],
                              attitude[:, 2] + angles[:, 2]], -1)
        s, c, near = pitch_trig(posterior[:, 1], margin, hold)
        e_post = euler_rate_matrix(posterior[:, 0], s, c)
        phi[:, :3, :3] = e_post @ np.swapaxes(exp_rho, -1, -2) @ inverse_euler_rate_matrix(attitude[:, 0], attitude[:, 1])
        phi[:, :3, 3:] = dt * e_post @ so3_right_jacobian(rho)
        gc = config.tuning_a * e_post @ so3_exp(-0.5 * rho)
    if decouple and np.any(near):
        phi[:, :3, :] = np.where(near[:, None, None], np.eye(3, 6) + dt * np.eye(3, 6, 3), phi[:, :3, :])
        gc = np.where(near[:, None, None], config.tuning_a * np.eye(3), gc)
    q_d = np.zeros((R, 6, 6))
    q_d[:, :3, :3] = (gc * q[:3]) @ np.swapaxes(gc, -1, -2) * dt  # A^2 E diag(sigma_v^2) E^T dt (rotated)
    q_d[:, 3:, 3:] = np.diag(config.bias_gain**2 * q[3:] * dt)
    return phi, q_d, posterior, near


def _sym(p: np.ndarray) -> np.ndarray:
    return 0.5 * (p + np.swapaxes(p, -1, -2))


class SixStateFilter:
    """R independent 6-state filters in float64 (filterpy style: ``predict`` then ``update``).

    ``predict(rates)`` takes the tick-averaged gyro rates (R, 3) (x, y, z); ``update`` takes a reference yaw
    (R,) with its variance, and optionally roll/pitch references (R, 2) with their variances.  The matrices of
    the last tick are kept (:attr:`last_phi`, :attr:`last_q_d`, :attr:`last_h`, :attr:`last_r`) and the last
    correction (:attr:`last_correction`, dx (R, 6)), so a caller can reproduce a step with any linear Kalman
    filter (the tests do, with filterpy's ``KalmanFilter``)."""

    def __init__(self, config: SixStateFilterConfig, realizations: int, initial_attitude_rad=0.0,
                 bias_offset_rad_s=0.0):
        self.config = config
        self.realizations = R = check_realizations(realizations)
        self._att = self._vec3("initial_attitude_rad", initial_attitude_rad)
        if np.any(np.abs(self._att[:, 1]) > math.pi / 2):
            raise FirmwareError("initial_attitude_rad: pitch outside [-pi/2, pi/2]; allowed the Z-Y-X angles with "
                                "|theta| <= pi/2 (the same attitude as (phi + pi, pi - theta, psi + pi))")
        self._bias = self._vec3("bias_offset_rad_s", bias_offset_rad_s)
        self._p = np.broadcast_to(config.p0, (R, 6, 6)).copy()
        self.singular_ticks = np.zeros(R, dtype=np.int64)
        self.last_phi = self.last_q_d = self.last_h = self.last_r = self.last_correction = None

    def _vec3(self, name: str, x) -> np.ndarray:
        x = check_finite(name, x)
        try:
            return np.broadcast_to(x, (self.realizations, 3)).copy()
        except ValueError:
            raise FirmwareError(f"{name}: shape {x.shape} does not fit {self.realizations} realizations x 3 axes "
                                f"(allowed: (), (3,) or ({self.realizations}, 3))") from None

    @property
    def attitude_rad(self) -> np.ndarray:
        """(roll, pitch, yaw) estimates (R, 3); roll and yaw continuous (not wrapped), like the 2-state yaw."""
        return self._att

    @property
    def yaw_rad(self) -> np.ndarray:
        """Yaw estimate (R,), what a node transmits."""
        return self._att[:, YAW]

    @property
    def bias_rad_s(self) -> np.ndarray:
        """Total gyro bias estimates (R, 3): initial static bias plus the filter's corrections."""
        return self._bias

    @property
    def covariance(self) -> np.ndarray:
        """Error covariance P (R, 6, 6) in rad and rad/s, order (phi, theta, psi, b_x, b_y, b_z)."""
        return self._p

    @property
    def yaw_variance_rad2(self) -> np.ndarray:
        return self._p[:, YAW, YAW]

    @property
    def near_singular(self) -> np.ndarray:
        """(R,) True where the current pitch is within the margin of +/-90 deg."""
        return np.abs(np.cos(self._att[:, 1])) < math.sin(self.config.singularity_margin_rad)

    @property
    def overflow_counts(self) -> dict[str, int]:
        """Saturation/overflow events per site (always empty for the float filter)."""
        return {}

    def predict(self, measured_rates_rad_s) -> None:
        """Time update over one tick with the tick-averaged gyro rates (R, 3) or (3,)."""
        rates = self._vec3("gyro rates", measured_rates_rad_s)
        phi, q_d, posterior, near = discrete_model(self.config, self._att, rates - self._bias)
        self.singular_ticks += near
        self._att = posterior
        self._p = _sym(phi @ self._p @ np.swapaxes(phi, -1, -2) + q_d)
        self.last_phi, self.last_q_d = phi, q_d

    def update(self, reference_yaw_rad, reference_variance_rad2, mask=None, reference_roll_pitch_rad=None,
               roll_pitch_variance_rad2=None) -> None:
        """Measurement update (eqs 3.11-3.14, 3.31): the yaw reference alone (H = e3^T), or with roll/pitch
        references (R, 2) and their variances (R, 2) too (H = [I3 0]); ``mask`` (R,) selects the realizations
        that got a reference."""
        R = self.realizations
        ref = [batch_arg("reference yaw", check_finite("reference yaw", reference_yaw_rad), R)]
        var = [batch_arg("reference variance", check_finite("reference variance", reference_variance_rad2), R)]
        axes: tuple[int, ...] = (YAW,)
        if (reference_roll_pitch_rad is None) != (roll_pitch_variance_rad2 is None):
            raise FirmwareError("reference_roll_pitch_rad and roll_pitch_variance_rad2: give both or neither")
        if reference_roll_pitch_rad is not None:
            rp = self._pair("reference roll/pitch", reference_roll_pitch_rad)
            rpv = self._pair("roll/pitch variance", roll_pitch_variance_rad2)
            ref, var, axes = [rp[:, 0], rp[:, 1], ref[0]], [rpv[:, 0], rpv[:, 1], var[0]], ATTITUDE
        ref, var = np.stack(ref, -1), np.stack(var, -1)
        if np.any(var < 0):
            raise FirmwareError("reference variance: negative value; allowed >= 0 (rad^2)")
        m = len(axes)
        h = np.zeros((m, 6))
        h[np.arange(m), axes] = 1.0
        z = wrap_pi_closed(self._att[:, axes] - ref)  # (R, m): z = Theta_INS - Theta_ref = H dx + v
        p = self._p
        ph_t = p[:, :, axes]  # P H^T (R, 6, m)
        s = p[:, axes][:, :, axes] + var[:, :, None] * np.eye(m)  # H P H^T + R
        on = self._mask(mask)
        k = ph_t * (1.0 / s) if m == 1 else ph_t @ np.linalg.inv(s)  # one division for yaw only, as the 2-state
        k = np.where(on[:, None, None], k, 0.0)  # K = 0 where no reference arrived
        dx = np.einsum("rim,rm->ri", k, z)
        self._att = self._att - dx[:, :3]
        self._bias = self._bias + dx[:, 3:]
        i_kh = np.eye(6) - k @ h
        self._p = _sym(i_kh @ p @ np.swapaxes(i_kh, -1, -2) + (k * var[:, None, :]) @ np.swapaxes(k, -1, -2))
        self.last_h, self.last_r, self.last_correction = h, np.where(on[:, None], var, np.nan), dx

    def _pair(self, name: str, x) -> np.ndarray:
        x = check_finite(name, x)
        try:
            return np.broadcast_to(x, (self.realizations, 2))
        except ValueError:
            raise FirmwareError(f"{name}: shape {x.shape} does not fit {self.realizations} realizations x "
                                f"(roll, pitch) (allowed: (), (2,) or ({self.realizations}, 2))") from None

    def _mask(self, mask) -> np.ndarray:
        if mask is None:
            return np.ones(self.realizations, dtype=bool)
        return batch_arg("update mask", mask, self.realizations, dtype=bool)
