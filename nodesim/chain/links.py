"""Simple links: a fixed transfer delay and an independent per-transmission loss probability.

The physical radio links (path loss, MAC, ARQ, faults) replace this module in the link issue; the
interface stays: ``SimpleLink.send(env, packet, deliver)`` delivers ``packet`` after ``delay_s`` with
``valid`` cleared in the realizations that lost it.

Losses are drawn per realization from that link's own stream (:meth:`nodesim.rng.RunStreams.link`), one
uniform number per transmission in transmission order, so every realization owns its losses while all
realizations share one SimPy event per transmission.  Draws are buffered in blocks for speed; a block is
the next ``block`` numbers of each realization's stream, so the result does not depend on the block size.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np
import simpy

from nodesim.rng import RunStreams


@dataclass
class LossDraws:
    """Uniform draws of one link, one per transmission of each realization, batched over realizations.

    A realization advances its own stream only when it transmits (``mask``), so its losses do not depend on
    what the other realizations did or on how many there are."""

    generators: list[np.random.Generator]
    block: int = 256
    _buffer: np.ndarray = field(default=None, init=False, repr=False)
    _next: np.ndarray = field(default=None, init=False, repr=False)

    def next_uniform(self, mask: np.ndarray | None = None) -> np.ndarray:
        """The next uniform number of every realization in ``mask`` (default: all), shape (R,); NaN elsewhere."""
        R = len(self.generators)
        if self._buffer is None:
            self._buffer = np.stack([g.random(self.block) for g in self.generators])
            self._next = np.zeros(R, dtype=np.int64)
        take = np.ones(R, dtype=bool) if mask is None else np.asarray(mask, dtype=bool)
        for r in np.flatnonzero(take & (self._next >= self.block)):  # refill exhausted rows only
            self._buffer[r] = self.generators[r].random(self.block)
            self._next[r] = 0
        out = np.where(take, self._buffer[np.arange(R), np.minimum(self._next, self.block - 1)], np.nan)
        self._next += take
        return out


@dataclass
class SimpleLink:
    """One hop: fixed delay, loss probability per transmission; counts what it carried and lost."""

    name: str
    delay_s: float
    loss_probability: float
    draws: LossDraws
    transmissions: int = 0
    lost: np.ndarray | None = None  # per realization, number of transmissions lost

    @classmethod
    def from_streams(cls, name: str, streams: RunStreams, link_index: int, realizations: int, delay_s: float,
                     loss_probability: float) -> "SimpleLink":
        gens = [streams.link(r, link_index) for r in range(realizations)]
        return cls(name, delay_s, loss_probability, LossDraws(gens), lost=np.zeros(realizations, dtype=np.int64))

    def draw_lost(self, sending: np.ndarray | None = None) -> np.ndarray:
        """Whether this transmission is lost, per realization (bool (R,)); only the realizations that are
        ``sending`` (default: all) draw, and only they can lose it."""
        self.transmissions += 1
        u = self.draws.next_uniform(sending)
        lost = np.isfinite(u) & (u < self.loss_probability)
        self.lost += lost
        return lost

    def send(self, env: simpy.Environment, packet, deliver: Callable[[object], None], extra_delay_s: float = 0.0):
        """SimPy process: after ``extra_delay_s`` (the sender's processing) and ``delay_s`` call
        ``deliver(packet)`` with the lost realizations invalidated."""
        lost = self.draw_lost(packet.valid)
        yield env.timeout(extra_delay_s + self.delay_s)
        deliver(packet.lost_where(lost))
