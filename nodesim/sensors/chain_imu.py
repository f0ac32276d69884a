"""The IMU every chain node reads: MPU6500 3-axis gyro and accelerometer, int16 counts, summed per firmware tick.

Per node n and realization r, sample j (at t_j = j / sample_rate_hz, :func:`~nodesim.sensors.tick_counts.sample_windows`)
and axis i, the noise-free readings in LSB are

    gyro:   mu_j = S_g [(1 + s) T_r omega_j + b_on + b_res [t_j >= t_start] + b_gm,k]     omega_j = (0, 0, theta'(t_j))
    accel:  mu_j = S_a T_r f_j / g0                   f_j = specific force of the tube (thesis eqs 1.1-1.3 frame)

with S_g the gyro sensitivity (131 / 65.5 / 32.8 / 16.4 LSB per deg/s at 250 / 500 / 1000 / 2000 deg/s, MPU-6500
product specification 6.1), S_a the accelerometer's (16384 / 8192 / 4096 / 2048 LSB per g at 2 / 4 / 8 / 16 g,
specification 6.2), s the gyro scale-factor error (thesis table 4.16), b_on the turn-on bias (removed by the static
window), b_res the residual bias after the node's filter start (thesis 4.2.3), b_gm the first-order Gauss-Markov
bias (thesis eqs 3.18-3.20) at the tick rate (held over a tick: tau = 500 s >> 0.53 s), and T_r the node's residual
static misalignment: the sensor frame tilted about x by a and about y by b, T = R_x(a) R_y(b), a, b ~ N(0,
residual_tilt_sigma^2) per node and realization (thesis table 4.20: MPU6500 turn-table calibration, standard
deviation 0.0422 deg).  The gyro error values apply to every gyro axis; the transverse gyros see no true rate (path
curvature rates at drilling speeds are below 1e-5 rad/s).  White noise per sample: sigma = N sqrt(sample_rate) with
N the two-sided density (gyro ARW, accelerometer density), so a tick's mean has sigma N / sqrt(T_tick) as before.
Each reading is quantised to int16, clipped at full scale (counted) and summed per tick
(:mod:`nodesim.sensors.tick_counts`: ``per_sample`` or the direct ``tick_sum`` draw with its fallback).

Random streams (:class:`nodesim.rng.streams.RunStreams`, per node, one generator per realization):
  ``tilt``: a, b (2 normals);
  ``gyro``: the Gauss-Markov drive (K, 3) when its sigma is > 0, then (tick_sum) the tick-sum normals (K, 3);
  ``accel``: (tick_sum) the tick-sum normals (K, 3);
  ``gyro_samples`` / ``accel_samples``: the per-sample normals (n_k, 3) of every tick read per sample, in tick order.
The tick-sum normals of every tick are drawn (used or not), so the fallback of one tick moves no other draw.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import weakref
from dataclasses import dataclass

import numpy as np
from numba import njit

from firmware_model.config import GYRO_SENS_X10

from nodesim.motion.timelines import ChainMotion
from nodesim import threads
from nodesim.rng import pcg64
from nodesim.rng.streams import RunStreams
from nodesim.scenario.schema import Scenario
from nodesim.sensors import tick_counts as tc
from nodesim.units import DEG, G0_M_S2

GYRO_LSB_PER_DEG_S = {fs: x10 / 10.0 for fs, x10 in GYRO_SENS_X10.items()}  # the firmware's table
"""MPU6500 gyro sensitivity [LSB per deg/s] by full-scale range [deg/s] (MPU-6500 product specification 6.1)."""
ACCEL_LSB_PER_G = {2: 16384.0, 4: 8192.0, 8: 4096.0, 16: 2048.0}
"""MPU6500 accelerometer sensitivity [LSB per g] by full-scale range [g] (MPU-6500 product specification 6.2)."""
PER_SAMPLE_CHUNK_NORMALS = 1 << 23
"""Per-sample normals drawn at once (a range of realizations; 64 MB)."""
TICK_SUM_BLOCK = 1024
"""Ticks whose tick-sum normals :func:`_tick_sums` draws at once (2 x 24 kB: they stay in the cache until used)."""


@dataclass(frozen=True)
class ChainImu:
    """The scenario's node IMU (module docstring); rates in rad/s, forces in m/s^2, sigmas per sample."""

    sampling: str
    sample_rate_hz: float
    gyro_full_scale_dps: int
    accel_full_scale_g: int
    gyro_arw_rad_per_sqrt_s: float
    accel_density_m_s2_per_sqrt_hz: float
    scale_factor_error: float
    turn_on_bias_rad_s: float
    residual_bias_rad_s: float
    bias_instability_rad_s: float
    bias_tau_s: float
    tilt_sigma_rad: float

    @classmethod
    def from_scenario(cls, scenario: Scenario) -> "ChainImu":
        s = scenario.sensor
        return cls(
            sampling=s.sampling, sample_rate_hz=s.sample_rate_hz, gyro_full_scale_dps=int(s.gyro_full_scale_dps),
            accel_full_scale_g=int(s.accel_full_scale_g), gyro_arw_rad_per_sqrt_s=s.gyro_arw_deg_per_sqrt_s * DEG,
            accel_density_m_s2_per_sqrt_hz=s.accel_noise_ug_per_sqrt_hz * 1e-6 * G0_M_S2,
            scale_factor_error=s.gyro_scale_factor_error, turn_on_bias_rad_s=s.gyro_turn_on_bias_deg_s * DEG,
            residual_bias_rad_s=s.gyro_residual_bias_deg_s * DEG,
            bias_instability_rad_s=s.gyro_bias_instability_deg_s * DEG, bias_tau_s=s.gyro_bias_tau_s,
            tilt_sigma_rad=s.residual_tilt_sigma_deg * DEG,
        )

    @property
    def gyro_lsb_per_deg_s(self) -> float:
        return GYRO_LSB_PER_DEG_S[self.gyro_full_scale_dps]

    @property
    def accel_lsb_per_g(self) -> float:
        return ACCEL_LSB_PER_G[self.accel_full_scale_g]

    @property
    def gyro_lsb_per_rad_s(self) -> float:
        return self.gyro_lsb_per_deg_s / DEG

    @property
    def accel_lsb_per_m_s2(self) -> float:
        return self.accel_lsb_per_g / G0_M_S2

    @property
    def gyro_sigma_lsb(self) -> float:
        """Per-sample gyro white-noise sigma: ARW sqrt(rate) in LSB."""
        return self.gyro_arw_rad_per_sqrt_s * math.sqrt(self.sample_rate_hz) * self.gyro_lsb_per_rad_s

    @property
    def gyro_white_arw_rad_per_sqrt_s(self) -> float:
        """The white noise the z gyro's counts carry, as an Allan deviation of them would measure it: the ARW and
        the rounding to 1 LSB (uniform, variance q^2 / 12 per sample, q = 1 / S_g) in quadrature,
        N_eff = sqrt(N^2 + q^2 / (12 f_s)).  What the filter is tuned to (Q, and the rate sigma of eq 3.29's R):
        the thesis's table V.1 values are Allan deviations of such quantised MPU6500 readings."""
        q_rad_s = 1.0 / self.gyro_lsb_per_rad_s
        return math.sqrt(self.gyro_arw_rad_per_sqrt_s**2 + q_rad_s**2 / (12.0 * self.sample_rate_hz))

    @property
    def accel_sigma_lsb(self) -> float:
        """Per-sample accelerometer white-noise sigma: N sqrt(rate) in LSB."""
        return self.accel_density_m_s2_per_sqrt_hz * math.sqrt(self.sample_rate_hz) * self.accel_lsb_per_m_s2

    @property
    def gyro_limits(self) -> tuple[int, int]:
        return tc.count_limits(self.gyro_full_scale_dps * self.gyro_lsb_per_deg_s)

    @property
    def accel_limits(self) -> tuple[int, int]:
        return tc.count_limits(self.accel_full_scale_g * self.accel_lsb_per_g)


