"""Full IMU model at the sensor rate: error model -> clipping -> int16 ADC counts -> firmware-rate averaging.

For each triad (3-axis gyro or accelerometer), with true input u (rad/s or m/s^2, shape (..., K, 3)):

    v = M (1 + k_s dT) u + b0 + k_b dT + b_gm(t) + b_flicker(t) + b_rrw(t) + w(t)      (thesis eq 3.17,
                                                                                   calibration paper eq 1)
    v_clipped = clip(v, -FS, +FS)
    counts    = clip(round(v_clipped * LSB), -32768, 32767)  as int16
    value     = counts / LSB                                 (engineering units, SI)

M is the scale-factor/misalignment matrix (row i = sensor axis i; diagonal 1 + scale error), b0 the
constant (turn-on) bias, dT = T - T_ref the temperature difference, b_gm a first-order Gauss-Markov bias
(sigma, tau; eqs 3.18-3.20), b_flicker the bias instability (IEEE coefficient B, Allan floor 0.664 B,
eqs V.33-V.34), b_rrw an optional rate random walk, and w white noise of density N (ARW for a gyro in
rad/sqrt(s), VRW for an accelerometer in m/s^2/sqrt(Hz)).  See :mod:`nodesim.sensors.noise` for the
processes.  MPU6500 defaults: +/-250 deg/s at 131 LSB/(deg/s), +/-2 g at 16384 LSB/g.

The firmware reads the sensor at its own rate (1.9 Hz) and averages the samples received since the last
tick: :func:`average_per_tick` does that for any (non-integer) rate ratio.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from nodesim.errors import NodesimError
from nodesim.sensors import noise

INT16_MIN, INT16_MAX = -32768, 32767
ADC_TYPES = {16: np.int16, 32: np.int32}
MAX_CONDITION = 1e6
"""Largest condition number of a misalignment matrix accepted as invertible."""


def _vec3(name: str, value) -> np.ndarray:
    arr = np.broadcast_to(np.asarray(value, dtype=float), (3,)).copy()
    if not np.all(np.isfinite(arr)):
        raise NodesimError(f"sensor spec: {name} = {value!r} must be finite")
    return arr


@dataclass(frozen=True)
class TriadSpec:
    """Error model of one 3-axis sensor, SI units (rad/s for a gyro, m/s^2 for an accelerometer).

    Scalars given for per-axis fields apply to all three axes.  ``bias_instability`` is the IEEE 952
    coefficient B (a datasheet or thesis table V.1 "bias stability" read as the Allan minimum is B * 0.664).
    """

    name: str
    full_scale: float  # +/- range in SI units
    lsb_per_unit: float  # ADC counts per SI unit
    white_density: object = 0.0  # per axis: rad/sqrt(s) or m/s^2/sqrt(Hz)
    bias: object = 0.0  # constant (turn-on) bias per axis
    bias_instability: object = 0.0  # IEEE coefficient B per axis
    flicker_tau_min_s: float = 0.1
    flicker_tau_max_s: float = 1.0e5
    gm_sigma: object = 0.0  # Gauss-Markov bias sigma per axis
    gm_tau_s: float = 500.0
    rate_random_walk: object = 0.0  # K per axis (unit/s/sqrt(s))
    misalignment: object = field(default_factory=lambda: np.eye(3))  # M, row i = sensor axis i
    bias_temp_coeff: object = 0.0  # bias change per kelvin, per axis
    scale_temp_coeff: float = 0.0  # relative scale change per kelvin
    reference_temperature_c: float = 25.0
    adc_bits: int = 16  # 16 (MEMS ADC, e.g. MPU6500) or 32 (sensors that output fine-grained words)

    def __post_init__(self):
        where = f"sensor spec {self.name!r}"
        if self.adc_bits not in ADC_TYPES:
            raise NodesimError(f"{where}: adc_bits = {self.adc_bits!r} (allowed: 16, 32)")
        for key in ("full_scale", "lsb_per_unit"):
            v = getattr(self, key)
            if not (math.isfinite(v) and v > 0.0):
                raise NodesimError(f"{where}: {key} = {v} must be > 0")
        if self.full_scale * self.lsb_per_unit > self.count_limits[1] + 1:
            raise NodesimError(
                f"{where}: full_scale * lsb_per_unit = {self.full_scale * self.lsb_per_unit:.1f} counts "
                f"exceeds the int{self.adc_bits} range (allowed: <= {self.count_limits[1] + 1})"
            )
        for key in ("white_density", "bias_instability", "gm_sigma", "rate_random_walk"):
            arr = _vec3(f"{where}: {key}", getattr(self, key))
            if np.any(arr < 0.0):
                raise NodesimError(f"{where}: {key} = {getattr(self, key)!r} must be >= 0 (a noise magnitude)")
            object.__setattr__(self, key, arr)
        for key in ("bias", "bias_temp_coeff"):
            object.__setattr__(self, key, _vec3(f"{where}: {key}", getattr(self, key)))
        for key in ("gm_tau_s", "flicker_tau_min_s", "flicker_tau_max_s"):
            v = getattr(self, key)
            if not (math.isfinite(v) and v > 0.0):
                raise NodesimError(f"{where}: {key} = {v} must be > 0 (a correlation time)")
        if self.flicker_tau_max_s <= self.flicker_tau_min_s:
            raise NodesimError(
                f"{where}: flicker_tau_max_s ({self.flicker_tau_max_s}) must exceed flicker_tau_min_s ({self.flicker_tau_min_s})"
            )
        m = np.asarray(self.misalignment, dtype=float)
        if m.shape != (3, 3) or not np.all(np.isfinite(m)):
            raise NodesimError(f"{where}: misalignment must be a finite 3x3 matrix (got shape {m.shape})")
        cond = np.linalg.cond(m)
        if not cond < MAX_CONDITION:
            raise NodesimError(
                f"{where}: misalignment matrix is not invertible (condition number {cond:.3g}, allowed < {MAX_CONDITION:g})"
            )
        object.__setattr__(self, "misalignment", m)
        if not math.isfinite(self.scale_temp_coeff):
            raise NodesimError(f"{where}: scale_temp_coeff must be finite")

    @property
    def count_limits(self) -> tuple[int, int]:
        info = np.iinfo(ADC_TYPES[self.adc_bits])
        return int(info.min), int(info.max)

    @property
    def lsb(self) -> float:
        """One count in SI units (the quantisation step)."""
        return 1.0 / self.lsb_per_unit

    def deterministic(self, true_input: np.ndarray, temperature_c=None) -> np.ndarray:
        """M (1 + k_s dT) u + b0 + k_b dT, shape of ``true_input`` (..., K, 3)."""
        u = np.asarray(true_input, dtype=float)
        out = u @ self.misalignment.T + self.bias
        if temperature_c is not None:
            dt = (np.asarray(temperature_c, dtype=float) - self.reference_temperature_c)[..., None]
            out = out + self.scale_temp_coeff * dt * (u @ self.misalignment.T) + self.bias_temp_coeff * dt
        return out

    def stochastic(self, rng: np.random.Generator, shape: tuple[int, ...], dt_s: float) -> np.ndarray:
        """Sum of the random error processes, shape (..., K, 3), drawn axis by axis in a fixed order."""
        lead, k = shape[:-2], shape[-2]
        out = np.zeros(shape)
        for axis in range(3):
            s = lead + (k,)
            out[..., axis] = (
                noise.gauss_markov(rng, s, float(self.gm_sigma[axis]), self.gm_tau_s, dt_s)
                + noise.flicker(rng, s, float(self.bias_instability[axis]), dt_s, self.flicker_tau_min_s, self.flicker_tau_max_s)
                + noise.random_walk(rng, s, float(self.rate_random_walk[axis]), dt_s)
                + noise.white(rng, s, float(self.white_density[axis]), dt_s)
            )
        return out

    def quantise(self, value: np.ndarray) -> np.ndarray:
        """Full-scale clipping then rounding to ADC counts (int16 by default)."""
        clipped = np.clip(value, -self.full_scale, self.full_scale)
        lo, hi = self.count_limits
        return np.clip(np.rint(clipped * self.lsb_per_unit), lo, hi).astype(ADC_TYPES[self.adc_bits])

    def measure(self, true_input, rng: np.random.Generator, dt_s: float, temperature_c=None) -> "TriadSamples":
        """Raw counts and engineering-unit output for true inputs sampled every ``dt_s``."""
        u = np.asarray(true_input, dtype=float)
        if u.ndim < 2 or u.shape[-1] != 3:
            raise NodesimError(f"sensor {self.name!r}: true input must have shape (..., K, 3) (got {u.shape})")
        if not dt_s > 0.0:
            raise NodesimError(f"sensor {self.name!r}: sample interval dt_s = {dt_s} must be > 0")
        v = self.deterministic(u, temperature_c) + self.stochastic(rng, u.shape, dt_s)
        counts = self.quantise(v)
        return TriadSamples(counts=counts, value=counts / self.lsb_per_unit)


@dataclass(frozen=True)
class TriadSamples:
    """Sensor output: ``counts`` (int16, what the firmware reads) and ``value`` (SI units)."""

    counts: np.ndarray
    value: np.ndarray


@dataclass(frozen=True)
class ImuSpec:
    """A 6-axis IMU: gyro and accelerometer triads sampled together at ``sample_rate_hz``."""

    name: str
    gyro: TriadSpec
    accel: TriadSpec
    sample_rate_hz: float

    def __post_init__(self):
        if not (math.isfinite(self.sample_rate_hz) and self.sample_rate_hz > 0.0):
            raise NodesimError(f"IMU {self.name!r}: sample_rate_hz = {self.sample_rate_hz} must be > 0")

    @property
    def dt_s(self) -> float:
        return 1.0 / self.sample_rate_hz

    def sample_times(self, duration_s: float, t0_s: float = 0.0) -> np.ndarray:
        """Sample instants k / rate, k = 0 .. floor(duration * rate)."""
        return t0_s + np.arange(int(math.floor(duration_s * self.sample_rate_hz)) + 1) * self.dt_s

    def measure(self, true_rate, true_force, gyro_rng, accel_rng, temperature_c=None):
        """(gyro samples, accel samples) for true rates (rad/s) and specific forces (m/s^2), (..., K, 3)."""
        return (
            self.gyro.measure(true_rate, gyro_rng, self.dt_s, temperature_c),
            self.accel.measure(true_force, accel_rng, self.dt_s, temperature_c),
        )


def _tick_bins(sample_t_s, ticks: np.ndarray, hold_empty: bool, who: str):
    """(first sample index of each tick's bin (K+1,), samples per tick (K,), empty (K,)) for the bins
    (t_{k-1}, t_k] (the first tick's bin as long as the second's); a tick without a sample is an error
    unless ``hold_empty`` (the first tick must still have one)."""
    t = np.asarray(sample_t_s, dtype=float)
    if ticks.size < 2:
        raise NodesimError(f"{who}: need at least two tick times")
    edges = np.concatenate([[ticks[0] - (ticks[1] - ticks[0])], ticks])
    idx = np.searchsorted(t, edges, side="right")  # samples with t <= edge come before idx
    counts = np.diff(idx)
    empty = counts == 0
    if np.any(empty) and (not hold_empty or empty[0]):
        k = int(np.flatnonzero(empty)[0])
        raise NodesimError(f"{who}: firmware tick {k} (t = {ticks[k]:.4g} s) has no sensor sample")
    return idx, counts, empty


def sum_per_tick(sample_t_s: np.ndarray, counts: np.ndarray, tick_t_s: np.ndarray,
                 hold_empty: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """(integer sums (K, C), number of samples (K,)) of the int ADC ``counts`` (N, C) in (t_{k-1}, t_k] for each
    firmware tick k: what the node firmware accumulates from the sensor FIFO between two ticks (the bins of
    :func:`average_per_tick`).  A tick without a sample repeats the previous tick's sum and number where
    ``hold_empty`` (else it is an error), as the averaging repeats the previous mean."""
    ticks = np.asarray(tick_t_s, dtype=float)
    idx, n, empty = _tick_bins(sample_t_s, ticks, hold_empty, "sum_per_tick")
    c = np.asarray(counts, dtype=np.int64)
    full = ~empty
    sums = np.add.reduceat(c[: idx[-1]], idx[:-1][full], axis=0)
    if not empty.any():
        return sums, n.astype(np.int64)
    src = np.maximum.accumulate(np.where(full, np.arange(ticks.size), 0))
    return sums[np.cumsum(full)[src] - 1], n[src].astype(np.int64)


def average_per_tick(sample_t_s: np.ndarray, values: np.ndarray, tick_t_s: np.ndarray, hold_empty: bool = False) -> np.ndarray:
    """Mean of the samples in (t_{k-1}, t_k] for each firmware tick k (sample axis = -2 of ``values``).

    This is the firmware's averaging of every sensor sample received since its last tick.  The first
    tick averages the samples in (t_0 - (t_1 - t_0), t_0].  A tick without a sample raises an error
    (the sensor must be faster than the firmware) unless ``hold_empty``: then it repeats the previous
    tick's mean (the first tick must still have a sample).  Each tick sums its own samples
    (``np.add.reduceat``), so a tick with one sample gets that sample bit for bit.
    """
    ticks = np.asarray(tick_t_s, dtype=float)
    idx, counts, empty = _tick_bins(sample_t_s, ticks, hold_empty, "average_per_tick")
    v = np.asarray(values, dtype=float)
    full = ~empty
    sums = np.add.reduceat(v[..., : idx[-1], :], idx[:-1][full], axis=-2)
    means = sums / counts[full][:, None]
    if not empty.any():
        return means
    src = np.maximum.accumulate(np.where(full, np.arange(ticks.size), 0))  # last tick with samples
    return np.take(means, np.cumsum(full)[src] - 1, axis=-2)
