"""Rotary encoder at the top of the string: quantised reference yaw and rate on its own time base.

An incremental encoder with ``counts_per_rev`` counts per revolution (thesis 5.1: 1024) reports the
count nearest the true angle, q = 2 pi / counts_per_rev, so the quantisation error is uniform in
[-q/2, q/2] with sigma = q / sqrt(12) (0.1015 deg at 1024 counts, thesis digest 2.6).  The encoder module
reads at its own clock: a node time t corresponds to encoder time t + clock_offset_s (+ an optional
drift in parts per million), so a clock offset shifts the angle it returns by rate * offset.  The rate
it sends (thesis 5.1: "position relative to the reference plus angular velocity") is the count
difference over ``rate_window_s`` divided by the window: a backward difference whose quantisation noise
is about sqrt(2) sigma_q / window.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from nodesim.errors import NodesimError


@dataclass(frozen=True)
class EncoderReading:
    """Encoder output at the requested node times: whole counts, yaw (rad) and rate (rad/s)."""

    counts: np.ndarray
    yaw_rad: np.ndarray
    rate_rad_s: np.ndarray
    encoder_time_s: np.ndarray


@dataclass(frozen=True)
class RotaryEncoder:
    counts_per_rev: int = 1024
    clock_offset_s: float = 0.0
    clock_drift_ppm: float = 0.0
    rate_window_s: float = 0.1
    zero_offset_rad: float = 0.0  # angle of the string at which the count is zero

    def __post_init__(self):
        if not (isinstance(self.counts_per_rev, (int, np.integer)) and self.counts_per_rev >= 1):
            raise NodesimError(f"encoder: counts_per_rev = {self.counts_per_rev!r} must be a positive integer")
        if not (math.isfinite(self.rate_window_s) and self.rate_window_s > 0.0):
            raise NodesimError(f"encoder: rate_window_s = {self.rate_window_s} must be > 0")
        for key in ("clock_offset_s", "clock_drift_ppm", "zero_offset_rad"):
            if not math.isfinite(getattr(self, key)):
                raise NodesimError(f"encoder: {key} must be finite")

    @property
    def step_rad(self) -> float:
        return 2.0 * math.pi / self.counts_per_rev

    @property
    def quantisation_sigma_rad(self) -> float:
        return self.step_rad / math.sqrt(12.0)

    def encoder_time(self, node_time_s) -> np.ndarray:
        """Encoder clock reading at node times: t (1 + drift) + offset."""
        t = np.asarray(node_time_s, dtype=float)
        return t * (1.0 + self.clock_drift_ppm * 1e-6) + self.clock_offset_s

    def counts_at(self, angle_rad) -> np.ndarray:
        """Whole counts nearest the string angle (relative to the zero offset)."""
        return np.rint((np.asarray(angle_rad, dtype=float) - self.zero_offset_rad) / self.step_rad).astype(np.int64)

    def read_rad(self, true_angle_rad) -> np.ndarray:
        """Quantised angle (no clock model): the nearest whole count times the step."""
        return self.angle_of_counts(self.counts_at(true_angle_rad))

    def angle_of_counts(self, counts) -> np.ndarray:
        return np.asarray(counts) * self.step_rad + self.zero_offset_rad

    def read(self, angle_of_time: Callable[[np.ndarray], np.ndarray], node_time_s) -> EncoderReading:
        """Read at node times: ``angle_of_time(t)`` is the true string angle (rad) at true time t.

        The encoder samples the true angle at its own clock time (true time = node time mapped through
        the clock model), so an offset shows up as a time shift of the reference.
        """
        t_enc = self.encoder_time(node_time_s)
        c_now = self.counts_at(angle_of_time(t_enc))
        c_before = self.counts_at(angle_of_time(t_enc - self.rate_window_s))
        return EncoderReading(
            counts=c_now,
            yaw_rad=self.angle_of_counts(c_now),
            rate_rad_s=(c_now - c_before) * self.step_rad / self.rate_window_s,
            encoder_time_s=t_enc,
        )