@dataclass(frozen=True)
class NodeCounts:
    """One node's per-tick count sums in every realization."""

    gyro_counts: np.ndarray  # (R, K, 3) int64
    accel_counts: np.ndarray  # (R, K, 3) int64
    samples: np.ndarray  # (K,) int64
    gyro_clipped_samples: np.ndarray  # (R,) int64, axis readings clipped
    accel_clipped_samples: np.ndarray  # (R,) int64
    true_bias_rad_s: np.ndarray  # (R, K) z-gyro bias at the tick times
    tilt_rad: np.ndarray  # (R, 2) the residual tilt (about x, about y)
    per_sample_ticks: int  # (tick, realization) pairs of either triad read per sample


@njit(cache=True, inline="always")
def _force(inc, azi, yaw):
    """g [sin I cos(A - psi), sin I sin(A - psi), cos I] at one sample (:func:`sensor_force`)."""
    tau = azi - yaw
    si = math.sin(inc)
    return G0_M_S2 * (math.cos(tau) * si), G0_M_S2 * (math.sin(tau) * si), G0_M_S2 * math.cos(inc)


@njit(cache=True, nogil=True)
def _forces(inc, azi, yaw, out) -> None:
    for j in range(inc.size):
        out[j, 0], out[j, 1], out[j, 2] = _force(inc[j], azi[j], yaw[j])


