"""The yaw filter of :mod:`firmware_model.yaw_filter` in the MCU's fixed-point arithmetic.

Same model and equations; the state lives in 32-bit words (thesis digest 2.7 suggestion, the thesis gives
no format):
    yaw            32-bit binary angle, 2**32 = 360 deg (QFormat(32, 32) in turns, wraps by design)
    rate, bias     Q16.16 deg/s
    P              three scaled int32 (P_yy deg^2, P_yb deg^2/s, P_bb (deg/s)^2; P is symmetric), P_ii >= 1 LSB
    gains          K_y dimensionless, K_b 1/s; one division per update (1 / S)
Constants (dt, 1 - dt/tau, Q_d, dt/360) are scaled at build time to the most precise 32-bit format
(:func:`const`), as a firmware engineer scales compile-time constants.

Per tick (C on the MCU, every product an int64 intermediate rounded and saturated by fixedpoint):
    predict:  d = rate - bias;  yaw += d * (dt/360)                        (binary angle, wraps)
              P_yy += 2 dt P_yb + dt^2 P_bb + q_y;  P_yb = f (P_yb + dt P_bb);  P_bb = f^2 P_bb + q_b
    update:   z = (int32_t)(yaw - ref)   (the wrap of the innovation into [-180, 180) is free)
              S = P_yy + R;  inv = 1 / S;  K_y = P_yy inv;  K_b = P_yb inv
              yaw -= K_y z;  bias += K_b z_deg;  P_yy -= K_y P_yy;  P_yb -= K_y P_yb;  P_bb -= K_b P_yb
Floats cross into the model only at explicit boundaries (``from_float``): the gyro rate (what the
counts-to-deg/s scaling of the IMU driver delivers), the reference yaw and its variance (received values).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from firmware_model import fixed_kernel as fk
from firmware_model import fixedpoint as fp
from firmware_model.errors import FirmwareError
from firmware_model.fixedpoint import FixedContext, Fx, Overflow, QFormat, Rounding
from firmware_model.yaw_filter import YawFilter, YawFilterConfig, batch_arg, check_finite, check_realizations

RAD_TO_DEG = fk.RAD_TO_DEG
TURN_RAD = fk.TURN_RAD


@dataclass(frozen=True)
class FixedFormats:
    """Q formats of the fixed filter's variables (defaults: thesis digest 2.7 plus our choices for P and K)."""

    yaw: QFormat = QFormat(32, 32)  # turns: a 32-bit binary angle
    rate: QFormat = QFormat(32, 16)  # deg/s, Q16.16
    bias: QFormat = QFormat(32, 16)  # deg/s, Q16.16
    p_yy: QFormat = QFormat(32, 24)  # deg^2: +/- 128
    p_yb: QFormat = QFormat(32, 32)  # deg^2/s: +/- 0.5
    p_bb: QFormat = QFormat(32, 38)  # (deg/s)^2: +/- 0.0078, sigma <= 0.088 deg/s
    inv_s: QFormat = QFormat(32, 16)  # 1/deg^2: S >= 3e-5 deg^2
    gain_yaw: QFormat = QFormat(32, 30)  # dimensionless, 0..1
    gain_bias: QFormat = QFormat(32, 28)  # 1/s
    innovation_deg: QFormat = QFormat(32, 20)  # deg: +/- 2048
    rounding: Rounding = Rounding.HALF_EVEN
    overflow: Overflow = Overflow.SATURATE

    def with_word_length(self, word_bits: int) -> "FixedFormats":
        """The same formats on a ``word_bits``-bit MCU word: every variable keeps its integer bits (its
        range) and loses ``32 - word_bits`` fraction bits (its resolution); the yaw stays a binary angle."""
        if not (isinstance(word_bits, int) and 8 <= word_bits <= 32):
            raise FirmwareError(f"word_bits = {word_bits!r}: allowed integers 8..32")
        drop = 32 - word_bits
        changes = {
            f.name: QFormat(word_bits, getattr(self, f.name).frac_bits - drop)
            for f in dataclasses.fields(self)
            if isinstance(getattr(self, f.name), QFormat)
        }
        return dataclasses.replace(self, **changes)


def const(value: float, word_bits: int = 32, site: str = "constant") -> Fx:
    """A compile-time constant in the most precise ``word_bits`` format that holds it (round half even)."""
    if not math.isfinite(value):
        raise FirmwareError(f"{site} = {value}: allowed finite numbers")
    if value == 0.0:
        return Fx(np.int64(0), QFormat(word_bits, 0))
    frac = word_bits - 2 - math.floor(math.log2(abs(value)))
    frac = max(-31, min(fp.MAX_SHIFT, frac))
    return fp.from_float(value, QFormat(word_bits, frac), site=site)


