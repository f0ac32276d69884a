"""The noise-free readings every sample of a chain node's IMU would give, and their prefix sums (:class:`SampleTruth`):
what :mod:`nodesim.sensors.chain_imu` sums per firmware tick before tilt, scale factor, bias and noise.

At sample j (t_j = j / sample_rate_hz) the z gyro reads the string's spin rate theta'(t_j) and the accelerometer the
specific force of the tube's attitude (:func:`sensor_force`), both in LSB (the MPU6500's sensitivities,
:class:`nodesim.sensors.chain_imu.ChainImu`).
"""

from __future__ import annotations

import math
import weakref

import numpy as np
from numba import njit

from nodesim.motion.timelines import ChainMotion
from nodesim.units import G0_M_S2

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

    ``start_sums`` (4,): the sums before j_lo where this truth continues one that ended there (its
    :attr:`end_sums`): its prefix sums are then those of one truth over both ranges, bit for bit (the same additions
    in the same order), so that a node read in windows of ticks (:class:`nodesim.sensors.chain_imu.NodeImuStream`)
    sums as it does at once.  ``imu``: the :class:`nodesim.sensors.chain_imu.ChainImu` (its sample rate and
    sensitivities).

    Without ``keep_readings`` it keeps only the prefix sums (and the maxima): half the memory (32 bytes a sample
    instead of 64), and :meth:`slice`, which only a tick drawn per sample needs, computes the readings of the samples
    asked for again, the same values (each sample's reading depends on its own time only: tested)."""

    def __init__(self, imu, motion: ChainMotion, j_lo: int, j_hi: int, node_index: int = 0,
                 shared: bool = False, keep_readings: bool = True, start_sums: np.ndarray | None = None):
        self.j_lo, self.j_hi = j_lo, j_hi
        # what :meth:`slice` needs to compute readings again (the motion by weak reference: the run holds it, and a
        # truth cached between runs, :func:`nodesim.chain.sensing.shared_truth`, must not keep it alive)
        self._imu, self._motion, self._node_index, self._shared = imu, weakref.ref(motion), node_index, shared
        S = j_hi - j_lo
        self._sums = np.empty((S + 1, 4))  # U of the z gyro and the accelerometer's x, y, z, side by side
        self.u_gz, self.u_a = (np.empty(S), np.empty((S, 3))) if keep_readings else (None, None)
        acc = np.zeros(4) if start_sums is None else np.array(start_sums, dtype=float)
        umax = np.zeros(4)
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

    @property
    def end_sums(self) -> np.ndarray:
        """(4,) U[j_hi]: the sums of every sample (the ``start_sums`` of a truth that continues this one)."""
        return self._sums[-1].copy()

    def sums_at(self, j: int) -> np.ndarray:
        """(4,) U[j] (j_lo <= j <= j_hi): the ``start_sums`` of a truth that continues this one from sample j."""
        return self._sums[j - self.j_lo].copy()

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