def sensor_force(inclination_rad, azimuth_rad, yaw_rad) -> np.ndarray:
    """Noise-free sensor-frame specific force (..., 3) m/s^2: g [sin I cos(A - psi), sin I sin(A - psi), cos I], the
    third row of :func:`nodesim.sensors.magnetometer.body_to_neu` (:func:`~nodesim.sensors.magnetometer.specific_force_body`)
    without building the matrices (the chain evaluates it at every sample, :class:`SampleTruth`)."""
    inc, azi, yaw = np.broadcast_arrays(*(np.asarray(x, dtype=float) for x in (inclination_rad, azimuth_rad, yaw_rad)))
    out = np.empty((inc.size, 3))
    _forces(np.ascontiguousarray(inc).ravel(), np.ascontiguousarray(azi).ravel(), np.ascontiguousarray(yaw).ravel(),
            out)
    return out.reshape(inc.shape + (3,))


@njit(cache=True, nogil=True)
def _sample_sums(inc, azi, yaw, rate, gyro_lsb, accel_lsb, u_gz, u_a, acc, umax, sums) -> None:
    """One pass over a block of consecutive samples: the truth in LSB (z gyro ``rate`` x ``gyro_lsb``, accelerometer
    :func:`_force` x ``accel_lsb``), written to ``u_gz`` / ``u_a`` where they have room (empty: not kept), the
    prefix sums before each sample (row m of ``sums``: z gyro, accel x, y, z) continued from ``acc`` (the sums
    before the block, left after it; added in sample order, as ``numpy.cumsum`` adds) and the largest |u| per axis
    carried in ``umax`` (z gyro, accel x, y, z)."""
    readings = u_gz.size > 0
    for m in range(inc.size):
        sums[m, 0], sums[m, 1], sums[m, 2], sums[m, 3] = acc[0], acc[1], acc[2], acc[3]
        g = rate[m] * gyro_lsb
        f0, f1, f2 = _force(inc[m], azi[m], yaw[m])
        a0, a1, a2 = f0 * accel_lsb, f1 * accel_lsb, f2 * accel_lsb
        if readings:
            u_gz[m], u_a[m, 0], u_a[m, 1], u_a[m, 2] = g, a0, a1, a2
        acc[0], acc[1], acc[2], acc[3] = acc[0] + g, acc[1] + a0, acc[2] + a1, acc[3] + a2
        umax[0], umax[1] = max(umax[0], abs(g)), max(umax[1], abs(a0))
        umax[2], umax[3] = max(umax[2], abs(a1)), max(umax[3], abs(a2))


def tilt_matrices(tilt_rad: np.ndarray) -> np.ndarray:
    """(R, 3, 3) T = R_x(a) R_y(b) for rows (a, b) of ``tilt_rad``."""
    a, b = tilt_rad[:, 0], tilt_rad[:, 1]
    ca, sa, cb, sb = np.cos(a), np.sin(a), np.cos(b), np.sin(b)
    z, o = np.zeros_like(a), np.ones_like(a)
    rx = np.stack([np.stack([o, z, z], -1), np.stack([z, ca, -sa], -1), np.stack([z, sa, ca], -1)], -2)
    ry = np.stack([np.stack([cb, z, sb], -1), np.stack([z, o, z], -1), np.stack([-sb, z, cb], -1)], -2)
    return rx @ ry


def _first_sample_at_or_after(t_s: float, rate_hz: float) -> int:
    """Smallest j with j / rate >= t (the residual bias applies from there on)."""
    if not math.isfinite(t_s):
        return np.iinfo(np.int64).max if t_s > 0 else np.iinfo(np.int64).min
    j = math.ceil(t_s * rate_hz)
    while (j - 1) / rate_hz >= t_s:
        j -= 1
    while j / rate_hz < t_s:
        j += 1
    return j


