"""Reference-update schedules (thesis 4.2.2 update modes).

A schedule answers one question for the network: "is the reference available to the top node at the tick
at time t?".  Modes:
  - continuous: every tick (1.9 Hz);
  - windowed:   ``update_s`` of updates, then ``timeout_s`` of time updates only, repeating from t = 0;
  - single:     one update every 1/f seconds, at the first tick at or after each multiple of 1/f
                (thesis digest 5.3: "schedule each update at the nearest cycle");
  - none:       no reference at all (free-running gyro integration).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class UpdateSchedule:
    mode: str
    update_s: float = 20.0
    timeout_s: float = 30.0
    single_rate_hz: float = 0.2

    def mask(self, tick_times_s: np.ndarray, tick_dt_s: float) -> np.ndarray:
        """Boolean array: True where the tick at that time receives a reference update."""
        t = np.asarray(tick_times_s, dtype=float)
        if self.mode == "continuous":
            return np.ones(t.shape, dtype=bool)
        if self.mode == "none":
            return np.zeros(t.shape, dtype=bool)
        if self.mode == "windowed":
            period = self.update_s + self.timeout_s
            return np.remainder(t, period) < self.update_s
        if self.mode == "single":
            period = 1.0 / self.single_rate_hz
            # the tick [t, t + dt) that contains a multiple of the period takes the update
            k_before = np.floor((t - 1e-12) / period)
            k_after = np.floor((t + tick_dt_s - 1e-12) / period)
            return (k_after > k_before) | (t == 0.0)
        raise ValueError(f"unknown schedule mode {self.mode!r}")

    def describe(self) -> str:
        if self.mode == "windowed":
            return f"windowed {self.update_s:g} s updates / {self.timeout_s:g} s timeouts"
        if self.mode == "single":
            return f"single updates at {self.single_rate_hz:g} Hz (every {1 / self.single_rate_hz:.4g} s)"
        return self.mode


__all__ = ["UpdateSchedule"]