def _advance(yaw: Fx, rate: Fx, k_turns: Fx, ctx: FixedContext, site: str) -> Fx:
    """yaw + rate * k (C: ``yaw + (int32_t)round((int64_t)rate * K, s)``, the binary angle wraps)."""
    inc = ctx.mul(rate, k_turns, yaw.fmt, site)
    return fp.add(yaw, inc, yaw.fmt, ctx.rounding, Overflow.WRAP)


def advance_binary_angle(yaw: Fx, rate: Fx, delay_s: float, ctx: FixedContext) -> Fx:
    """Eq 3.29 in fixed point: the previous node's binary-angle estimate advanced by its rate (deg/s) times
    the transfer delay, psi_ref = psi_prev + rate * dt_n, with dt_n / 360 a compile-time-style constant."""
    if not (math.isfinite(delay_s) and delay_s >= 0):
        raise FirmwareError(f"delay_s = {delay_s}: allowed finite values >= 0")
    return _advance(yaw, rate, const(delay_s / 360.0, site="delay/360"), ctx, "reference advance")


class FixedYawFilter(YawFilter):
    """R independent yaw filters in fixed point; raw int64 arrays of shape (R,)."""

    def __init__(
        self,
        config: YawFilterConfig,
        realizations: int,
        initial_yaw_rad=0.0,
        bias_offset_rad_s=0.0,
        formats: FixedFormats | None = None,
    ):
        self.config = config
        self.realizations = R = check_realizations(realizations)
        self.formats = f = formats or FixedFormats()
        self.ctx = FixedContext(f.rounding, f.overflow)
        dt = config.dt_s
        phi_bb = 1.0 - dt / config.bias_tau_s
        q_d = config.q_d * np.array([[RAD_TO_DEG**2, 1.0], [1.0, RAD_TO_DEG**2]])  # deg^2, (deg/s)^2
        self.k_turns = const(dt / 360.0, site="dt/360")
        self.c_dt = const(dt, site="dt")
        self.c_2dt = const(2.0 * dt, site="2 dt")
        self.c_dt2 = const(dt * dt, site="dt^2")
        self.c_f = const(phi_bb, site="1 - dt/tau")
        self.c_f2 = const(phi_bb * phi_bb, site="(1 - dt/tau)^2")
        self.c_360 = Fx(np.int64(360), QFormat(32, 0))
        self.one = Fx(np.int64(1 << 30), QFormat(32, 30))
        self.q_yy = self.ctx.from_float(q_d[0, 0], f.p_yy, "q_yy")
        self.q_bb = self.ctx.from_float(q_d[1, 1], f.p_bb, "q_bb")
        init_yaw = batch_arg("initial_yaw_rad", check_finite("initial_yaw_rad", initial_yaw_rad), R)
        init_bias = batch_arg("bias_offset_rad_s", check_finite("bias_offset_rad_s", bias_offset_rad_s), R)
        self.yaw = fp.from_float(init_yaw / TURN_RAD, f.yaw, f.rounding, Overflow.WRAP)
        self.bias = self.ctx.from_float(init_bias * RAD_TO_DEG, f.bias, "initial bias")
        p0 = config.p0
        self.p_yy = self.ctx.from_float(np.full(R, p0[0, 0] * RAD_TO_DEG**2), f.p_yy, "P0_yy")
        self.p_yb = Fx(np.zeros(R, dtype=np.int64), f.p_yb)
        self.p_bb = self.ctx.from_float(np.full(R, p0[1, 1] * RAD_TO_DEG**2), f.p_bb, "P0_bb")

    # ---- the interface -------------------------------------------------------------------------------
    @property
    def yaw_rad(self) -> np.ndarray:
        """Binary angle as radians in [-pi, pi)."""
        return fp.to_float(self.yaw) * TURN_RAD

    @property
    def bias_rad_s(self) -> np.ndarray:
        return fp.to_float(self.bias) / RAD_TO_DEG

    @property
    def covariance(self) -> np.ndarray:
        yy, yb, bb = (fp.to_float(p) / RAD_TO_DEG**2 for p in (self.p_yy, self.p_yb, self.p_bb))
        return np.stack([np.stack([yy, yb], -1), np.stack([yb, bb], -1)], -2)

    @property
    def yaw_variance_rad2(self) -> np.ndarray:
        return fp.to_float(self.p_yy) / RAD_TO_DEG**2

    @property
    def overflow_counts(self) -> dict[str, int]:
        return dict(self.ctx.counter.counts)

    @property
    def _fusable(self) -> bool:
        """The default policy (round half even, saturate) runs the firmware's own compiled steps
        (:func:`firmware_model.fixed_kernel.predict_raw_lanes` / ``update_raw_lanes``: the code the chain's
        node firmware runs, bit for bit the primitive-by-primitive path below, tests/firmware_model/
        test_fixed_kernel.py); other policies (rounding and overflow studies) run the primitives."""
        return self.ctx.rounding is Rounding.HALF_EVEN and self.ctx.overflow is Overflow.SATURATE

    def _kernel_params(self):
        """The compiled kernels' parameter vector, or None where the primitives must run (another policy, a
        state or input outside the build's formats)."""
        if not self._fusable:
            return None
        f = self.formats
        if any(getattr(self, n).fmt != getattr(f, n) for n in self.STATE):
            return None
        if getattr(self, "_kp", None) is None:
            self._kp = fk.kernel_params(self)
        return self._kp

    def _run_kernel(self, kernel, *raws) -> np.ndarray:
        """(R, 5) states after ``kernel`` on every lane; its overflows recorded per site."""
        states = fk.lane_states(self)
        counts = np.zeros(len(fk.SITES), dtype=np.int64)
        R = self.realizations
        args = [np.ascontiguousarray(np.broadcast_to(np.asarray(x, dtype=np.int64), (R,))) for x in raws]
        kernel(states, *args, self._kp, counts)
        for i in np.flatnonzero(counts):
            self.ctx.counter.record(fk.SITES[i], int(counts[i]))
        return states

    def _set_states(self, states: np.ndarray, mask=None) -> None:
        for i, name in enumerate(self.STATE):
            old = getattr(self, name)
            raw = states[:, i] if mask is None else np.where(mask, states[:, i], old.raw)
            setattr(self, name, Fx(np.ascontiguousarray(raw), old.fmt))

    def predict(self, measured_rate_rad_s) -> None:
        rate = batch_arg("gyro rate", check_finite("gyro rate", measured_rate_rad_s), self.realizations)
        self.predict_raw(self.ctx.from_float(rate * RAD_TO_DEG, self.formats.rate, "gyro rate"))

    def update(self, reference_yaw_rad, reference_variance_rad2, mask=None) -> None:
        """Measurement update in the ``mask`` realizations; the others keep their state and count no overflow
        (their reference does not exist: only the realizations that received one convert and use it)."""
        ref = batch_arg("reference yaw", check_finite("reference yaw", reference_yaw_rad), self.realizations)
        r = batch_arg("reference variance", check_finite("reference variance", reference_variance_rad2), self.realizations)
        if np.any(r < 0):
            raise FirmwareError("reference variance: negative value; allowed >= 0 (rad^2)")
        mask = self._mask(mask)
        if mask.all():
            self._update_float(ref, r)
            return
        lanes = np.flatnonzero(mask)  # the others neither change nor count overflows of references they never got
        if lanes.size:
            self._on_lanes(lanes, lambda: self._update_float(ref[lanes], r[lanes]))

    def _update_float(self, ref: np.ndarray, r: np.ndarray) -> None:
        f = self.formats
        ref_fx = fp.from_float(ref / TURN_RAD, f.yaw, f.rounding, Overflow.WRAP)  # binary angle, wraps
        r_fx = self.ctx.from_float(r * RAD_TO_DEG**2, f.p_yy, "reference variance")
        self.update_raw(ref_fx, r_fx, np.ones(ref.shape[0], dtype=bool))

    STATE = ("yaw", "bias", "p_yy", "p_yb", "p_bb")

    def _on_lanes(self, lanes: np.ndarray, step) -> None:
        """Run ``step`` on the realizations ``lanes`` only (their state gathered, stepped, scattered back)."""
        full = {name: getattr(self, name) for name in self.STATE}
        R = self.realizations
        try:
            for name, fx in full.items():
                setattr(self, name, Fx(fx.raw[lanes], fx.fmt))
            self.realizations = lanes.size
            step()
        finally:
            stepped = {name: getattr(self, name) for name in self.STATE}
            self.realizations = R
            for name, fx in full.items():
                raw = np.array(fx.raw, dtype=np.int64, copy=True)
                raw[lanes] = stepped[name].raw
                setattr(self, name, Fx(raw, stepped[name].fmt))

    # ---- the firmware, on raw values -----------------------------------------------------------------
    def predict_raw(self, rate: Fx) -> None:
        """Time update with the gyro rate already in fixed point (deg/s): the compiled firmware step where it
        applies (:meth:`_kernel_params`), else primitive by primitive (the same bits and counts)."""
        if self._kernel_params() is not None and rate.fmt == self.formats.rate:
            self._set_states(self._run_kernel(fk.predict_raw_lanes, rate.raw))
            return
        c, f = self.ctx, self.formats
        d = c.sub(rate, self.bias, f.rate, "rate - bias")
        self.yaw = _advance(self.yaw, d, self.k_turns, c, "yaw increment")  # binary angle: wraps by design
        p_yy = c.add(self.p_yy, c.mul(self.p_yb, self.c_2dt, f.p_yy, "2 dt P_yb"), f.p_yy, "P_yy predict")
        p_yy = c.add(p_yy, c.mul(self.p_bb, self.c_dt2, f.p_yy, "dt^2 P_bb"), f.p_yy, "P_yy predict")
        p_yy = c.add(p_yy, self.q_yy, f.p_yy, "P_yy predict")
        p_yb = c.add(self.p_yb, c.mul(self.p_bb, self.c_dt, f.p_yb, "dt P_bb"), f.p_yb, "P_yb predict")
        p_yb = c.mul(p_yb, self.c_f, f.p_yb, "P_yb predict")
        p_bb = c.add(c.mul(self.p_bb, self.c_f2, f.p_bb, "f^2 P_bb"), self.q_bb, f.p_bb, "P_bb predict")
        self.p_yy, self.p_yb, self.p_bb = self._floor_variance(p_yy), p_yb, self._floor_variance(p_bb)

    def update_raw(self, ref: Fx, r: Fx, mask: np.ndarray) -> None:
        """Measurement update with the reference as a binary angle and its variance in P_yy's format (the
        compiled firmware step where it applies, else primitive by primitive).  Every lane is computed (and
        counts its overflows), the ``mask`` lanes keep the result."""
        f = self.formats
        if self._kernel_params() is not None and ref.fmt == f.yaw and r.fmt == f.p_yy:
            self._set_states(self._run_kernel(fk.update_raw_lanes, ref.raw, r.raw), None if mask.all() else mask)
            return
        c, f = self.ctx, self.formats
        z = fp.sub(self.yaw, ref, f.yaw, f.rounding, Overflow.WRAP)  # (int32_t)(yaw - ref): wrapped innovation
        s = c.add(self.p_yy, r, f.p_yy, "S = P_yy + R")
        inv = c.div(self.one, s, f.inv_s, "1 / S")
        k_y = c.mul(self.p_yy, inv, f.gain_yaw, "K_y")
        k_b = c.mul(self.p_yb, inv, f.gain_bias, "K_b")
        z_deg = c.mul(z, self.c_360, f.innovation_deg, "innovation deg")
        yaw = fp.sub(self.yaw, c.mul(k_y, z, f.yaw, "K_y z"), f.yaw, f.rounding, Overflow.WRAP)
        bias = c.add(self.bias, c.mul(k_b, z_deg, f.bias, "K_b z"), f.bias, "bias update")
        p_yy = c.sub(self.p_yy, c.mul(k_y, self.p_yy, f.p_yy, "K_y P_yy"), f.p_yy, "P_yy update")
        p_yb = c.sub(self.p_yb, c.mul(k_y, self.p_yb, f.p_yb, "K_y P_yb"), f.p_yb, "P_yb update")
        p_bb = c.sub(self.p_bb, c.mul(k_b, self.p_yb, f.p_bb, "K_b P_yb"), f.p_bb, "P_bb update")
        pick = lambda new, old: Fx(np.where(mask, new.raw, old.raw), old.fmt)  # noqa: E731
        self.yaw, self.bias = pick(yaw, self.yaw), pick(bias, self.bias)
        self.p_yy = pick(self._floor_variance(p_yy), self.p_yy)
        self.p_yb = pick(p_yb, self.p_yb)
        self.p_bb = pick(self._floor_variance(p_bb), self.p_bb)

    @staticmethod
    def _floor_variance(p: Fx) -> Fx:
        """P_ii >= 1 LSB (C: ``if (p < 1) p = 1;``) keeps the covariance positive after rounding."""
        return Fx(np.maximum(p.raw, 1), p.fmt)
