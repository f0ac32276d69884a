"""Per-realization uniform draws of a link (the hops, MAC and faults are in radio.py, mac.py, faults.py).

Draws come per realization from that link's own stream (:meth:`nodesim.rng.streams.RunStreams.link`), in
transmission order, and a realization advances its stream only when it transmits, so every realization owns
its packet outcomes while all realizations share the event skeleton.  Draws are buffered in blocks for
speed; a block is the next ``block`` numbers of each realization's stream, so the result does not depend on
the block size.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np


class LazyStreams:
    """One generator per realization, all built together on first use (``make_all()``, e.g.
    :meth:`nodesim.rng.streams.RunStreams.link_batch`): a link that never transmits, such as an up link of a run
    without surveys, costs no generator."""

    def __init__(self, make_all: Callable[[], list[np.random.Generator]], realizations: int):
        self._make_all = make_all
        self._n = realizations
        self._gens: list[np.random.Generator] | None = None

    def __len__(self) -> int:
        return self._n

    def __getitem__(self, r: int) -> np.random.Generator:
        if self._gens is None:
            self._gens = self._make_all()
        return self._gens[r]

    def __iter__(self):
        return (self[r] for r in range(len(self)))

    @property
    def built(self) -> list[np.random.Generator | None]:
        """The generators (None everywhere if they were never needed)."""
        return list(self._gens) if self._gens is not None else [None] * self._n


@dataclass
class LossDraws:
    """Uniform draws of one link, one per transmission of each realization, batched over realizations.

    A realization advances its own stream only when it transmits (``mask``), so its losses do not depend on
    what the other realizations did or on how many there are."""

    generators: list[np.random.Generator] | LazyStreams
    block: int = 256
    _buffer: np.ndarray = field(default=None, init=False, repr=False)
    _next: np.ndarray = field(default=None, init=False, repr=False)
    _rows: np.ndarray = field(default=None, init=False, repr=False)

    def next_uniform(self, mask: np.ndarray | None = None) -> np.ndarray:
        """The next uniform number of every realization in ``mask`` (default: all), shape (R,); NaN elsewhere."""
        return self.next_uniforms(1, mask)[:, 0]

    def next_uniforms(self, n: int, mask: np.ndarray | None = None) -> np.ndarray:
        """The next ``n`` uniform numbers of every realization in ``mask``, shape (R, n); NaN elsewhere (the
        same numbers as ``n`` calls of :meth:`next_uniform` with that mask)."""
        R = len(self.generators)
        if self._buffer is None:
            self._buffer = np.stack([g.random(self.block) for g in self.generators])
            self._next = np.zeros(R, dtype=np.int64)
            self._rows = np.arange(R)[:, None]
        take = np.ones(R, dtype=bool) if mask is None else np.asarray(mask, dtype=bool)
        short = take & (self._next > self.block - n)
        if short.any():  # keep the unread numbers in order, refill the rest of the row from the stream
            for r in np.flatnonzero(short):
                rest = self._buffer[r, self._next[r]:]
                self._buffer[r] = np.concatenate([rest, self.generators[r].random(self.block - rest.size)])
                self._next[r] = 0
        idx = np.minimum(self._next[:, None] + np.arange(n), self.block - 1)
        out = self._buffer[self._rows, idx]
        out[~take] = np.nan
        self._next += take * n
        return out
