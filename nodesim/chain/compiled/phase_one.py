"""Phase 1 on a thread of its own while phase 2 runs in windows of time (issue 20).

Phase 1 (:func:`.engine._resolve`) takes the run's events in time order, a chunk at a time, and phase 2 in windows
(:mod:`.time_windows`) reads its records one window of time at a time: the records of a node's tick k are written
by that tick's own event (which reference it took, from where; an encoder request's reply; a survey's arrival at
the ground station, decided hop by hop at its send event).  So once every event before time t is done, the records
of every tick before t are final, and phase 2 can run a window [t0, t1) while phase 1 goes on past t1: on two
cores, the second half of phase 1 (one core's work, ~13 s of the drilling day) runs beside the first window of
phase 2 instead of before it.

:class:`PhaseOne` runs phase 1 on its thread and tells phase 2 how far it has come (:meth:`PhaseOne.wait`).  Where an
inbox overflows, phase 1 starts again with more slots (:func:`.engine._resolve`); the chunk that overflowed is not
told.  The events before the overflow are the same in the new attempt (a larger inbox changes nothing until it would
have been full), so the records phase 2 was given are those of the new attempt too; its next window waits for the new
attempt to get past it, and reads that attempt's tables.  The numbers are those of phase 1 before phase 2, bit for bit
(tests/nodesim/chain/test_time_windows.py).
"""

from __future__ import annotations

import math
import threading
from typing import Callable

import numpy as np

from nodesim.chain.packets import SurveyPacket


class Cancelled(Exception):
    """Phase 1 was stopped by :meth:`PhaseOne.cancel`."""


class PhaseOne:
    """Phase 1 run by ``resolve(beside)`` (:func:`.engine._resolve` with this object as its ``beside``) on a thread
    of its own, or given already run (``done``: its result)."""

    def __init__(self, resolve: Callable | None = None, done: tuple | None = None):
        self._cond = threading.Condition()
        self._ready_s = -math.inf  # the records of the ticks before this time are final
        self._tables: tuple | None = None  # (records, survey arrivals) of the attempt that got there
        self._result, self._error = done, None
        self._cancelled = False
        self._thread = None
        if done is not None:
            self._ready_s, self._tables = math.inf, (done[1], done[4])
        else:
            self._thread = threading.Thread(target=self._run, args=(resolve,), name="nodesim-phase1", daemon=True)
            self._thread.start()

    def _run(self, resolve: Callable) -> None:
        try:
            result = resolve(self)
        except BaseException as err:  # noqa: BLE001 - raised in phase 2's thread (wait, result)
            with self._cond:
                self._error = err
                self._cond.notify_all()
            return
        with self._cond:
            self._result, self._ready_s, self._tables = result, math.inf, (result[1], result[4])
            self._cond.notify_all()

    def publish(self, records, arrivals: tuple, t_s: float) -> None:
        """Every event before ``t_s`` is done: the records of the ticks before it are final in ``records``."""
        with self._cond:
            self._ready_s, self._tables = t_s, (records, arrivals)
            self._cond.notify_all()

    def cancel(self) -> None:
        """Phase 2 failed (or was interrupted): phase 1 stops at its next chunk (:meth:`check`) instead of running on
        in the background; :meth:`result` then raises."""
        with self._cond:
            self._cancelled = True

    def check(self) -> None:
        """Raise :class:`Cancelled` in phase 1's thread once :meth:`cancel` was called (``_resolve``, every chunk)."""
        if self._cancelled:
            raise Cancelled("phase 1 stopped: phase 2 failed")

    def wait(self, t_s: float) -> tuple:
        """(records, (survey arrival, event)) once the records of every tick before ``t_s`` are final in them (``t_s``
        inf: phase 1 is done)."""
        with self._cond:
            while self._error is None and self._ready_s < t_s:
                self._cond.wait()
            if self._error is not None:
                raise self._error
            return self._tables

    def result(self) -> tuple:
        """Phase 1's (events, records, radio, stats, survey arrivals) once it is done."""
        self.wait(math.inf)
        if self._thread is not None:
            self._thread.join()
        return self._result


def ground_surveys(net, senders: list, arrivals: tuple, before_s: float = math.inf) -> None:
    """The network's surveys (:meth:`Network.received_survey`) from phase 1's (arrival (R, S), event (S,)), in send
    order (the order of their events), those sent before ``before_s`` that it does not have yet: phase 1 has done
    every event before ``before_s`` (:meth:`PhaseOne.wait`), so these come before any survey sent later."""
    arrival, event = arrivals
    sent = np.array([float(net.nodes[n].t_s[k]) < before_s for n, k, _ in senders], dtype=bool)
    order = [s for s in np.argsort(event, kind="stable") if sent[s]]
    for s in order[len(net.ground):]:
        n, k, stop = senders[s]
        packet = SurveyPacket(stop.station, stop.md_m, n + 1, k, float(net.nodes[n].t_s[k]), np.ones(net.R, bool))
        net.received_survey(packet, arrival[:, s].copy(), [])  # no bit errors on these hops (``unsupported``)
