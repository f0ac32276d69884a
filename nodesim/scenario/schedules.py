"""Reference-update schedules (thesis 4.2.2 update modes).

A schedule answers one question for the network: "is the encoder reference available to the top node at
the tick at time t?".  Modes:
  - continuous: every tick (1.9 Hz);
  - windowed:   ``update_s`` of updates, then ``timeout_s`` of time updates only, repeating from t = 0;
  - single:     one update every 1/f seconds, at the first tick at or after each multiple of 1/f
                (thesis digest 5.3: "schedule each update at the nearest cycle");
  - arbitrary:  a list of ``(start_s, stop_s, rate_hz)`` windows; inside a window the ``single`` rule with
                period 1/rate counted from the window start (a rate at or above the tick rate updates every tick);
  - none:       no reference at all (free-running gyro integration).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def _periodic_ticks(t: np.ndarray, tick_dt_s: float, period_s: float, origin_s: float) -> np.ndarray:
    """True for the tick [t, t + dt) that contains a multiple of ``period_s`` counted from ``origin_s``
    (and for the tick at the origin itself)."""
    u = t - origin_s
    k_before = np.floor((u - 1e-12) / period_s)
    k_after = np.floor((u + tick_dt_s - 1e-12) / period_s)
    return (k_after > k_before) | (u == 0.0)


@dataclass(frozen=True)
class UpdateSchedule:
    mode: str
    update_s: float = 20.0
    timeout_s: float = 30.0
    single_rate_hz: float = 0.2
    windows: tuple[tuple[float, float, float], ...] = ()

    def mask(self, tick_times_s: np.ndarray, tick_dt_s: float) -> np.ndarray:
        """Boolean array: True where the tick at that time receives a reference update (read-only; "continuous" and
        "none" a broadcast of one value, no memory: a day's 1000 nodes held 164 MB of them)."""
        t = np.asarray(tick_times_s, dtype=float)
        if self.mode in ("continuous", "none"):
            return np.broadcast_to(np.bool_(self.mode == "continuous"), t.shape)
        if self.mode == "windowed":
            period = self.update_s + self.timeout_s
            return np.remainder(t, period) < self.update_s
        if self.mode == "single":
            return _periodic_ticks(t, tick_dt_s, 1.0 / self.single_rate_hz, 0.0)
        if self.mode == "arbitrary":
            out = np.zeros(t.shape, dtype=bool)
            for start, stop, rate in self.windows:
                inside = (t + tick_dt_s > start) & (t < stop)  # ticks overlapping the window
                out |= inside & _periodic_ticks(t, tick_dt_s, 1.0 / rate, start)
            return out
        raise ValueError(f"unknown schedule mode {self.mode!r}")

    def describe(self) -> str:
        if self.mode == "windowed":
            return f"windowed {self.update_s:g} s updates / {self.timeout_s:g} s timeouts"
        if self.mode == "single":
            return f"single updates at {self.single_rate_hz:g} Hz (every {1 / self.single_rate_hz:.4g} s)"
        if self.mode == "arbitrary":
            return "arbitrary: " + ", ".join(f"{a:g}-{b:g} s at {r:g} Hz" for a, b, r in self.windows)
        return self.mode


__all__ = ["UpdateSchedule"]
