"""The thesis's 6-state error-state filter (:mod:`firmware_model.six_state_filter`) in the MCU's fixed point (issue 24).

The same model as the float filter's default configuration: state dx = [d_phi, d_theta, d_psi, b_x, b_y, b_z]
(thesis eq 3.23), Euler kinematics E(phi, theta) (eq 3.21, App. II eq II.16), the tuning of eqs 3.26 and
4.14-4.15, the "rotation" discretisation, the measurement of eqs 3.27-3.31 (yaw only, H = e3^T, or roll, pitch and
yaw, H = [I3 0]) and the closed-loop reset (thesis digest 2.7 [A]).  Only the **"rotation"** discretisation is
implemented: "euler" (Phi = I + F dt) is unstable under string rotation (|eig| = sqrt(1 + (w dt)^2), 14 % growth a
tick at the drilling 60 deg/s; :mod:`firmware_model.six_state_filter`), and on an MCU an unstable roll/pitch
covariance overflows its fixed-point format within tens of ticks; so a build would gain nothing from the cheaper
form.  :class:`SixStateFixedConfig` rejects ``discretisation = "euler"`` naming the key.

Words (:class:`SixStateFixedFormats`, every one named; 32-bit, round half even, saturation counted per site):
    roll, pitch, yaw     32-bit binary angles (2^32 = one turn, wrap by design), also innovations and dx angles
    rates, biases        Q16.16 deg/s (the 2-state filter's rate and bias formats)
    rho = (w - b) dt     rad, ``rho``;  s = |rho|^2 rad^2, ``rho2``
    trig, DCM, Exp, J_r  Q2.30 ``unit`` (the CORDIC's output format)
    E, Phi11, Phi12, G_C ``transition`` (|entries| <= 1/sin(margin); Phi12 in s)
    P                    three block formats: angle-angle ``p_aa`` deg^2, angle-bias ``p_ab`` deg^2/s, bias-bias
                         ``p_bb`` (deg/s)^2 (the 2-state filter's P_yy, P_yb, P_bb formats), P_ii >= 1 LSB
Build-time constants (dt, dt pi/180, 1 - dt/tau_i, A sigma_v,i sqrt(dt), Q_bb,i, the series coefficients) are
scaled to the most precise 32-bit format (:func:`firmware_model.fixed_filter.const`), Q_bb,i into ``p_bb``.

Predict (firmware_model.six_state_kernel.predict_raw; C nf6_predict), per tick dt:
    rho = (omega_meas - b_hat) dt;  s = rho . rho
    c1 = sin a / a, c2 = (1 - cos a) / a^2, c3 = (a - sin a) / a^3 (a = |rho|) as 13-term Taylor series in
        u = s / 16 (exact: the raw of s read with 4 more fraction bits), coefficients b_k = (-1)^k 16^k / (2k+1+j)!
        (the truncation is below 4e-13 for |rho| <= 4 rad, 229 deg a tick); c1, c2 at s / 4 for Exp(-rho/2)
    Exp(rho) = I + c1 [rho x] + c2 [rho x]^2,  J_r = I - c2 [rho x] + c3 [rho x]^2 ([rho x]^2 = rho rho^T - s I),
        Exp(-rho/2) = I - c1' [rho x] / 2 + c2' [rho x]^2 / 4                     (Rodrigues; J_r: the right Jacobian)
    strapdown (App. II eq II.8): C+ = C_b^n(phi, theta, 0) Exp(rho), the trig of phi, theta by CORDIC rotation
        (:func:`firmware_model.cordic.sin_cos`); the Z-Y-X angles of C+ by CORDIC vectoring:
        d_psi = atan2(C+_10, C+_00), phi+ = atan2(C+_21, C+_22), theta+ = atan2(-C+_20, |(C+_21, C+_22)|);
        psi+ = psi + d_psi (binary angle: wraps)
    Phi11 = E(Theta+) Exp(rho)^T E(Theta)^-1,  Phi12 = (E(Theta+) J_r) dt,  Phi22 = diag(1 - dt/tau)
    Q_d = blkdiag(Gs Gs^T, diag(Q_bb)),  Gs = E(Theta+) Exp(-rho/2) diag(A sigma_v sqrt(dt))   (eqs 3.26, 4.14-4.15)
    P = Phi P Phi^T + Q_d (eqs 3.8, 4.12): T = Phi P, then the upper triangle of T Phi^T + Q_d, mirrored
    singular pitch (|cos theta+| < sin(margin)): counted; "hold" moves cos/sin theta+ to the margin, "decouple"
        takes Phi11 = I, Phi12 = dt I, G_C = A I (as the float filter); one division 1 / cos theta+ a tick
Update (six_state_kernel.update_raw; C nf6_update), eqs 3.11-3.14, as sequential scalar updates (R is diagonal, so
    equal to the float filter's batch update in exact arithmetic; one division per scalar update, digest 2.7):
    z_a = wrap(Theta_INS,a - Theta_ref,a) (the binary angle's int32 difference: wrapped for free), for a = yaw only
    or roll, pitch, yaw:  r = wrap(z_a - dx_a);  S = P_aa + R_a;  K = P e_a / S;  dx += K r;  P -= K (P e_a)^T
    then the closed-loop reset (digest 2.7): Theta_INS -= dx[:3] (wrapping), b_hat += dx[3:], dx = 0, P kept.
Levelling (six_state_kernel.level_raw; C nf6_level; ``filter.levelling = "static"``, the float filter's "Levelling"
    in :mod:`firmware_model.six_state_filter`), after the predict of a tick with the tick's rate words w and
    accelerometer count sums f over n samples:
    static:  sum_i clamp(w_i - b_0,i, +/-2^30)^2 < w_thr^2, exact int64 arithmetic on the rate raws (b_0 the start
             bias, held in the lane; w_thr = ``levelling_rate_rad_s`` in the rate format; the clamp is above any
             allowed threshold, so the test is exact and no square overflows)
    tilt:    phi_m = atan2(f_y, f_z), theta_m = atan2(-f_x, |(f_y, f_z)|) by two CORDIC vectorings (tilt_raw, the
             node's levelled start uses the same; thesis eqs 1.1-1.3 as the survey resolves its inclination)
    R:       sigma_F = c_sigma n (c_sigma = sigma_f S_a 180/pi, deg counts: the noise of one count sum's mean,
             S_a = ``accel_counts_per_m_s2``), R_theta = (sigma_F / |f|)^2, R_phi = (sigma_F / |(f_y, f_z)|)^2:
             the quotient rounded into ``formats.level_sigma`` (deg, site "level sigma"), squared into p_aa
             (site "level R"); the float's sigma_f^2 / |f|^2 and sigma_f^2 / (f_y^2 + f_z^2)
    update:  update_raw with ROLL_PITCH (H = the roll and pitch rows of [I3 0], eqs 3.27-3.31), or PITCH_ONLY where
             cos(theta_m) < sin(margin) (near horizontal the roll is undefined; cordic.sin_cos, the predict's test).
The float crosses in only at the boundaries (six_state_kernel.predict / update): gyro rates (rad/s -> Q16.16 deg/s),
references (rad -> binary angle, wrapped) and their variances (rad^2 -> p_aa).

The configuration checks (:meth:`SixStateFixedConfig.check`), each a FirmwareError naming the key:
    - ``discretisation`` other than "rotation"; the CORDIC formats (``formats.angle`` = Q0.32 turns,
      ``formats.unit`` = Q2.30); non-32-bit words;
    - Q >= 0: the float configuration's own checks (sigma >= 0, tau > 0, A, B > 0), each quantised Q_d term >= 0;
    - ``formats.transition`` must hold 2 / sin(margin) (E and Phi11 reach 1/sin(margin) at the held pitch; one bit of
      headroom), ``formats.noise_sqrt`` 2 A max(sigma_v) sqrt(dt) / sin(margin);
    - with levelling: ``accel_counts_per_m_s2`` finite > 0, ``levelling_rate_rad_s`` 1 .. 2^30 LSB of
      ``formats.rate``, and ``levelling_force_sigma_m_s2`` such that the division sigma_F / |f| into
      ``formats.level_sigma`` shifts by -LEVEL_MAX_SHIFT .. 0 (|f| << 20 stays in int64 for count sums < 2^42);
    - covariance formats too narrow for the 6 x 6 covariance: with P1 = the covariance after one tick at rest from
      P0 (Phi11 = I, Phi12 = dt I: P1_aa = P0_aa + dt^2 P0_bb + Q_aa, P1_bb = f^2 P0_bb + Q_bb), every diagonal of
      P0 and P1 must be <= half its block format's maximum, the Cauchy-Schwarz bound sqrt(P1_ii P1_jj) of every
      angle-bias entry <= half the ``p_ab`` maximum, and every nonzero diagonal of P0 >= 2^8 LSB of its format (at
      least 8 significant bits: a coarser one is not the configured P0).

The engines' API: ``cfg = SixStateFixedConfig.from_filter_config(six_state_config(scenario))``;
``params = cfg.params()``; ``state = cfg.initial_state(attitude_rad, bias_rad_s)``; ``work = new_work()``;
``counts = new_counts()``; per tick in njit code ``six_state_kernel.predict(state, rates_rad_s, params, counts,
work)`` (or ``predict_raw`` with Q16.16 rates), ``six_state_kernel.level_raw(state, rate_raw, accel_sums, n, params,
counts, work)`` (returns 1 where it levelled) and, with a reference, ``six_state_kernel.update(state, YAW_ONLY,
ref_rad, var_rad2, params, counts, work, raw)`` (or ``update_raw``); ``counts_dict(counts)`` names the overflows.
:class:`SixStateFixedFilter` is the batched class with the float filter's interface.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from fractions import Fraction

import numpy as np

from firmware_model import cordic
from firmware_model import fixedpoint as fp
from firmware_model import six_state_kernel as k6
from firmware_model.errors import FirmwareError
from firmware_model.fixed_filter import RAD_TO_DEG, TURN_RAD, const
from firmware_model.fixedpoint import OverflowCounter, QFormat
from firmware_model.six_state_filter import ATTITUDE, YAW, SixStateFilterConfig
from firmware_model.yaw_filter import batch_arg, check_finite, check_realizations

ANGLE_FORMAT = QFormat(32, 32)  # the CORDIC's binary angle
UNIT_FORMAT = QFormat(32, cordic.GAIN_FRAC)  # the CORDIC's sin/cos words, Q2.30
MIN_P0_LSB = 2**8
LEVEL_MAX_SHIFT = 20  # level_raw's sigma_F / |f|: |f| << (-shift) stays in int64 for count sums |f| < 2^42


@dataclass(frozen=True)
class SixStateFixedFormats:
    """Q formats of the 6-state fixed filter (module docstring); the P blocks as the 2-state filter's P formats."""

    angle: QFormat = ANGLE_FORMAT  # turns
    rate: QFormat = QFormat(32, 16)  # deg/s
    bias: QFormat = QFormat(32, 16)  # deg/s
    rho: QFormat = QFormat(32, 29)  # rad: |rho| < 4
    rho2: QFormat = QFormat(32, 25)  # rad^2: s < 64
    series: QFormat = QFormat(32, 28)  # the Horner sums (< 8)
    unit: QFormat = UNIT_FORMAT  # trig, DCM, Exp, J_r
    transition: QFormat = QFormat(32, 26)  # E, Phi11, Phi12 (s), G_C: < 32
    noise_sqrt: QFormat = QFormat(32, 28)  # deg: G_C A sigma_v sqrt(dt)
    p_aa: QFormat = QFormat(32, 24)  # deg^2: +/- 128
    p_ab: QFormat = QFormat(32, 32)  # deg^2/s: +/- 0.5
    p_bb: QFormat = QFormat(32, 38)  # (deg/s)^2: +/- 0.0078
    inv_s: QFormat = QFormat(32, 16)  # 1/deg^2
    gain_angle: QFormat = QFormat(32, 30)  # dimensionless
    gain_bias: QFormat = QFormat(32, 28)  # 1/s
    innovation_deg: QFormat = QFormat(32, 20)  # deg
    level_sigma: QFormat = QFormat(32, 20)  # deg: the levelling's angle sigma sigma_F / |f| (+/- 2048)


