"""Faults of a chain run (``[faults]``): node failure, link outage windows, burst loss, clock steps, and the
ad-hoc fallback to the next-but-one node.  None of them stops the run; their effect shows in the metrics.

* node failure at ``at_s``: the node stops ticking (no filter, no transmissions); frames sent to it are lost;
* link outage ``[start_s, end_s)`` on hop h: every attempt (data or ACK) starting inside it is lost;
* burst loss on hop h: a Gilbert-Elliott channel (:class:`channel.budget.GilbertElliott` parameters) per
  realization, advanced per attempt, on top of the hop's PER;
* clock step of ``step_s`` at ``at_s``: the node's tick times from ``at_s`` on move by ``step_s`` (ticks that
  would not follow the previous one are dropped);
* fallback (needs the ARQ MAC, which tells a sender that its frames went unacknowledged): once
  ``fallback_after_failures`` frames in a row went unacknowledged by its neighbour, a node that fails again
  sends the frame on to the node after its neighbour over the skip hop (:mod:`nodesim.chain.radio`), if the
  skip hop's margin (shadowing included) is at least ``fallback_min_margin_db``; per realization.  It keeps
  trying its neighbour first, so it returns to it when it answers again (after an outage).  Surveys going up
  take the skip hop the same way, at once (a survey is sent once, so there is no streak to wait for): a survey
  hop left unanswered after its tries goes on to the node two above, if the skip hop's margin allows
  (:meth:`nodesim.chain.network.Network.up_skip_open`).  Faults are deterministic in time, so the event
  skeleton stays shared.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nodesim.chain.radio import HopChannel
from nodesim.scenario.schema import Scenario
from nodesim.scenario.radio_sections import BurstLoss


def death_time_s(scenario: Scenario, node_id: int) -> float:
    """When ``node_id`` fails (inf if it does not)."""
    times = [f.at_s for f in scenario.faults.node_failure if f.node == node_id]
    return min(times) if times else np.inf


def outages(scenario: Scenario, hop: int) -> tuple[tuple[float, float], ...]:
    """Outage windows of hop ``hop`` (0-based)."""
    return tuple((o.start_s, o.end_s) for o in scenario.faults.link_outage if o.hop == hop + 1)


def burst(scenario: Scenario, hop: int) -> BurstLoss | None:
    return next((b for b in scenario.faults.burst if b.hop == hop + 1), None)


def stepped_ticks(scenario: Scenario, node_id: int, t_s: np.ndarray, duration_s: float) -> np.ndarray:
    """Tick times after the node's clock steps (kept increasing and inside [0, duration]).  Without a step the
    ticks (increasing, :func:`nodesim.chain.network.tick_times`) are the slice inside [0, duration], a view."""
    steps = [step for step in scenario.faults.clock_step if step.node == node_id]
    if not steps:
        return t_s[np.searchsorted(t_s, 0.0, side="left"):np.searchsorted(t_s, duration_s, side="right")]
    for step in steps:
        t_s = np.where(t_s >= step.at_s, t_s + step.step_s, t_s)
    t_s = t_s[(t_s >= 0.0) & (t_s <= duration_s)]
    if t_s.size < 2:
        return t_s
    before_max = np.concatenate(([-np.inf], np.maximum.accumulate(t_s)[:-1]))
    return t_s[t_s > before_max]  # strictly after every earlier tick: a step back of whole ticks repeats none


@dataclass
class Fallback:
    """Per-realization fallback state of one sender and direction."""

    skip: HopChannel | None
    after_failures: int
    min_margin_db: float
    enabled: bool
    streak: np.ndarray
    active: np.ndarray

    @classmethod
    def new(cls, scenario: Scenario, skip: HopChannel | None, R: int) -> "Fallback":
        f = scenario.faults
        return cls(skip, f.fallback_after_failures, f.fallback_min_margin_db,
                   f.fallback and scenario.mac.enabled and skip is not None,
                   np.zeros(R, dtype=np.int64), np.zeros(R, dtype=bool))

    def record(self, sending: np.ndarray, delivered: np.ndarray, t_s: float) -> np.ndarray:
        """Count unacknowledged frames in a row; return where this failed frame goes over the skip hop.
        ``sending``: the realizations whose frame went on air (one the sender's queue dropped tells nothing
        about the neighbour: it neither counts nor goes over the skip hop)."""
        if not self.enabled:
            return np.zeros(sending.shape, dtype=bool)
        failed = sending & ~delivered
        self.streak = np.where(failed, self.streak + 1, np.where(delivered, 0, self.streak))
        self.active = (self.streak > self.after_failures) & skip_margin_ok(self.skip, t_s, self.min_margin_db)
        return failed & self.active


def skip_margin_ok(skip: HopChannel, t_s: float, min_margin_db: float) -> np.ndarray:
    """(R,) where the skip hop's margin at ``t_s`` (its time table's row, shadowing included) is at least
    ``min_margin_db``: the fallback may use it."""
    g = min(int(t_s / skip.step_s), skip.margin_db.shape[0] - 1)
    return skip.margin_db[g] >= min_margin_db
