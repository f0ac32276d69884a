"""A one-line progress bar on stderr: completed / failed / remaining and an ETA.

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


class Progress:
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
        self.stream = stream if stream is not None else sys.stderr
        isatty = getattr(self.stream, "isatty", lambda: False)
        self.enabled = not quiet and bool(isatty())
        self.total = total
        self.ok = already_done
        self.failed = 0
        self.session = 0
        self.label = label
        self.width = width
        self._min_dt = 1.0 / max_rate_hz
        self._t0 = time.perf_counter()
        self._last = 0.0
        self.draw(force=True)

    @property
    def remaining(self) -> int:
        return max(self.total - self.ok - self.failed, 0)

    def eta_s(self) -> float:
        if self.session == 0:
            return float("nan")
        return (time.perf_counter() - self._t0) / self.session * self.remaining

    def line(self) -> str:
        done = self.ok + self.failed
        filled = int(self.width * done / self.total) if self.total else self.width
        bar = "#" * filled + "." * (self.width - filled)
        return (
            f"[{bar}] {done}/{self.total} {self.label}  ok {self.ok}  failed {self.failed}  "
            f"remaining {self.remaining}  ETA {format_duration(self.eta_s())}"
        )

    def update(self, ok: bool) -> None:
        if ok:
            self.ok += 1
        else:
            self.failed += 1
        self.session += 1
        self.draw()

    def draw(self, force: bool = False) -> None:
        if not self.enabled:
            return
        now = time.perf_counter()
        if not force and now - self._last < self._min_dt and self.remaining:
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