class SampleTruth:
    """The noise-free readings (LSB, before tilt, scale factor and bias) on the sample grid j_lo <= j < j_hi (at
    t_j = j / sample_rate_hz: the z gyro the string's spin rate, the accelerometer :func:`sensor_force` of the
    node's attitude) and their prefix sums, so that a tick's sum of the noise-free readings is one difference
    (O(1) per tick, not O(samples)):

        sum_{first_k <= j < first_k + n_k} u_j = U[first_k + n_k] - U[first_k],   U[m] = sum_{j_lo <= j < m} u_j

    (rounding: a few ulp of U, < 1e-4 LSB for a day of 65 Hz samples at full scale), computed block by block
    (:data:`TRUTH_BLOCK_SAMPLES` samples: times, rates and attitudes of a block, not of the run) by one compiled
    pass (:func:`_sample_sums`).  One per run where every node has the same attitude (``shared``: the motion's
    :attr:`~nodesim.motion.timelines.ChainMotion.shared_attitude`, the lab's rigid string or a drilling string in a
    straight hole, :func:`nodesim.chain.sensing.shared_truth`), else one per node (its ``attitude``).

    Without ``keep_readings`` it keeps only the prefix sums (and the maxima): half the memory (32 bytes a sample
    instead of 64), and :meth:`slice`, which only a tick drawn per sample needs, computes the readings of the samples
    asked for again, the same values (each sample's reading depends on its own time only: tested)."""

    def __init__(self, imu: ChainImu, motion: ChainMotion, j_lo: int, j_hi: int, node_index: int = 0,
                 shared: bool = False, keep_readings: bool = True):
        self.j_lo, self.j_hi = j_lo, j_hi
        # what :meth:`slice` needs to compute readings again (the motion by weak reference: the run holds it, and a
        # truth cached between runs, :func:`nodesim.chain.sensing.shared_truth`, must not keep it alive)
        self._imu, self._motion, self._node_index, self._shared = imu, weakref.ref(motion), node_index, shared
        S = j_hi - j_lo
        self._sums = np.empty((S + 1, 4))  # U of the z gyro and the accelerometer's x, y, z, side by side
        self.u_gz, self.u_a = (np.empty(S), np.empty((S, 3))) if keep_readings else (None, None)
        acc, umax = np.zeros(4), np.zeros(4)
        none = (np.empty(0), np.empty((0, 3)))  # the readings' place in a block where they are not kept
        for a in range(j_lo, j_hi, TRUTH_BLOCK_SAMPLES):
            b = min(j_hi, a + TRUTH_BLOCK_SAMPLES)
            t_j = np.arange(a, b, dtype=np.int64) / imu.sample_rate_hz
            rate = np.ascontiguousarray(motion.rotation.rate_rad_s(t_j), dtype=float)
            att = motion.shared_attitude(t_j) if shared else motion.attitude(node_index, t_j)
            inc, azi, yaw = (np.ascontiguousarray(np.broadcast_to(x, t_j.shape), dtype=float)
                             for x in (att.inclination_rad, att.azimuth_rad, att.yaw_rad))
            u_gz, u_a = (self.u_gz[a - j_lo:b - j_lo], self.u_a[a - j_lo:b - j_lo]) if keep_readings else none
            _sample_sums(inc, azi, yaw, rate, imu.gyro_lsb_per_rad_s, imu.accel_lsb_per_m_s2, u_gz, u_a, acc, umax,
                         self._sums[a - j_lo:b - j_lo])
        self._sums[S] = acc  # U[j_hi]: after the last sample
        self.umax = (np.array([0.0, 0.0, umax[0]]), umax[1:].copy())

    def covers(self, a: int, b: int) -> bool:
        return self.j_lo <= a and b <= self.j_hi

    def slice(self, a: int, b: int) -> tuple[np.ndarray, np.ndarray]:
        """(z-gyro (S,), accelerometer (S, 3)) truth of the samples a <= j < b (views; computed again where the
        readings were not kept)."""
        if self.u_gz is None:
            again = SampleTruth(self._imu, self._motion(), a, b, self._node_index, self._shared)
            return again.u_gz, again.u_a
        return self.u_gz[a - self.j_lo:b - self.j_lo], self.u_a[a - self.j_lo:b - self.j_lo]

    def tick_sums(self, first: np.ndarray, n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(z-gyro (K,), accelerometer (K, 3)) sums of the truth over each tick's samples first_k .. first_k + n_k - 1
        (:func:`_window_sums`: the differences of the prefix sums, the same subtraction as fancy indexing,
        without its index and gathered temporaries)."""
        K = first.size
        out_gz, out_a = np.empty(K), np.empty((K, 3))
        _window_sums(self._sums, np.ascontiguousarray(first, dtype=np.int64) - self.j_lo,
                     np.ascontiguousarray(n, dtype=np.int64), out_gz, out_a)
        return out_gz, out_a


TRUTH_BLOCK_SAMPLES = 1 << 16
"""Samples :class:`SampleTruth` computes at a time: ~3 MB of times, attitudes and rates, not the run's (the drilling
day's shared truth, 5.6 M samples, 180 MB, built in 0.4-0.9 s instead of 1.3-1.5 s and at a peak of 180 MB instead
of 580 MB: the whole run's temporaries are no longer made; 2026-12-05)."""


@njit(cache=True, nogil=True)
def _window_sums(sums, a, n, out_gz, out_a) -> None:
    """``out_gz[k] = U[a_k + n_k] - U[a_k]`` for the z gyro, ``out_a[k]`` likewise per accelerometer axis: the sums over
    windows of :class:`SampleTruth`'s prefix sums ``sums`` (rows: z gyro, accel x, y, z; ``a`` relative to its first
    sample, in range).  A node's windows are consecutive (a_(k+1) = a_k + n_k): the prefix sums at a window's end
    are kept for the next window's start, so each row is read once, not twice, and a row's four sums are side by
    side (one cache line, not two arrays' lines): memory, not arithmetic, is the cost here (a node of the drilling
    day, 163 k ticks: min / median 2.2 / 2.6 ms against 2.6-3.1 / 3.3-3.5 ms with the gyro's and the
    accelerometer's sums in two arrays, 2026-12-05)."""
    end = -1
    g_hi, x_hi, y_hi, z_hi = 0.0, 0.0, 0.0, 0.0
    for k in range(a.size):
        lo, hi = a[k], a[k] + n[k]
        if lo == end:
            g_lo, x_lo, y_lo, z_lo = g_hi, x_hi, y_hi, z_hi
        else:
            g_lo, x_lo, y_lo, z_lo = sums[lo, 0], sums[lo, 1], sums[lo, 2], sums[lo, 3]
        g_hi, x_hi, y_hi, z_hi = sums[hi, 0], sums[hi, 1], sums[hi, 2], sums[hi, 3]
        out_gz[k] = g_hi - g_lo
        out_a[k, 0], out_a[k, 1], out_a[k, 2] = x_hi - x_lo, y_hi - y_lo, z_hi - z_lo
        end = hi


def node_counts(imu: ChainImu, motion: ChainMotion, streams: RunStreams, node_index: int, t_s: np.ndarray,
                dt_s: float, realizations: int, truth: SampleTruth | None = None) -> NodeCounts:
    """Count sums of node ``node_index`` (0-based) at its true tick times ``t_s`` (module docstring); ``truth`` the
    run's shared per-sample truth where the attitude is the same for every node."""
    R, K = realizations, t_s.size
    first, n = tc.sample_windows(t_s, dt_s, imu.sample_rate_hz)
    j0, S = int(first[0]), int(n.sum())  # the node's samples are consecutive
    starts = np.concatenate([[0], np.cumsum(n)[:-1]]).astype(np.int64)
    if truth is None or not truth.covers(j0, j0 + S):
        truth = SampleTruth(imu, motion, j0, j0 + S, node_index)
    readings = functools.cache(lambda: truth.slice(j0, j0 + S))  # (u_gz, u_a): only a tick drawn per sample reads them
    tilt = streams.sensor_normals(R, node_index, "tilt", 2) * imu.tilt_sigma_rad
    T = tilt_matrices(tilt)
    # gyro bias (LSB): turn-on + residual after the filter start (from sample j_start on) + Gauss-Markov per tick
    timeline = motion.timelines[node_index]
    j_start = _first_sample_at_or_after(timeline.filter_start_s, imu.sample_rate_hz)
    n_after = np.clip(first + n - j_start, 0, n)
    sg = imu.gyro_lsb_per_rad_s
    b_on, b_res = imu.turn_on_bias_rad_s * sg, imu.residual_bias_rad_s * sg
    phi = math.exp(-dt_s / imu.bias_tau_s)
    gm = (imu.bias_instability_rad_s * sg, imu.bias_instability_rad_s * sg * math.sqrt(1.0 - phi * phi), phi)
    g_states = streams.sensor_states(R, node_index, "gyro")  # the Gauss-Markov drive, then the tick-sum normals
    gm_z = np.empty((R, K))  # the z axis' Gauss-Markov bias [LSB]
    gain = 1.0 + imu.scale_factor_error
    g_lo, g_hi = imu.gyro_limits
    a_lo, a_hi = imu.accel_limits
    if imu.sampling == "tick_sum":
        # tick sums of the noise-free readings; a bound on each tick's largest |mu| first from the largest |u| of
        # the grid, only where that bound fails from the per-tick maxima (the draws do not depend on the bound)
        usum_gz, usum_a = truth.tick_sums(first, n)
        gyro, accel = np.empty((R, K, 3), np.int64), np.empty((R, K, 3), np.int64)
        g_sel, a_sel = np.empty((R, K), np.bool_), np.empty((R, K), np.bool_)
        a_states = streams.sensor_states(R, node_index, "accel")
        sums = (usum_gz, usum_a, np.ascontiguousarray(T), gain, b_on, b_res, *gm, n.astype(float), n_after.astype(float),
                imu.gyro_sigma_lsb, imu.accel_sigma_lsb, g_lo, g_hi, a_lo, a_hi)

        def draw(umax_gz: np.ndarray, umax_a: np.ndarray) -> None:  # ranges of realizations on threads
            zg, za = g_states.copy(), a_states.copy()  # a second draw reads the same normals
            threads.map_chunks(lambda r0, r1: _tick_sums(umax_gz, umax_a, *sums, zg, za, gyro, accel, g_sel, a_sel,
                                                         gm_z, r0, r1), R)
        draw(np.broadcast_to(truth.umax[0][2], (K,)), np.broadcast_to(truth.umax[1], (K, 3)))  # views, no copies
        if g_sel.any() or a_sel.any():
            draw(np.maximum.reduceat(np.abs(readings()[0]), starts),
                 np.ascontiguousarray(np.maximum.reduceat(np.abs(readings()[1]), starts, axis=0)))
    else:
        g_sel = a_sel = np.ones((R, K), dtype=bool)
        gyro, accel = np.zeros((R, K, 3), np.int64), np.zeros((R, K, 3), np.int64)
        threads.map_chunks(lambda r0, r1: _gauss_markov_z(g_states.copy(), *gm, gm_z, r0, r1), R)
    # turn-on + residual + Gauss-Markov [rad/s], in gm_z's memory (x + y == y + x in floating point: the same bits
    # as the sum in that order, without two more (R, K) arrays)
    true_bias = np.divide(gm_z, sg, out=gm_z)
    true_bias += imu.turn_on_bias_rad_s + imu.residual_bias_rad_s * (t_s >= timeline.filter_start_s)

    def gyro_mu(r: int, idx: np.ndarray, ticks: np.ndarray) -> np.ndarray:
        after = (j0 + idx >= j_start)[:, None]
        u = np.zeros((idx.size, 3))
        u[:, 2] = readings()[0][idx]
        return gain * (u @ T[r].T) + b_on + _gauss_markov_bias(g_states[r].copy(), *gm, K)[ticks] + b_res * after

    def accel_mu(r: int, idx: np.ndarray, ticks: np.ndarray) -> np.ndarray:
        return readings()[1][idx] @ T[r].T

    g_clip = _per_sample(gyro, g_sel, gyro_mu, imu.gyro_sigma_lsb, g_lo, g_hi, starts, n, streams, node_index,
                         "gyro_samples")
    a_clip = _per_sample(accel, a_sel, accel_mu, imu.accel_sigma_lsb, a_lo, a_hi, starts, n, streams, node_index,
                         "accel_samples")
    return NodeCounts(gyro, accel, n.astype(np.int64), g_clip, a_clip, true_bias, tilt,
                      int(g_sel.sum() + a_sel.sum()))


@njit(cache=True, inline="always")
def _gauss_markov_draw(hi, lo, inc_hi, inc_lo, sigma, drive_sigma, phi, out):
    """``out[k, i]`` (K, 3): the first-order Gauss-Markov bias of axis i at tick k, driven by the next 3 K normals
    of the stream at state (hi, lo, inc_hi, inc_lo), normal 3 k + i: x_0 = sigma w_0, x_k = phi x_(k-1) +
    sigma sqrt(1 - phi^2) w_k (``drive_sigma``; exact discretisation, thesis eqs 3.18-3.20; the recursion of
    :func:`nodesim.sensors.noise.gauss_markov_from_normals`); zero, drawing nothing, when sigma is 0.  Returns
    the new (hi, lo)."""
    if sigma == 0.0:
        out[:] = 0.0
        return hi, lo
    for k in range(out.shape[0]):
        for i in range(3):
            w, hi, lo = pcg64.normal(hi, lo, inc_hi, inc_lo)
            out[k, i] = sigma * w if k == 0 else w * drive_sigma + phi * out[k - 1, i]
    return hi, lo


@njit(cache=True)
def _gauss_markov_bias(state, sigma, drive_sigma, phi, K):
    """(K, 3) :func:`_gauss_markov_draw` of one realization's "gyro" stream at PCG64 ``state`` (4,)."""
    out = np.empty((K, 3))
    _gauss_markov_draw(state[0], state[1], state[2], state[3], sigma, drive_sigma, phi, out)
    return out


@njit(cache=True, nogil=True)
def _gauss_markov_z(states, sigma, drive_sigma, phi, gm_z, r_first, r_end) -> None:
    """``gm_z[r]`` (K,): the z axis of :func:`_gauss_markov_draw` for realizations ``r_first`` .. ``r_end - 1``."""
    scratch = np.empty((gm_z.shape[1], 3))
    for r in range(r_first, r_end):
        _gauss_markov_draw(states[r, 0], states[r, 1], states[r, 2], states[r, 3], sigma, drive_sigma, phi, scratch)
        gm_z[r] = scratch[:, 2]


@njit(cache=True, nogil=True)
def _tick_sums(umax_gz, umax_a, usum_gz, usum_a, T, gain, b_on, b_res, gm_sigma, gm_drive, gm_phi, n, n_after,
               sigma_g, sigma_a, g_lo, g_hi, a_lo, a_hi, z_g, z_a, gyro, accel, g_sel, a_sel, gm_z, r_first,
               r_end) -> None:
    """The direct tick-sum draws of every (realization r, tick k, axis i) and which ticks must be read per sample
    (:mod:`nodesim.sensors.tick_counts`), from the tick sums of the noise-free z-gyro (``usum_gz`` (K,)) and
    accelerometer (``usum_a`` (K, 3)) readings before tilt, bias and scale factor, and bounds ``umax_*`` on their
    largest magnitude in each tick:

        mean_g = gain (T_r u_g)_i + n_k (b_on + b_gm,rki) + n_after,k b_res     mean_a = (T_r u_a)_i
        bound_g = |gain| (|T_r| umax_g)_i + max(|b_on + b_gm|, |b_on + b_res + b_gm|)   bound_a = (|T_r| umax_a)_i

    (u_g = (0, 0, usum_gz)); a tick is drawn directly while every axis' bound is valid (``valid_one``); the sum
    round_he(mean + spread_k z), spread_k = sqrt(n_k (sigma^2 + 1/12)) (:func:`~.tick_counts.draw_one`, its spread
    once per tick).  The
    normals z, in order 3 k + i: realization r's "gyro" stream (``z_g``, PCG64 states) after the Gauss-Markov
    drive b_gm (:func:`_gauss_markov_draw`; its z axis into ``gm_z``) and its "accel" stream (``z_a``), advanced
    in place.  Realizations ``r_first`` .. ``r_end - 1``.  A block of TICK_SUM_BLOCK ticks' normals is drawn
    first, both streams in one tight loop (:func:`_two_streams_normals`), then used: ~20 % faster than drawing
    them inside the loop below (the generator's code and the arithmetic then share registers and branches), the
    same numbers; a block, not the realization's 6 K normals at once, so that they are still in the cache when
    read.  A block's draws go gyro, then accelerometer, each in a loop of its own, and which ticks are valid is
    found after them (:func:`_direct_invalid`): the batched Monte Carlo's nodes (R = 1000, K = 229) draw ~30 %
    faster and the drilling day's (R = 1, K ~ 150 k) ~45 % faster than with one loop doing all three (the same
    numbers)."""
    K = gyro.shape[1]
    spread_g, spread_a = np.empty(K), np.empty(K)
    for k in range(K):
        spread_g[k], spread_a[k] = tc.draw_spread(n[k], sigma_g), tc.draw_spread(n[k], sigma_a)
    gm = np.empty((K, 3))
    B = max(1, min(K, TICK_SUM_BLOCK))
    w_g, w_a = np.empty(3 * B), np.empty(3 * B)  # a block of ticks' normals, in stream order 3 k + i
    for r in range(r_first, r_end):
        g_hi_s, g_lo_s, g_inc_hi, g_inc_lo = z_g[r, 0], z_g[r, 1], z_g[r, 2], z_g[r, 3]
        a_hi_s, a_lo_s, a_inc_hi, a_inc_lo = z_a[r, 0], z_a[r, 1], z_a[r, 2], z_a[r, 3]
        g_hi_s, g_lo_s = _gauss_markov_draw(g_hi_s, g_lo_s, g_inc_hi, g_inc_lo, gm_sigma, gm_drive, gm_phi, gm)
        gm_z[r] = gm[:, 2]
        for k0 in range(0, K, B):
            k1 = min(k0 + B, K)
            g_hi_s, g_lo_s, a_hi_s, a_lo_s = _two_streams_normals(g_hi_s, g_lo_s, g_inc_hi, g_inc_lo, a_hi_s, a_lo_s,
                                                                  a_inc_hi, a_inc_lo, w_g[:3 * (k1 - k0)],
                                                                  w_a[:3 * (k1 - k0)])
            for k in range(k0, k1):
                for i in range(3):
                    mean_g = gain * (T[r, i, 2] * usum_gz[k]) + (n[k] * (b_on + gm[k, i]) + n_after[k] * b_res)
                    gyro[r, k, i] = tc.draw_with_spread(mean_g, spread_g[k], w_g[3 * (k - k0) + i])
            for k in range(k0, k1):
                for i in range(3):
                    mean_a = T[r, i, 0] * usum_a[k, 0] + T[r, i, 1] * usum_a[k, 1] + T[r, i, 2] * usum_a[k, 2]
                    accel[r, k, i] = tc.draw_with_spread(mean_a, spread_a[k], w_a[3 * (k - k0) + i])
        _direct_invalid(umax_gz, umax_a, T[r], gain, b_on, b_res, gm, sigma_g, sigma_a, g_lo, g_hi, a_lo, a_hi,
                        g_sel[r], a_sel[r])
        z_g[r, 0], z_g[r, 1], z_a[r, 0], z_a[r, 1] = g_hi_s, g_lo_s, a_hi_s, a_lo_s


@njit(cache=True, _nrt=False, nogil=True)
def _direct_invalid(umax_gz, umax_a, T, gain, b_on, b_res, gm, sigma_g, sigma_a, g_lo, g_hi, a_lo, a_hi, g_sel,
                    a_sel) -> None:
    """``g_sel[k]``, ``a_sel[k]`` (K,) for every tick k of one realization (tilt ``T`` (3, 3), Gauss-Markov bias
    ``gm`` (K, 3)): whether some axis' bound fails (:func:`_tick_sums`), so that the tick must be read per
    sample.  A function of its own, not inlined: inlined after the draws' loop nest, the day's long nodes drew
    ~45 % slower."""
    for k in range(gm.shape[0]):
        ok_g, ok_a = True, True
        for i in range(3):
            t0, t1, t2 = abs(T[i, 0]), abs(T[i, 1]), abs(T[i, 2])
            b_max = max(abs(b_on + gm[k, i]), abs(b_on + b_res + gm[k, i]))
            ok_g &= tc.valid_one(abs(gain) * (t2 * umax_gz[k]) + b_max, sigma_g, g_lo, g_hi)
            ok_a &= tc.valid_one(t0 * umax_a[k, 0] + t1 * umax_a[k, 1] + t2 * umax_a[k, 2], sigma_a, a_lo, a_hi)
        g_sel[k], a_sel[k] = not ok_g, not ok_a


@njit(cache=True, inline="always")
def _two_streams_normals(g_hi, g_lo, g_inc_hi, g_inc_lo, a_hi, a_lo, a_inc_hi, a_inc_lo, w_g, w_a):
    """``w_g``, ``w_a`` (M,) = the next M normals of two PCG64 streams (states (hi, lo, inc_hi, inc_lo)), drawn in
    turn so that the two generators' steps overlap; returns their new (g_hi, g_lo, a_hi, a_lo)."""
    for j in range(w_g.size):
        w_g[j], g_hi, g_lo = pcg64.normal(g_hi, g_lo, g_inc_hi, g_inc_lo)
        w_a[j], a_hi, a_lo = pcg64.normal(a_hi, a_lo, a_inc_hi, a_inc_lo)
    return g_hi, g_lo, a_hi, a_lo


def _per_sample(out: np.ndarray, sel: np.ndarray, mu_of, sigma_lsb: float, lo: int, hi: int, starts: np.ndarray,
                n: np.ndarray, streams: RunStreams, node_index: int, stream: str) -> np.ndarray:
    """Overwrite the selected ticks (sel (R, K)) of ``out`` (R, K, 3) with per-sample sums; clipped readings (R,)."""
    R = sel.shape[0]
    clipped = np.zeros(R, dtype=np.int64)
    if not sel.any():  # every tick drawn directly (tick_sum's common case): no pass over (R, K), no loop over R
        return clipped
    need = 3 * (sel * n[None, :]).sum(axis=1)  # normals per realization
    r0 = 0
    while r0 < R:
        if need[r0] == 0:
            r0 += 1
            continue
        r1 = r0 + 1  # a range of realizations whose normals fit in one chunk
        while r1 < R and (r1 + 1 - r0) * max(int(need[r0:r1 + 1].max()), 1) <= PER_SAMPLE_CHUNK_NORMALS:
            r1 += 1
        sub = dataclasses.replace(streams, first_realization=streams.first_realization + r0)
        w = sub.sensor_normals(r1 - r0, node_index, stream, int(need[r0:r1].max()))
        for r in range(r0, r1):
            ks = np.flatnonzero(sel[r])
            if ks.size == 0:
                continue
            nk = n[ks]
            m = int(nk.sum())
            offsets = np.concatenate([[0], np.cumsum(nk)[:-1]])
            idx = np.repeat(starts[ks] - offsets, nk) + np.arange(m)
            ticks = np.repeat(ks, nk)
            sums, clip = tc.per_sample_sums(mu_of(r, idx, ticks), sigma_lsb, w[r - r0, :3 * m].reshape(m, 3), nk, lo, hi)
            out[r, ks] = sums
            clipped[r] = int(clip.sum())
        r0 = r1
    return clipped
