"""One-line progress bars on stderr: a campaign's completed / failed / remaining runs with an ETA, and one
long simulation's simulated time with an ETA.

Shown only when stderr is a terminal and ``--quiet`` is not given, so pipes, CI logs and ``--json`` output
stay clean.  Redrawn at most ``max_rate_hz`` times a second.  The ETA is the mean wall time per run finished
in this session times the runs remaining (runs skipped by ``--resume`` do not count towards the rate).
"""

from __future__ import annotations

import sys
import time
from typing import TextIO


def format_duration(seconds: float) -> str:
    """``75.0 -> '1m15s'``, ``3700 -> '1h01m'``; '?' when unknown."""
    if seconds != seconds or seconds == float("inf"):
        return "?"
    s = int(round(seconds))
    if s < 60:
        return f"{s}s"
    if s < 3600:
        return f"{s // 60}m{s % 60:02d}s"
    return f"{s // 3600}h{(s % 3600) // 60:02d}m"


class _Bar:
    """A redrawn one-line bar on ``stream`` (stderr), enabled only on a terminal and without ``quiet``."""

    def __init__(self, quiet: bool, stream: TextIO | None, width: int, max_rate_hz: float):
        self.stream = stream if stream is not None else sys.stderr
        isatty = getattr(self.stream, "isatty", lambda: False)
        self.enabled = not quiet and bool(isatty())
        self.width = width
        self._min_dt = 1.0 / max_rate_hz
        self._t0 = time.perf_counter()
        self._last = 0.0

    def line(self) -> str:  # pragma: no cover - overridden
        raise NotImplementedError

    @property
    def finished(self) -> bool:  # pragma: no cover - overridden
        raise NotImplementedError

    def bar(self, fraction: float) -> str:
        filled = int(self.width * min(max(fraction, 0.0), 1.0))
        return "[" + "#" * filled + "." * (self.width - filled) + "]"

    def draw(self, force: bool = False) -> None:
        if not self.enabled:
            return
        now = time.perf_counter()
        if not force and now - self._last < self._min_dt and not self.finished:
            return
        self._last = now
        self.stream.write("\r" + self.line())
        self.stream.flush()

    def close(self) -> None:
        if self.enabled:
            self.draw(force=True)
            self.stream.write("\n")
            self.stream.flush()

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.close()


class Progress(_Bar):
    """Counts finished runs; draws ``[####....] 12/64 ok 11 failed 1 remaining 52 ETA 1m23s``."""

    def __init__(
        self,
        total: int,
        already_done: int = 0,
        quiet: bool = False,
        stream: TextIO | None = None,
        label: str = "runs",
        width: int = 28,
        max_rate_hz: float = 10.0,
    ):
        super().__init__(quiet, stream, width, max_rate_hz)
        self.total = total
        self.ok = already_done
        self.failed = 0
        self.session = 0
        self.label = label
        self.draw(force=True)

    @property
    def remaining(self) -> int:
        return max(self.total - self.ok - self.failed, 0)

    @property
    def finished(self) -> bool:
        return self.remaining == 0

    def eta_s(self) -> float:
        if self.session == 0:
            return float("nan")
        return (time.perf_counter() - self._t0) / self.session * self.remaining

    def line(self) -> str:
        done = self.ok + self.failed
        bar = self.bar(done / self.total if self.total else 1.0)
        return (
            f"{bar} {done}/{self.total} {self.label}  ok {self.ok}  failed {self.failed}  "
            f"remaining {self.remaining}  ETA {format_duration(self.eta_s())}"
        )

    def update(self, ok: bool) -> None:
        if ok:
            self.ok += 1
        else:
            self.failed += 1
        self.session += 1
        self.draw()


class SimulatedTimeProgress(_Bar):
    """Progress of one long simulation: ``[####....] simulated 310/620 s  ETA 12s`` (``nodesim run``).

    ``update(fraction)`` is the simulation's progress callback; the ETA extrapolates the wall time per
    simulated second so far."""

    def __init__(self, duration_s: float, quiet: bool = False, stream: TextIO | None = None, width: int = 28,
                 max_rate_hz: float = 5.0):
        super().__init__(quiet, stream, width, max_rate_hz)
        self.duration_s = duration_s
        self.fraction = 0.0
        self.draw(force=True)

    @property
    def finished(self) -> bool:
        return self.fraction >= 1.0

    def eta_s(self) -> float:
        if self.fraction <= 0.0:
            return float("nan")
        return (time.perf_counter() - self._t0) * (1.0 - self.fraction) / self.fraction

    def line(self) -> str:
        return (
            f"{self.bar(self.fraction)} simulated {self.fraction * self.duration_s:.0f}/{self.duration_s:.0f} s  "
            f"ETA {format_duration(self.eta_s())}"
        )

    def update(self, fraction: float) -> None:
        self.fraction = min(max(float(fraction), 0.0), 1.0)
        self.draw()