def _series_table(j: int, fmt: QFormat) -> list[int]:
    """b_k = (-1)^k 16^k / (2k + 1 + j)!, k < SERIES_TERMS, rounded half even into ``fmt`` (exact rationals)."""
    out = []
    for kk in range(k6.SERIES_TERMS):
        b = Fraction((-1) ** kk * 16**kk, math.factorial(2 * kk + 1 + j))
        out.append(round(b * 2**fmt.frac_bits))
    return out


@dataclass(frozen=True)
class SixStateFixedConfig:
    """One build of the 6-state fixed filter: the float tuning, the formats, the CORDIC iterations."""

    filter: SixStateFilterConfig
    formats: SixStateFixedFormats = SixStateFixedFormats()
    cordic_iterations: int = cordic.MAX_ITERATIONS
    accel_counts_per_m_s2: float = 0.0  # the accelerometer's count weight S_a (levelling only: its sums' noise)

    def __post_init__(self) -> None:
        self.check()

    @classmethod
    def from_filter_config(cls, cfg: SixStateFilterConfig, **fixed) -> "SixStateFixedConfig":
        """The build of a float 6-state tuning (``nodesim.chain.estimator.six_state_config(scenario)``)."""
        return cls(filter=cfg, **fixed)

    # ---- the checks (module docstring) ---------------------------------------------------------------------
    def check(self) -> None:
        f, t = self.formats, self.filter
        if t.discretisation != "rotation":
            raise FirmwareError(f"discretisation = {t.discretisation!r}: the fixed-point 6-state filter implements only "
                                "'rotation' (Phi = I + F dt, 'euler', is unstable under string rotation); allowed: rotation")
        cordic.check_iterations(self.cordic_iterations)
        for fld in dataclasses.fields(f):
            q = getattr(f, fld.name)
            if not isinstance(q, QFormat) or q.word_bits != 32:
                raise FirmwareError(f"formats.{fld.name} = {q}: the 6-state fixed filter is built for 32-bit words")
        if f.angle != ANGLE_FORMAT or f.unit != UNIT_FORMAT:
            raise FirmwareError(f"formats.angle = {f.angle}, formats.unit = {f.unit}: the CORDIC fixes them; allowed "
                                f"{ANGLE_FORMAT} and {UNIT_FORMAT}")
        inv_margin = 1.0 / math.sin(t.singularity_margin_rad)
        if 2.0 * inv_margin > f.transition.max_value:
            raise FirmwareError(f"singularity_margin_rad = {t.singularity_margin_rad}: 1/sin(margin) = {inv_margin:.4g} "
                                f"needs 2x headroom in formats.transition = {f.transition} (max {f.transition.max_value:.4g})")
        sv = self._sigma_v_deg()
        if 2.0 * max(sv) * inv_margin > f.noise_sqrt.max_value:
            raise FirmwareError(f"tuning_a = {t.tuning_a}: A sigma_v sqrt(dt) / sin(margin) = {max(sv) * inv_margin:.4g} "
                                f"deg needs 2x headroom in formats.noise_sqrt = {f.noise_sqrt}")
        self._check_covariance()
        self._check_levelling()

    def _level_sigma_deg_counts(self) -> float:
        """c_sigma = sigma_f S_a 180/pi: the noise of one sample-mean count (deg counts; level_raw's sigma_F / n)."""
        return self.filter.levelling_force_sigma_m_s2 * self.accel_counts_per_m_s2 * RAD_TO_DEG

    def _check_levelling(self) -> None:
        f, t = self.formats, self.filter
        if not t.levelling:
            return
        s_a = self.accel_counts_per_m_s2
        if not (math.isfinite(s_a) and s_a > 0):
            raise FirmwareError(f"accel_counts_per_m_s2 = {s_a} with levelling: allowed finite values > 0 (the "
                                "accelerometer's counts per m/s^2)")
        thr = t.levelling_rate_rad_s * RAD_TO_DEG * 2**f.rate.frac_bits
        if not 1.0 <= thr < k6.LEVEL_DIFF_LIMIT:
            raise FirmwareError(f"levelling_rate_rad_s = {t.levelling_rate_rad_s}: {thr:.4g} LSB of formats.rate = "
                                f"{f.rate}; allowed 1 .. 2^30 LSB")
        c = const(self._level_sigma_deg_counts(), site="levelling sigma")
        shift = f.level_sigma.frac_bits - c.fmt.frac_bits  # level_raw's division sigma_F / |f|
        if not -LEVEL_MAX_SHIFT <= shift <= 0:
            raise FirmwareError(f"levelling_force_sigma_m_s2 = {t.levelling_force_sigma_m_s2}: its count noise "
                                f"{self._level_sigma_deg_counts():.4g} deg counts needs a division shift {shift} into "
                                f"formats.level_sigma = {f.level_sigma}; allowed -{LEVEL_MAX_SHIFT} .. 0")

    def _sigma_v_deg(self) -> list[float]:
        t = self.filter
        return [t.tuning_a * s * math.sqrt(t.dt_s) * RAD_TO_DEG for s in t.arw_rad_per_sqrt_s]

    def _q_bb_deg2(self) -> np.ndarray:
        t = self.filter
        q = t.q_continuous[3:] * t.bias_gain**2 * t.dt_s * RAD_TO_DEG**2
        if np.any(q < 0) or not np.all(np.isfinite(q)):
            raise FirmwareError(f"bias_instability_rad_s = {t.bias_instability_rad_s}: Q_bb = {q}: allowed finite >= 0")
        return q

    def _check_covariance(self) -> None:
        f, t = self.formats, self.filter
        dt = t.dt_s
        p0_a = np.array(t.initial_angle_sigma_rad) ** 2 * RAD_TO_DEG**2
        p0_b = np.array(t.initial_bias_sigma_rad_s) ** 2 * RAD_TO_DEG**2
        q_a = np.array(self._sigma_v_deg()) ** 2
        fb = 1.0 - dt / np.array(t.bias_tau_s)
        p1_a = p0_a + dt * dt * p0_b + q_a
        p1_b = fb * fb * p0_b + self._q_bb_deg2()
        for name, key, fmt, p0, p1 in (("angle", "initial_angle_sigma_rad", f.p_aa, p0_a, p1_a),
                                       ("bias", "initial_bias_sigma_rad_s", f.p_bb, p0_b, p1_b)):
            block = "p_aa" if name == "angle" else "p_bb"
            worst = max(p0.max(), p1.max())
            if worst > fmt.max_value / 2:
                raise FirmwareError(f"formats.{block} = {fmt} is too narrow for the covariance: {key} = "
                                    f"{getattr(t, key)} gives a {name} variance {worst:.4g} after one tick, above half "
                                    f"the format's maximum {fmt.max_value:.4g}")
            small = p0[(p0 > 0) & (p0 < MIN_P0_LSB * fmt.lsb)]
            if small.size:
                raise FirmwareError(f"formats.{block} = {fmt} is too coarse for the covariance: {key} = "
                                    f"{getattr(t, key)} gives an initial variance {small[0]:.4g} below {MIN_P0_LSB} LSB "
                                    f"({MIN_P0_LSB * fmt.lsb:.4g})")
        cross = math.sqrt(p1_a.max() * p1_b.max())
        if cross > f.p_ab.max_value / 2:
            raise FirmwareError(f"formats.p_ab = {f.p_ab} is too narrow for the covariance: the angle-bias entries may "
                                f"reach sqrt(P_aa P_bb) = {cross:.4g} after one tick (initial_angle_sigma_rad, "
                                f"initial_bias_sigma_rad_s), above half the format's maximum {f.p_ab.max_value:.4g}")

    # ---- the build ---------------------------------------------------------------------------------------------
    def params(self) -> np.ndarray:
        """int64[six_state_kernel.N_PARAMS]: formats, constants, series tables and integers of this build."""
        f, t = self.formats, self.filter
        p = np.zeros(k6.N_PARAMS, dtype=np.int64)
        for name, i in k6._FMT.items():
            q = getattr(f, name)
            p[i], p[i + 1] = q.word_bits, q.frac_bits
        dt = t.dt_s
        consts = {"dt_rad": const(dt / RAD_TO_DEG, site="dt pi/180"), "dt": const(dt, site="dt"),
                  "c_360": fp.Fx(np.int64(360), QFormat(32, 0)),
                  "level_sigma": const(self._level_sigma_deg_counts() if t.levelling else 0.0, site="levelling sigma")}
        for axis, tau, sv, qb in zip("xyz", t.bias_tau_s, self._sigma_v_deg(), self._q_bb_deg2()):
            consts[f"f_{axis}"] = const(1.0 - dt / tau, site="1 - dt/tau")
            consts[f"sv_{axis}"] = const(sv, site="A sigma_v sqrt(dt)")
            consts[f"q_b{axis}"] = fp.from_float(qb, f.p_bb, site="Q_bb")
        for name, i in k6._CONST.items():
            c = consts[name]
            p[i], p[i + 1], p[i + 2] = int(np.asarray(c.raw).reshape(-1)[0]), c.fmt.frac_bits, c.fmt.word_bits
        for j in range(3):
            p[k6.T_SERIES + j * k6.SERIES_TERMS:k6.T_SERIES + (j + 1) * k6.SERIES_TERMS] = _series_table(j, f.series)
        m = t.singularity_margin_rad
        ints = {"cordic_iterations": self.cordic_iterations, "decouple": int(t.singularity == "decouple"),
                "sin_margin": round(math.sin(m) * 2**f.unit.frac_bits),
                "cos_margin": round(math.cos(m) * 2**f.unit.frac_bits),
                "one_unit": 1 << f.unit.frac_bits, "one_transition": 1 << f.transition.frac_bits,
                "dt_transition": round(dt * 2**f.transition.frac_bits), "level": int(t.levelling),
                "level_rate": round(t.levelling_rate_rad_s * RAD_TO_DEG * 2**f.rate.frac_bits)}
        for name, i in k6._INT.items():
            p[i] = ints[name]
        return p

    def initial_state(self, initial_attitude_rad=(0.0, 0.0, 0.0), bias_offset_rad_s=(0.0, 0.0, 0.0),
                      counter: OverflowCounter | None = None) -> np.ndarray:
        """int64[STATE_SIZE] of one lane: the attitude as binary angles, the biases, P0 (thesis eqs 3.15-3.16)."""
        f, t = self.formats, self.filter
        att = np.broadcast_to(check_finite("initial_attitude_rad", initial_attitude_rad), (3,))
        bias = np.broadcast_to(check_finite("bias_offset_rad_s", bias_offset_rad_s), (3,))
        if abs(att[1]) > math.pi / 2:
            raise FirmwareError("initial_attitude_rad: pitch outside [-pi/2, pi/2]; allowed |theta| <= pi/2")
        st = np.zeros(k6.STATE_SIZE, dtype=np.int64)
        st[k6.I_ATT:k6.I_ATT + 3] = fp.from_float(att / TURN_RAD, f.angle, overflow=fp.Overflow.WRAP).raw
        st[k6.I_BIAS:k6.I_BIAS + 3] = fp.from_float(bias * RAD_TO_DEG, f.bias, counter=counter, site="initial bias").raw
        st[k6.I_B0:k6.I_B0 + 3] = st[k6.I_BIAS:k6.I_BIAS + 3]  # the start bias b_0 (the levelling's static test)
        p0 = np.diag(t.p0) * RAD_TO_DEG**2
        for i in range(6):
            fmt = f.p_aa if i < 3 else f.p_bb
            st[k6.I_P + 7 * i] = max(1, int(fp.from_float(p0[i], fmt, counter=counter, site="P0").raw))
        return st


