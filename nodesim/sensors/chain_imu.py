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
  ``gyro_bias``: the Gauss-Markov drive (K, 3) when its sigma is > 0;
  ``gyro``: (tick_sum) the tick-sum normals (K, 3);
  ``accel``: (tick_sum) the tick-sum normals (K, 3);
  ``gyro_samples`` / ``accel_samples``: the per-sample normals (n_k, 3) of every tick read per sample, in tick order.
The tick-sum normals of every tick are drawn (used or not), so the fallback of one tick moves no other draw.
"""

from __future__ import annotations

import functools
import math
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
from nodesim.sensors.sample_truth import SampleTruth
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


def node_counts(imu: ChainImu, motion: ChainMotion, streams: RunStreams, node_index: int, t_s: np.ndarray,
                dt_s: float, realizations: int, truth: SampleTruth | None = None) -> NodeCounts:
    """Count sums of node ``node_index`` (0-based) at its true tick times ``t_s`` (module docstring); ``truth`` the
    run's shared per-sample truth where the attitude is the same for every node.  All ticks in one window of
    :class:`NodeImuStream`."""
    return NodeImuStream(imu, motion, streams, node_index, t_s, dt_s, realizations, truth).counts(0, t_s.size, truth)


class NodeImuStream:
    """Node ``node_index``'s count sums (module docstring) window by window of its ticks: :meth:`counts` for
    consecutive windows [0, k_1), [k_1, k_2), ... gives, tick for tick, the numbers of one window over all ticks
    (tests/nodesim/sensors/test_chain_imu.py), so that a run need not hold a node's readings of the whole run.

    Carried from window to window, per realization: the PCG64 states of the streams (module docstring), the
    Gauss-Markov bias of the last tick (x_k = phi x_(k-1) + sigma sqrt(1 - phi^2) w_k goes on from it), and, for a
    node whose samples the shared truth does not cover, its own truth's prefix sums (:class:`SampleTruth`
    ``start_sums``).  The Gauss-Markov drive has a stream of its own ("gyro_bias"), so a window's tick-sum normals
    go on in the "gyro" stream from where the window before left it.  (Until 2026-12-06 the drive came first in the
    "gyro" stream, and a node read in more than one window found where its tick-sum normals started by drawing and
    dropping its whole drive, 3 K normals: ~3 s of CPU for the drilling day, beside phase 1.)  Which
    ticks fall back to per-sample sums does not depend on the window: the first draw's bound (the truth's largest
    |u|) only decides whether the per-tick bounds are looked at, and those decide (:func:`tick_counts.valid_one` is
    monotone in the bound)."""

    def __init__(self, imu: ChainImu, motion: ChainMotion, streams: RunStreams, node_index: int, t_s: np.ndarray,
                 dt_s: float, realizations: int, shared: SampleTruth | None = None):
        R = realizations
        self.imu, self.motion, self.node_index, self.t_s, self.dt_s, self.R = imu, motion, node_index, t_s, dt_s, R
        self.tilt = streams.sensor_normals(R, node_index, "tilt", 2) * imu.tilt_sigma_rad
        self.T = np.ascontiguousarray(tilt_matrices(self.tilt))
        # gyro bias (LSB): turn-on + residual after the filter start (from sample j_start on) + Gauss-Markov per tick
        self.filter_start_s = motion.timelines[node_index].filter_start_s
        self.j_start = _first_sample_at_or_after(self.filter_start_s, imu.sample_rate_hz)
        sg = imu.gyro_lsb_per_rad_s
        self.b_on, self.b_res = imu.turn_on_bias_rad_s * sg, imu.residual_bias_rad_s * sg
        phi = math.exp(-dt_s / imu.bias_tau_s)
        self.gm = (imu.bias_instability_rad_s * sg, imu.bias_instability_rad_s * sg * math.sqrt(1.0 - phi * phi), phi)
        self.z_gm = streams.sensor_states(R, node_index, "gyro_bias")  # the Gauss-Markov drive
        self.z_g = streams.sensor_states(R, node_index, "gyro")  # the tick-sum normals
        self.z_a = streams.sensor_states(R, node_index, "accel")
        self.streams, self.z_samples = streams, {}  # the per-sample streams' states, made when first drawn from
        self.gm_last = np.zeros((R, 3))  # the Gauss-Markov bias of the last tick read
        self.k_next = 0
        j0, j_end = _sample_span(t_s, dt_s, imu.sample_rate_hz)
        self.own = shared is None or not shared.covers(j0, j_end)  # reads a truth of its own, window by window
        self.own_sums = np.zeros(4)

    def counts(self, k0: int, k1: int, truth: SampleTruth | None = None) -> NodeCounts:
        """The count sums of ticks ``k0`` .. ``k1 - 1`` (the window after the last one read), arrays over those
        ticks; ``truth`` the shared truth covering their samples (read unless the node reads its own)."""
        if k0 != self.k_next or not k0 < k1 <= self.t_s.size:
            raise ValueError(f"node {self.node_index}: ticks [{k0}, {k1}) do not follow tick {self.k_next} "
                             f"(of {self.t_s.size})")
        self.k_next = k1
        imu, R, K = self.imu, self.R, k1 - k0
        t_s = self.t_s[k0:k1]
        first, n = tc.sample_windows(self.t_s[max(k0 - 1, 0):k1], self.dt_s, imu.sample_rate_hz)
        first, n = (first[1:], n[1:]) if k0 > 0 else (first, n)  # tick k0 - 1 only gives tick k0's first sample
        j0, S = int(first[0]), int(n.sum())  # the window's samples are consecutive
        starts = functools.cache(lambda: np.concatenate([[0], np.cumsum(n)[:-1]]).astype(np.int64))  # only a tick
        # drawn per sample reads them (each tick's first sample in the window)
        if self.own:
            truth = SampleTruth(imu, self.motion, j0, j0 + S, self.node_index, start_sums=self.own_sums)
            self.own_sums = truth.end_sums
        elif truth is None or not truth.covers(j0, j0 + S):
            raise ValueError(f"node {self.node_index}: the shared truth does not cover samples [{j0}, {j0 + S})")
        readings = functools.cache(lambda: truth.slice(j0, j0 + S))  # (u_gz, u_a): only a tick drawn per sample reads them
        gm_start = (self.z_gm.copy(), self.gm_last.copy(), k0 == 0)  # the window's drive: per-sample ticks draw it again
        gm_z = np.empty((R, K))  # the z axis' Gauss-Markov bias [LSB]
        gain, T = 1.0 + imu.scale_factor_error, self.T
        g_lo, g_hi = imu.gyro_limits
        a_lo, a_hi = imu.accel_limits
        if imu.sampling == "tick_sum":
            # tick sums of the noise-free readings; a bound on each tick's largest |mu| first from the largest |u| of
            # the truth, only where that bound fails from the per-tick maxima (the draws do not depend on the bound)
            usum_gz, usum_a = truth.tick_sums(first, n)
            gyro, accel = np.empty((R, K, 3), np.int64), np.empty((R, K, 3), np.int64)
            g_sel, a_sel = np.empty((R, K), np.bool_), np.empty((R, K), np.bool_)
            sums = (usum_gz, usum_a, T, gain, self.b_on, self.b_res, *self.gm, *_sample_counts(first, n, self.j_start),
                    imu.gyro_sigma_lsb, imu.accel_sigma_lsb, g_lo, g_hi, a_lo, a_hi)

            def draw(umax_gz: np.ndarray, umax_a: np.ndarray) -> tuple:  # ranges of realizations on threads
                z = (self.z_gm.copy(), self.z_g.copy(), self.z_a.copy(), self.gm_last.copy())
                threads.map_chunks(lambda r0, r1: _tick_sums(umax_gz, umax_a, *sums, *z, k0 == 0, gyro, accel,
                                                             g_sel, a_sel, gm_z, r0, r1), R)
                return z  # a second draw reads the same normals: the streams advance from the last one
            z = draw(np.broadcast_to(truth.umax[0][2], (K,)), np.broadcast_to(truth.umax[1], (K, 3)))  # views
            if g_sel.any() or a_sel.any():
                z = draw(np.maximum.reduceat(np.abs(readings()[0]), starts()),
                         np.ascontiguousarray(np.maximum.reduceat(np.abs(readings()[1]), starts(), axis=0)))
            self.z_gm, self.z_g, self.z_a, self.gm_last = z
        else:
            g_sel = a_sel = np.ones((R, K), dtype=bool)
            gyro, accel = np.zeros((R, K, 3), np.int64), np.zeros((R, K, 3), np.int64)
            threads.map_chunks(lambda r0, r1: _gauss_markov_z(self.z_gm, *self.gm, self.gm_last, k0 == 0, gm_z, r0, r1),
                               R)
        # turn-on + residual + Gauss-Markov [rad/s], in gm_z's memory (x + y == y + x in floating point: the same bits
        # as the sum in that order, without two more (R, K) arrays)
        true_bias = np.divide(gm_z, imu.gyro_lsb_per_rad_s, out=gm_z)
        true_bias += imu.turn_on_bias_rad_s + imu.residual_bias_rad_s * (t_s >= self.filter_start_s)
        b_on, b_res, j_start = self.b_on, self.b_res, self.j_start

        def gyro_mu(r: int, idx: np.ndarray, ticks: np.ndarray) -> np.ndarray:
            after = (j0 + idx >= j_start)[:, None]
            u = np.zeros((idx.size, 3))
            u[:, 2] = readings()[0][idx]
            drive = _gauss_markov_bias(gm_start[0][r].copy(), *self.gm, gm_start[1][r], gm_start[2], K)
            return gain * (u @ T[r].T) + b_on + drive[ticks] + b_res * after

        def accel_mu(r: int, idx: np.ndarray, ticks: np.ndarray) -> np.ndarray:
            return readings()[1][idx] @ T[r].T

        g_clip = _per_sample(gyro, g_sel, gyro_mu, imu.gyro_sigma_lsb, g_lo, g_hi, starts, n,
                             lambda: self._sample_states("gyro_samples"))
        a_clip = _per_sample(accel, a_sel, accel_mu, imu.accel_sigma_lsb, a_lo, a_hi, starts, n,
                             lambda: self._sample_states("accel_samples"))
        return NodeCounts(gyro, accel, n.astype(np.int64), g_clip, a_clip, true_bias, self.tilt,
                          int(g_sel.sum() + a_sel.sum()))

    def _sample_states(self, stream: str) -> np.ndarray:
        """(R, 4): the PCG64 states of the per-sample stream ``stream`` where its next draw is (made at the first)."""
        if stream not in self.z_samples:
            self.z_samples[stream] = self.streams.sensor_states(self.R, self.node_index, stream)
        return self.z_samples[stream]


@njit(cache=True, _nrt=False, nogil=True)
def _fill_sample_counts(first, n, j_start, n_f, n_after_f) -> None:
    for k in range(n.size):
        n_f[k] = n[k]
        n_after_f[k] = min(max(first[k] + n[k] - j_start, 0), n[k])


def _sample_counts(first: np.ndarray, n: np.ndarray, j_start: int) -> tuple[np.ndarray, np.ndarray]:
    """(n_k, n_after,k) as floats (:func:`_tick_sums`): each tick's samples and those of them at or after sample
    ``j_start`` (the residual bias's start), clip(first_k + n_k - j_start, 0, n_k), in one compiled pass instead of numpy's
    clip and two conversions (~0.2 ms a node's 4-hour window of ~27 k ticks in the drilling day's first 8 h, line by
    line, 2026-12-06)."""
    n_f, n_after_f = np.empty(n.size), np.empty(n.size)
    _fill_sample_counts(first, n, np.int64(j_start), n_f, n_after_f)
    return n_f, n_after_f


def _sample_span(t_s: np.ndarray, dt_s: float, rate_hz: float) -> tuple[int, int]:
    """(first, end) of the samples the ticks ``t_s`` read (:func:`tick_counts.sample_windows` of the first tick and of
    the last two: the same floors as over all ticks)."""
    first = tc.sample_windows(t_s[:1], dt_s, rate_hz)[0]
    f, n = tc.sample_windows(t_s[-2:], dt_s, rate_hz)
    return int(first[0]), int(f[-1] + n[-1])


@njit(cache=True, inline="always")
def _gauss_markov_draw(hi, lo, inc_hi, inc_lo, sigma, drive_sigma, phi, prev, first, out):
    """``out[k, i]`` (K, 3): the first-order Gauss-Markov bias of axis i at tick k, driven by the next 3 K normals
    of the stream at state (hi, lo, inc_hi, inc_lo), normal 3 k + i: x_0 = sigma w_0 at the node's first tick
    (``first``; else x_0 = phi prev_i + ..., going on from the bias ``prev`` (3,) of the tick before), x_k =
    phi x_(k-1) + sigma sqrt(1 - phi^2) w_k (``drive_sigma``; exact discretisation, thesis eqs 3.18-3.20; the
    recursion of :func:`nodesim.sensors.noise.gauss_markov_from_normals`); zero, drawing nothing, when sigma is 0.
    Returns the new (hi, lo)."""
    if sigma == 0.0:
        out[:] = 0.0
        return hi, lo
    for k in range(out.shape[0]):
        for i in range(3):
            w, hi, lo = pcg64.normal(hi, lo, inc_hi, inc_lo)
            if k == 0:
                out[k, i] = sigma * w if first else w * drive_sigma + phi * prev[i]
            else:
                out[k, i] = w * drive_sigma + phi * out[k - 1, i]
    return hi, lo


@njit(cache=True)
def _gauss_markov_bias(state, sigma, drive_sigma, phi, prev, first, K):
    """(K, 3) :func:`_gauss_markov_draw` of one realization's "gyro_bias" stream at PCG64 ``state`` (4,)."""
    out = np.empty((K, 3))
    _gauss_markov_draw(state[0], state[1], state[2], state[3], sigma, drive_sigma, phi, prev, first, out)
    return out


@njit(cache=True, nogil=True)
def _gauss_markov_z(states, sigma, drive_sigma, phi, last, first, gm_z, r_first, r_end) -> None:
    """``gm_z[r]`` (K,): the z axis of :func:`_gauss_markov_draw` for realizations ``r_first`` .. ``r_end - 1``,
    going on from ``last[r]`` (3,) unless ``first``; ``states`` and ``last`` advanced in place."""
    scratch = np.empty((gm_z.shape[1], 3))
    for r in range(r_first, r_end):
        states[r, 0], states[r, 1] = _gauss_markov_draw(states[r, 0], states[r, 1], states[r, 2], states[r, 3], sigma,
                                                        drive_sigma, phi, last[r], first, scratch)
        gm_z[r] = scratch[:, 2]
        last[r] = scratch[-1]


@njit(cache=True, nogil=True)
def _tick_sums(umax_gz, umax_a, usum_gz, usum_a, T, gain, b_on, b_res, gm_sigma, gm_drive, gm_phi, n, n_after,
               sigma_g, sigma_a, g_lo, g_hi, a_lo, a_hi, z_gm, z_g, z_a, gm_last, gm_first, gyro, accel,
               g_sel, a_sel, gm_z, r_first, r_end) -> None:
    """The direct tick-sum draws of every (realization r, tick k, axis i) and which ticks must be read per sample
    (:mod:`nodesim.sensors.tick_counts`), from the tick sums of the noise-free z-gyro (``usum_gz`` (K,)) and
    accelerometer (``usum_a`` (K, 3)) readings before tilt, bias and scale factor, and bounds ``umax_*`` on their
    largest magnitude in each tick:

        mean_g = gain (T_r u_g)_i + n_k (b_on + b_gm,rki) + n_after,k b_res     mean_a = (T_r u_a)_i
        bound_g = |gain| (|T_r| umax_g)_i + max(|b_on + b_gm|, |b_on + b_res + b_gm|)   bound_a = (|T_r| umax_a)_i

    (u_g = (0, 0, usum_gz)); a tick is drawn directly while every axis' bound is valid (``valid_one``); the sum
    round_he(mean + spread_k z), spread_k = sqrt(n_k (sigma^2 + 1/12)) (:func:`~.tick_counts.draw_one`, its spread
    once per tick).  The
    normals z, in order 3 k + i: realization r's "gyro" stream (the states ``z_g``) and its "accel" stream
    (``z_a``); the Gauss-Markov bias b_gm from its "gyro_bias" stream (:func:`_gauss_markov_draw` from the states
    ``z_gm``, going on from ``gm_last`` unless ``gm_first``; its z axis into ``gm_z``); the states and ``gm_last``
    advanced in place.  Realizations ``r_first`` .. ``r_end - 1``.  A block of TICK_SUM_BLOCK ticks' normals is drawn
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
        z_gm[r, 0], z_gm[r, 1] = _gauss_markov_draw(z_gm[r, 0], z_gm[r, 1], z_gm[r, 2], z_gm[r, 3], gm_sigma, gm_drive,
                                                    gm_phi, gm_last[r], gm_first, gm)
        gm_z[r] = gm[:, 2]
        gm_last[r] = gm[K - 1]
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
    ~45 % slower.  The window's largest bounds first (:func:`_window_valid`): where they are valid every tick's are,
    and no tick is checked (tick by tick ~8 ns a tick of the draws' ~57, the window's check ~4; drilling-day
    node-window, min of 25, 2026-12-06); else tick by tick (:func:`_direct_invalid_ticks`)."""
    if _window_valid(umax_gz, umax_a, T, gain, b_on, b_res, gm, sigma_g, sigma_a, g_lo, g_hi, a_lo, a_hi):
        g_sel[:] = False
        a_sel[:] = False
    else:
        _direct_invalid_ticks(umax_gz, umax_a, T, gain, b_on, b_res, gm, sigma_g, sigma_a, g_lo, g_hi, a_lo, a_hi,
                              g_sel, a_sel)


@njit(cache=True, inline="always")
def _axis_valid(T, i, gain, b_on, b_res, u_gz, u_a0, u_a1, u_a2, b_gm, sigma_g, sigma_a, g_lo, g_hi, a_lo, a_hi):
    """(gyro, accelerometer) axis ``i``'s bounds valid (:func:`_tick_sums`, ``valid_one``) for the largest |u| of
    the z gyro ``u_gz`` and of the accelerometer axes ``u_a*`` and the Gauss-Markov bias ``b_gm`` of that axis."""
    t0, t1, t2 = abs(T[i, 0]), abs(T[i, 1]), abs(T[i, 2])
    b_max = max(abs(b_on + b_gm), abs(b_on + b_res + b_gm))
    return (tc.valid_one(abs(gain) * (t2 * u_gz) + b_max, sigma_g, g_lo, g_hi),
            tc.valid_one(t0 * u_a0 + t1 * u_a1 + t2 * u_a2, sigma_a, a_lo, a_hi))


@njit(cache=True, _nrt=False, nogil=True)
def _window_valid(umax_gz, umax_a, T, gain, b_on, b_res, gm, sigma_g, sigma_a, g_lo, g_hi, a_lo, a_hi) -> bool:
    """Whether every tick's bound is valid (:func:`_direct_invalid_ticks` sets no tick), from the window's largest
    bounds: :func:`_axis_valid` of the largest ``umax_*`` and of each end of the axis' Gauss-Markov bias range
    (|c + x| is largest at an end of x's range); a rounded product or sum does not decrease when an operand grows,
    so no tick's bound exceeds these, and where they are valid every tick's is.  False where a value is NaN (the
    ticks decide)."""
    if gm.shape[0] == 0:
        return True
    ug, ua0, ua1, ua2 = -np.inf, -np.inf, -np.inf, -np.inf  # the largest umax of the z gyro and of each accel axis
    lo0, lo1, lo2, hi0, hi1, hi2 = np.inf, np.inf, np.inf, -np.inf, -np.inf, -np.inf  # each axis' bias range
    for k in range(gm.shape[0]):
        u, a0, a1, a2 = umax_gz[k], umax_a[k, 0], umax_a[k, 1], umax_a[k, 2]
        x0, x1, x2 = gm[k, 0], gm[k, 1], gm[k, 2]
        if u != u or a0 != a0 or a1 != a1 or a2 != a2 or x0 != x0 or x1 != x1 or x2 != x2:
            return False
        ug, ua0, ua1, ua2 = max(ug, u), max(ua0, a0), max(ua1, a1), max(ua2, a2)
        lo0, lo1, lo2, hi0, hi1, hi2 = min(lo0, x0), min(lo1, x1), min(lo2, x2), max(hi0, x0), max(hi1, x1), max(hi2, x2)
    ok = True
    for i in range(3):
        for b_gm in ((lo0, hi0) if i == 0 else (lo1, hi1) if i == 1 else (lo2, hi2)):
            ok_g, ok_a = _axis_valid(T, i, gain, b_on, b_res, ug, ua0, ua1, ua2, b_gm, sigma_g, sigma_a, g_lo, g_hi,
                                     a_lo, a_hi)
            ok &= ok_g and ok_a
    return ok


@njit(cache=True, _nrt=False, nogil=True)
def _direct_invalid_ticks(umax_gz, umax_a, T, gain, b_on, b_res, gm, sigma_g, sigma_a, g_lo, g_hi, a_lo, a_hi, g_sel,
                          a_sel) -> None:
    """:func:`_direct_invalid` tick by tick (:func:`_axis_valid` of every axis)."""
    for k in range(gm.shape[0]):
        ok_g, ok_a = True, True
        for i in range(3):
            g, a = _axis_valid(T, i, gain, b_on, b_res, umax_gz[k], umax_a[k, 0], umax_a[k, 1], umax_a[k, 2], gm[k, i],
                               sigma_g, sigma_a, g_lo, g_hi, a_lo, a_hi)
            ok_g &= g
            ok_a &= a
        g_sel[k], a_sel[k] = not ok_g, not ok_a


@njit(cache=True, inline="always")
def _two_streams_normals(g_hi, g_lo, g_inc_hi, g_inc_lo, a_hi, a_lo, a_inc_hi, a_inc_lo, w_g, w_a):
    """``w_g``, ``w_a`` (M,) = the next M normals of two PCG64 streams (states (hi, lo, inc_hi, inc_lo)), drawn in
    turn so that the two generators' steps overlap; returns their new (g_hi, g_lo, a_hi, a_lo)."""
    for j in range(w_g.size):
        w_g[j], g_hi, g_lo = pcg64.normal(g_hi, g_lo, g_inc_hi, g_inc_lo)
        w_a[j], a_hi, a_lo = pcg64.normal(a_hi, a_lo, a_inc_hi, a_inc_lo)
    return g_hi, g_lo, a_hi, a_lo


def _per_sample(out: np.ndarray, sel: np.ndarray, mu_of, sigma_lsb: float, lo: int, hi: int, starts,
                n: np.ndarray, states_of) -> np.ndarray:
    """Overwrite the selected ticks (sel (R, K)) of ``out`` (R, K, 3) with per-sample sums, their normals drawn from
    each realization's stream (``states_of()``: PCG64 states (R, 4), advanced by what it drew; asked for only where a
    tick is selected; ``starts()`` each tick's first sample in the window, likewise); clipped readings (R,)."""
    R = sel.shape[0]
    clipped = np.zeros(R, dtype=np.int64)
    if not sel.any():  # every tick drawn directly (tick_sum's common case): no pass over (R, K), no loop over R
        return clipped
    states = states_of()
    need = 3 * (sel * n[None, :]).sum(axis=1)  # normals per realization
    r0 = 0
    while r0 < R:
        if need[r0] == 0:
            r0 += 1
            continue
        r1 = r0 + 1  # a range of realizations whose normals fit in one chunk
        while r1 < R and (r1 + 1 - r0) * max(int(need[r0:r1 + 1].max()), 1) <= PER_SAMPLE_CHUNK_NORMALS:
            r1 += 1
        w, counts = np.empty((r1 - r0, int(need[r0:r1].max()))), need[r0:r1]
        threads.map_chunks(lambda a, b: pcg64.fill_normals_rows(states[r0 + a:r0 + b], counts[a:b], w[a:b]), r1 - r0)
        for r in range(r0, r1):
            ks = np.flatnonzero(sel[r])
            if ks.size == 0:
                continue
            nk = n[ks]
            m = int(nk.sum())
            offsets = np.concatenate([[0], np.cumsum(nk)[:-1]])
            idx = np.repeat(starts()[ks] - offsets, nk) + np.arange(m)
            ticks = np.repeat(ks, nk)
            sums, clip = tc.per_sample_sums(mu_of(r, idx, ticks), sigma_lsb, w[r - r0, :3 * m].reshape(m, 3), nk, lo, hi)
            out[r, ks] = sums
            clipped[r] = int(clip.sum())
        r0 = r1
    return clipped
