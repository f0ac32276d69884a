"""What the firmware does to the sensor data before and around the filter (thesis 4.2.2-4.2.3, digest 5.2).

- :class:`FixedMovingAverage`: the N-point moving-average filter (32 points default, 16.8 s at 1.9 Hz) as
  the MCU runs it: a ring buffer of raw fixed-point samples and a running int64 sum.  While the buffer
  fills, the average is over the samples received so far.  :func:`moving_average_fixed` computes the same
  outputs for a whole series at once (bit-identical, for batch use).
- :func:`initial_bias`: the fixed gyro bias, the average of the rates over the first stationary window
  (50 s default) - simple averaging, thesis 4.2.3.
- :func:`alignment_offset` / :func:`tilt_angles` / :func:`corrected_inclination`: the alignment offset of
  the IMU in its tube, from the maximum and minimum of pitch and roll during the slow calibration
  rotation: offset = (max + min) / 2, subtracted from later readings, I = sqrt(pitch^2 + roll^2)
  (thesis 4.2.2 procedure, digest 5.2).
- :func:`check_tick_times`: sample times must be finite and strictly increasing (zero or negative steps
  are rejected: the firmware's tick counter never repeats or runs backwards).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from firmware_model import fixedpoint as fp
from firmware_model.errors import FirmwareError
from firmware_model.fixedpoint import Fx, QFormat, Rounding
from firmware_model.yaw_filter import check_finite

COUNT_FORMAT = QFormat(32, 0)


def check_tick_times(t_s, name: str = "t_s") -> np.ndarray:
    """Finite, strictly increasing sample times (K,); the error names the first offending index."""
    t = check_finite(name, t_s)
    if t.ndim != 1:
        raise FirmwareError(f"{name}: shape {t.shape}; allowed a 1-D array of tick times")
    step = np.diff(t)
    bad = np.flatnonzero(step <= 0)
    if bad.size:
        i = int(bad[0]) + 1
        raise FirmwareError(
            f"{name}: time step {step[i - 1]:.6g} s at index {i} ({t[i - 1]:.6g} -> {t[i]:.6g} s); "
            "allowed strictly increasing times (dt > 0)"
        )
    return t


def _check_points(points: int) -> int:
    if not (isinstance(points, (int, np.integer)) and 1 <= points <= 1 << 16):
        raise FirmwareError(f"moving average points = {points!r}: allowed integers 1..65536")
    return int(points)


class FixedMovingAverage:
    """Ring-buffer N-point moving average of raw fixed-point samples (batch shape fixed at construction).

    C per sample:  ``sum += x - buf[head]; buf[head] = x; head = (head + 1) % N; if (n < N) n++;``
    ``avg = round(sum / n)`` (int64 sum, the division rounded with the build's rounding mode).
    """

    def __init__(self, points: int = 32, fmt: QFormat = QFormat(32, 16), batch_shape=(), rounding=Rounding.HALF_EVEN):
        self.points = _check_points(points)
        self.fmt = fmt
        self.rounding = Rounding(rounding)
        self.buf = np.zeros(tuple(batch_shape) + (self.points,), dtype=np.int64)
        self.sum = np.zeros(tuple(batch_shape), dtype=np.int64)
        self.head = 0
        self.filled = 0

    def push(self, x: Fx) -> Fx:
        """Add one sample (raw in ``fmt``, batch shape) and return the current average."""
        if x.fmt != self.fmt:
            raise FirmwareError(f"moving average sample format {x.fmt}: this filter holds {self.fmt}")
        raw = np.broadcast_to(np.asarray(x.raw, dtype=np.int64), self.sum.shape)
        self.sum += raw - self.buf[..., self.head]
        self.buf[..., self.head] = raw
        self.head = (self.head + 1) % self.points
        self.filled = min(self.filled + 1, self.points)
        return fp.div(Fx(self.sum, self.fmt), Fx(np.int64(self.filled), COUNT_FORMAT), self.fmt, self.rounding)

    def push_float(self, x) -> Fx:
        """The float -> fixed boundary (an ADC value scaled to ``fmt``), then :meth:`push`."""
        return self.push(fp.from_float(check_finite("moving average sample", x), self.fmt, self.rounding, site="moving average"))


def moving_average_fixed(x: Fx, points: int = 32, rounding=Rounding.HALF_EVEN) -> Fx:
    """Outputs of :class:`FixedMovingAverage` for a whole series along the last axis, bit-identical."""
    points = _check_points(points)
    raw = np.asarray(x.raw, dtype=np.int64)
    csum = np.cumsum(raw, axis=-1)
    window = csum.copy()
    window[..., points:] = csum[..., points:] - csum[..., :-points]
    counts = np.minimum(np.arange(1, raw.shape[-1] + 1), points)
    return fp.div(Fx(window, x.fmt), Fx(counts, COUNT_FORMAT), x.fmt, rounding)


def initial_bias(t_s, rate: Fx, window_s: float = 50.0, rounding=Rounding.HALF_EVEN) -> Fx:
    """Fixed gyro bias: mean of the raw rates (R, K) at times ``t_s`` (K,) with t < t_0 + window_s.

    C: ``for (i = 0; t[i] < t0 + W; i++) sum += rate[i]; bias = round(sum / i);`` (int64 sum).
    """
    t = check_tick_times(t_s)
    if not (np.isfinite(window_s) and window_s > 0):
        raise FirmwareError(f"bias window_s = {window_s}: allowed finite values > 0")
    raw = np.asarray(rate.raw, dtype=np.int64)
    if raw.shape[-1] != t.size:
        raise FirmwareError(f"gyro rates: {raw.shape[-1]} samples for {t.size} tick times; allowed equal counts")
    n = int(np.count_nonzero(t < t[0] + window_s))
    if n == 0:
        raise FirmwareError(f"bias window_s = {window_s}: no sample inside; allowed windows covering >= 1 tick")
    total = raw[..., :n].sum(axis=-1)
    return fp.div(Fx(total, rate.fmt), Fx(np.int64(n), COUNT_FORMAT), rate.fmt, rounding)


def tilt_angles(specific_force_sensor) -> tuple[np.ndarray, np.ndarray]:
    """Pitch and roll (rad) of the sensor z axis from the specific force (..., 3):
    pitch = atan2(f'_x, f'_z), roll = atan2(f'_y, f'_z) (z up-hole; for small tilts pitch = I cos(tau'),
    roll = I sin(tau') with tau' the sensor-frame toolface)."""
    f = check_finite("accelerometer sample", specific_force_sensor)
    if f.shape[-1:] != (3,):
        raise FirmwareError(f"accelerometer sample: shape {f.shape}; allowed (..., 3)")
    return np.arctan2(f[..., 0], f[..., 2]), np.arctan2(f[..., 1], f[..., 2])


@dataclass(frozen=True)
class AlignmentOffset:
    """Constant pitch and roll offsets of the IMU in its tube (rad), per realization."""

    pitch_rad: np.ndarray
    roll_rad: np.ndarray


def alignment_offset(pitch_rad, roll_rad, during) -> AlignmentOffset:
    """Offset = (max + min) / 2 of pitch and of roll over the samples where ``during`` (K,) is True (the
    slow calibration rotation; thesis 4.2.2).  Inputs (R, K); the rotation must cover at least one turn
    for the extremes to be reached (not checked: the firmware cannot know)."""
    p, r = check_finite("pitch", pitch_rad), check_finite("roll", roll_rad)
    mask = np.asarray(during, dtype=bool)
    if not mask.any():
        raise FirmwareError("alignment offset: the calibration rotation window holds no sample; allowed >= 1")
    p, r = p[..., mask], r[..., mask]
    return AlignmentOffset(0.5 * (p.max(axis=-1) + p.min(axis=-1)), 0.5 * (r.max(axis=-1) + r.min(axis=-1)))


def corrected_tilt(pitch_rad, roll_rad, offset: AlignmentOffset) -> tuple[np.ndarray, np.ndarray]:
    """Pitch and roll with the alignment offset removed (offsets broadcast over the last, time, axis)."""
    return np.asarray(pitch_rad) - offset.pitch_rad[..., None], np.asarray(roll_rad) - offset.roll_rad[..., None]


def corrected_inclination(pitch_rad, roll_rad, offset: AlignmentOffset) -> np.ndarray:
    """I = sqrt(pitch^2 + roll^2) after the offset correction (thesis 4.2.2)."""
    p, r = corrected_tilt(pitch_rad, roll_rad, offset)
    return np.hypot(p, r)
