"""The node's execution cycle (thesis 4.2.2, fig 4.10 and the event list of the second "table 4.21").

Every firmware tick (1/1.9 Hz = 526 ms) runs, in order:
    SYNC               sync the encoder and node clocks, execution begins
    REQUEST_REFERENCE  the node requests the reference (radio leg to the encoder / previous node)
    READ_REFERENCE     the encoder module reads the encoder
    RECEIVE            the reference is sent back and received (radio leg)
    PROCESS_FILTER     moving average, time update, measurement update (KF processing)
    TRANSMIT           the estimate and its variance are sent on
    IDLE               until the next tick
A tick without a reference skips the three reference steps.  The thesis gives no durations (digest 5.1,
item 30 of digest 9); the defaults are the digest's [A] values: read 2 ms, radio legs 15 ms, KF 5 ms.

:meth:`ExecutionCycle.step_at` answers "what does the node do at time t" and
:meth:`ExecutionCycle.estimate_ready_s` "when is its estimate ready to send", vectorised over arrays of times
or tick indices.  No engine drives a node through this model yet: the chain's node process
(:mod:`nodesim.chain.node_process`) runs the same order of steps with a single processing time
(``chain.processing_s``); only the tests call this module today.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from enum import IntEnum

import numpy as np

from firmware_model.errors import FirmwareError
from firmware_model.yaw_filter import check_finite


class Step(IntEnum):
    SYNC = 0
    REQUEST_REFERENCE = 1
    READ_REFERENCE = 2
    RECEIVE = 3
    PROCESS_FILTER = 4
    TRANSMIT = 5
    IDLE = 6


REFERENCE_STEPS = (Step.REQUEST_REFERENCE, Step.READ_REFERENCE, Step.RECEIVE)


@dataclass(frozen=True)
class CycleTiming:
    """Tick period and per-step durations (s)."""

    period_s: float = 1.0 / 1.9
    sync_s: float = 0.002
    request_s: float = 0.015
    read_s: float = 0.002
    receive_s: float = 0.015
    filter_s: float = 0.005
    transmit_s: float = 0.015

    def __post_init__(self) -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            if not (math.isfinite(v) and v >= 0):
                raise FirmwareError(f"CycleTiming.{f.name} = {v}: allowed finite values >= 0")
        if not self.period_s > 0:
            raise FirmwareError(f"CycleTiming.period_s = {self.period_s}: allowed > 0")
        busy = sum(self.duration_s(s) for s in Step if s is not Step.IDLE)
        if busy > self.period_s:
            raise FirmwareError(
                f"CycleTiming: the steps take {busy:.6g} s, longer than period_s = {self.period_s:.6g} s; "
                "allowed step durations summing to at most the period"
            )

    def duration_s(self, step: Step) -> float:
        return {
            Step.SYNC: self.sync_s,
            Step.REQUEST_REFERENCE: self.request_s,
            Step.READ_REFERENCE: self.read_s,
            Step.RECEIVE: self.receive_s,
            Step.PROCESS_FILTER: self.filter_s,
            Step.TRANSMIT: self.transmit_s,
        }.get(step, 0.0)


class ExecutionCycle:
    """The tick sequence of one node whose tick k starts at ``start_s + k * period_s``."""

    def __init__(self, timing: CycleTiming | None = None, start_s: float = 0.0):
        self.timing = timing or CycleTiming()
        if not math.isfinite(start_s):
            raise FirmwareError(f"ExecutionCycle.start_s = {start_s}: allowed finite values")
        self.start_s = float(start_s)
        self._tables = {flag: self._table(flag) for flag in (False, True)}

    def _table(self, with_reference: bool) -> tuple[np.ndarray, np.ndarray]:
        """Step codes and their end offsets within a tick (IDLE runs to the period)."""
        steps = [s for s in Step if s is not Step.IDLE and (with_reference or s not in REFERENCE_STEPS)]
        ends = np.cumsum([self.timing.duration_s(s) for s in steps])
        return np.array([int(s) for s in steps] + [int(Step.IDLE)]), np.append(ends, self.timing.period_s)

    def steps(self, with_reference: bool = True) -> list[tuple[Step, float, float]]:
        """(step, start offset, end offset) within a tick, IDLE last."""
        codes, ends = self._tables[bool(with_reference)]
        starts = np.concatenate([[0.0], ends[:-1]])
        return [(Step(int(c)), float(a), float(b)) for c, a, b in zip(codes, starts, ends)]

    def tick_index(self, t_s) -> np.ndarray:
        """Index of the tick running at time t (floor); times before the first tick are rejected."""
        t = check_finite("time", t_s)
        if np.any(t < self.start_s):
            raise FirmwareError(f"time: {np.min(t):.6g} s is before the first tick at {self.start_s:.6g} s; allowed t >= start_s")
        return np.floor((t - self.start_s) / self.timing.period_s).astype(np.int64)

    def tick_start_s(self, k) -> np.ndarray:
        k = np.asarray(k)
        if np.any(k < 0):
            raise FirmwareError(f"tick index {int(np.min(k))}: allowed >= 0")
        return self.start_s + k * self.timing.period_s

    def step_at(self, t_s, with_reference=True) -> np.ndarray:
        """The :class:`Step` code the node is in at each time (``with_reference`` scalar or per time)."""
        t = check_finite("time", t_s)
        offset = t - self.tick_start_s(self.tick_index(t))
        out = np.empty(t.shape, dtype=np.int64)
        flags = np.broadcast_to(np.asarray(with_reference, dtype=bool), t.shape)
        for flag in (False, True):
            codes, ends = self._tables[flag]
            sel = flags == flag
            idx = np.minimum(np.searchsorted(ends, offset[sel], side="right"), len(codes) - 1)
            out[sel] = codes[idx]
        return out

    def _offset_end(self, step: Step, with_reference: bool) -> float:
        for s, _, end in self.steps(with_reference):
            if s is step:
                return end
        raise FirmwareError(f"step {step.name} is not part of a tick with with_reference={with_reference}")

    def reference_read_s(self, k) -> np.ndarray:
        """Time the reference is read in tick k (end of READ_REFERENCE)."""
        return self.tick_start_s(k) + self._offset_end(Step.READ_REFERENCE, True)

    def estimate_ready_s(self, k, with_reference=True) -> np.ndarray:
        """Time the estimate of tick k is ready to send (end of PROCESS_FILTER)."""
        return self.tick_start_s(k) + np.where(
            with_reference, self._offset_end(Step.PROCESS_FILTER, True), self._offset_end(Step.PROCESS_FILTER, False)
        )

    def transmit_end_s(self, k, with_reference=True) -> np.ndarray:
        """Time the transmission of tick k's estimate ends."""
        return self.estimate_ready_s(k, with_reference) + self.timing.transmit_s

    @property
    def reference_latency_s(self) -> float:
        """Delta t_1 of eq 3.29: from reading the reference to the filter using it (start of PROCESS_FILTER)."""
        return self.timing.receive_s
