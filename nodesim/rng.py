"""Deterministic random streams derived from one root seed.

Every random draw in a run comes from a :class:`numpy.random.Generator` built from a
:class:`numpy.random.SeedSequence` child.  The spawn order is fixed and documented, so adding a
realization or a node never changes the streams of the others:

    root = SeedSequence(seed)
    realization r         = root.spawn(R)[r]                 (per realization)
      node n              = realization.spawn(N)[n]          (per node, 0 = top node)
        sensor stream k   = node.spawn(len(SENSOR_STREAMS))[k]   in the order of SENSOR_STREAMS
      link l              = realization.spawn(N + L)[N + l]  (per link, after the node children)

Child ``n`` of a ``SeedSequence`` depends only on the parent entropy and ``n`` (its ``spawn_key``), so
the streams above are stable however many siblings are spawned.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

SENSOR_STREAMS: tuple[str, ...] = ("gyro", "accel", "encoder", "magnetometer", "clock")
"""Per-node stream names, in spawn order.  Append new names at the end only."""


def _child(parent: np.random.SeedSequence, index: int) -> np.random.SeedSequence:
    """Child ``index`` of ``parent`` without mutating the parent's spawn counter."""
    return np.random.SeedSequence(parent.entropy, spawn_key=parent.spawn_key + (index,))


@dataclass(frozen=True)
class RunStreams:
    """Factory of the named random streams of one run (root seed -> realizations -> nodes/links)."""

    seed: int
    n_nodes: int

    def _realization(self, r: int) -> np.random.SeedSequence:
        return _child(np.random.SeedSequence(self.seed), r)

    def sensor(self, realization: int, node: int, stream: str) -> np.random.Generator:
        """Generator for sensor ``stream`` (one of :data:`SENSOR_STREAMS`) of ``node`` in ``realization``."""
        k = SENSOR_STREAMS.index(stream)
        node_seq = _child(self._realization(realization), node)
        return np.random.default_rng(_child(node_seq, k))

    def link(self, realization: int, link: int) -> np.random.Generator:
        """Generator for link ``link`` (0 = encoder/top hop) in ``realization``."""
        return np.random.default_rng(_child(self._realization(realization), self.n_nodes + link))

    def sensor_batch(self, realizations: int, node: int, stream: str) -> list[np.random.Generator]:
        """One generator per realization for a (node, stream): used to draw batched noise arrays."""
        return [self.sensor(r, node, stream) for r in range(realizations)]