def new_work() -> np.ndarray:
    """The kernels' scratch words (one per caller; its contents between calls mean nothing)."""
    return np.zeros(k6.WORK_SIZE, dtype=np.int64)


def new_counts() -> np.ndarray:
    return np.zeros(len(k6.SITES), dtype=np.int64)


def counts_dict(counts) -> dict[str, int]:
    """The nonzero overflow counts by site name."""
    return {k6.SITES[i]: int(c) for i, c in enumerate(np.asarray(counts)) if c}


class SixStateFixedFilter:
    """R independent 6-state fixed filters, the interface of :class:`firmware_model.six_state_filter.SixStateFilter`
    (``predict`` then ``update``; SI units at the boundary), running the compiled kernels lane by lane."""

    def __init__(self, config: SixStateFixedConfig, realizations: int, initial_attitude_rad=0.0, bias_offset_rad_s=0.0):
        self.config = config
        self.realizations = R = check_realizations(realizations)
        self.params = config.params()
        self._counts = new_counts()
        self._work = new_work()
        self._raw = np.zeros(6, dtype=np.int64)
        self._counter = OverflowCounter()
        att = np.broadcast_to(check_finite("initial_attitude_rad", initial_attitude_rad), (R, 3))
        bias = np.broadcast_to(check_finite("bias_offset_rad_s", bias_offset_rad_s), (R, 3))
        self.states = np.stack([config.initial_state(att[r], bias[r], self._counter) for r in range(R)])

    def __repr__(self) -> str:
        return (f"SixStateFixedFilter(realizations={self.realizations}, yaw_deg={np.degrees(self.yaw_rad)[:4]}, "
                f"overflows={self.overflow_counts})")

    @property
    def attitude_rad(self) -> np.ndarray:
        """(roll, pitch, yaw) (R, 3), each a binary angle in [-pi, pi)."""
        return fp.to_float(fp.Fx(self.states[:, k6.I_ATT:k6.I_ATT + 3], self.config.formats.angle)) * TURN_RAD

    @property
    def yaw_rad(self) -> np.ndarray:
        return self.attitude_rad[:, YAW]

    @property
    def bias_rad_s(self) -> np.ndarray:
        return fp.to_float(fp.Fx(self.states[:, k6.I_BIAS:k6.I_BIAS + 3], self.config.formats.bias)) / RAD_TO_DEG

    @property
    def covariance(self) -> np.ndarray:
        """P (R, 6, 6) in rad and rad/s (order phi, theta, psi, b_x, b_y, b_z)."""
        f = self.config.formats
        frac = np.full((6, 6), f.p_ab.frac_bits)
        frac[:3, :3], frac[3:, 3:] = f.p_aa.frac_bits, f.p_bb.frac_bits
        raw = self.states[:, k6.I_P:k6.I_P + 36].reshape(-1, 6, 6).astype(float)
        return np.ldexp(raw, -frac) / RAD_TO_DEG**2

    @property
    def yaw_variance_rad2(self) -> np.ndarray:
        return self.covariance[:, YAW, YAW]

    @property
    def singular_ticks(self) -> np.ndarray:
        return self.states[:, k6.I_SING].copy()

    @property
    def overflow_counts(self) -> dict[str, int]:
        """Saturations per site (the kernels' and the initial conversions')."""
        out = dict(self._counter.counts)
        for name, n in counts_dict(self._counts).items():
            out[name] = out.get(name, 0) + n
        return out

    def predict(self, measured_rates_rad_s) -> None:
        """Time update over one tick with the tick-averaged gyro rates (R, 3) or (3,), rad/s."""
        rates = np.ascontiguousarray(np.broadcast_to(check_finite("gyro rates", measured_rates_rad_s),
                                                     (self.realizations, 3)), dtype=float)
        k6.predict_lanes(self.states, rates, self.params, self._counts, self._work)

    def level(self, measured_rates_rad_s, accel_count_sums, n_samples: int) -> int:
        """The levelling update (``filter.levelling``; :func:`firmware_model.six_state_kernel.level_raw`) of every
        lane at a static tick: the tick's gyro rates (R, 3) or (3,) rad/s and accelerometer count sums (R, 3) or
        (3,) over ``n_samples`` samples; returns how many lanes were static and levelled."""
        R = self.realizations
        rates = np.ascontiguousarray(np.broadcast_to(check_finite("gyro rates", measured_rates_rad_s), (R, 3)),
                                     dtype=float)
        sums = np.ascontiguousarray(np.broadcast_to(np.asarray(accel_count_sums, dtype=np.int64), (R, 3)))
        return int(k6.level_lanes(self.states, rates, sums, int(n_samples), self.params, self._counts, self._work))

    def update(self, reference_yaw_rad, reference_variance_rad2, mask=None, reference_roll_pitch_rad=None,
               roll_pitch_variance_rad2=None) -> None:
        """Measurement update: the yaw reference (H = e3^T) or roll/pitch/yaw (H = [I3 0]), on the ``mask`` lanes."""
        R = self.realizations
        ref = np.zeros((R, 3))
        var = np.zeros((R, 3))
        ref[:, YAW] = batch_arg("reference yaw", check_finite("reference yaw", reference_yaw_rad), R)
        var[:, YAW] = batch_arg("reference variance", check_finite("reference variance", reference_variance_rad2), R)
        if (reference_roll_pitch_rad is None) != (roll_pitch_variance_rad2 is None):
            raise FirmwareError("reference_roll_pitch_rad and roll_pitch_variance_rad2: give both or neither")
        axes = k6.YAW_ONLY
        if reference_roll_pitch_rad is not None:
            ref[:, :2] = np.broadcast_to(check_finite("reference roll/pitch", reference_roll_pitch_rad), (R, 2))
            var[:, :2] = np.broadcast_to(check_finite("roll/pitch variance", roll_pitch_variance_rad2), (R, 2))
            axes = k6.ALL_AXES
        if np.any(var[:, list(ATTITUDE) if axes == k6.ALL_AXES else [YAW]] < 0):
            raise FirmwareError("reference variance: negative value; allowed >= 0 (rad^2)")
        on = np.ones(R, dtype=np.int64) if mask is None else batch_arg("update mask", mask, R, dtype=bool).astype(np.int64)
        k6.update_lanes(self.states, axes, ref, var, on, self.params, self._counts, self._work, self._raw)
