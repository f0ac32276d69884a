"""Deterministic random streams derived from one root seed.

Every random draw in a run comes from a :class:`numpy.random.Generator` built from a
:class:`numpy.random.SeedSequence` child.  The spawn order is fixed and documented, so adding a
realization or a node never changes the streams of the others:

    root = SeedSequence(seed)
    realization r         = root.spawn(R)[r]                 (per realization)
      node n              = realization.spawn(N)[n]          (per node, 0 = top node)
        sensor stream k   = node.spawn(len(SENSOR_STREAMS))[k]   in the order of SENSOR_STREAMS
      link l              = realization.spawn(N + L)[N + l]  (per link, after the node children; L = 2N:
                                                          down link l feeds node l + 1, up link N + l
                                                          carries surveys from node l + 1)
      radio hop h         = realization.spawn(3N + H)[3N + h]  (per physical hop h = 0..N-1, after the
                                                          links: its shadowing draws)
      skip link of node h = realization.spawn(4N + ...)[4N + h]   (the ad-hoc fallback from node h, 1-based,
                                                          to the node after its neighbour)

Realization index r of a run is ``simulation.first_realization + i`` for its i-th realization (i = 0..R-1):
a run with R realizations is exactly the R runs of one realization each with first_realization = r, and
every realization's draws are independent of R (the batched-equals-one-by-one test checks it).
Per-transmission draws on link l, in order, per attempt of a realization that attempts: the data-frame
loss uniform; with the ARQ MAC the ACK loss uniform; on a burst-loss hop the Gilbert-Elliott state and
loss uniforms.

Child ``n`` of a ``SeedSequence`` depends only on the parent entropy and ``n`` (its ``spawn_key``), so
the streams above are stable however many siblings are spawned.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

SENSOR_STREAMS: tuple[str, ...] = ("gyro", "accel", "encoder", "magnetometer", "clock")
"""Per-node stream names, in spawn order.  Append new names at the end only."""


def _child(parent: np.random.SeedSequence, index: int) -> np.random.SeedSequence:
    """Child ``index`` of ``parent`` without mutating the parent's spawn counter."""
    return np.random.SeedSequence(parent.entropy, spawn_key=parent.spawn_key + (index,))


@lru_cache(maxsize=4096)
def _realization_seq(seed: int, index: int) -> np.random.SeedSequence:
    """Realization ``index`` of root ``seed`` (cached: every stream of a realization starts here; a
    SeedSequence is not changed by building children with :func:`_child`)."""
    return _child(np.random.SeedSequence(seed), index)


@lru_cache(maxsize=1 << 16)
def _node_seq(seed: int, realization: int, node: int) -> np.random.SeedSequence:
    """Node ``node`` of realization ``realization`` (cached: each of its sensor streams starts here)."""
    return _child(_realization_seq(seed, realization), node)


@dataclass(frozen=True)
class RunStreams:
    """Factory of the named random streams of one run (root seed -> realizations -> nodes/links)."""

    seed: int
    n_nodes: int
    first_realization: int = 0

    def _realization(self, r: int) -> np.random.SeedSequence:
        return _realization_seq(self.seed, self.first_realization + r)

    def sensor(self, realization: int, node: int, stream: str) -> np.random.Generator:
        """Generator for sensor ``stream`` (one of :data:`SENSOR_STREAMS`) of ``node`` in ``realization``."""
        k = SENSOR_STREAMS.index(stream)
        return np.random.default_rng(_child(_node_seq(self.seed, self.first_realization + realization, node), k))

    def link(self, realization: int, link: int) -> np.random.Generator:
        """Generator for link ``link`` (0 = encoder/top hop) in ``realization``."""
        return np.random.default_rng(_child(self._realization(realization), self.n_nodes + link))

    def radio(self, realization: int, hop: int) -> np.random.Generator:
        """Generator for the radio hop ``hop`` (0 = surface to the top node) in ``realization``."""
        return np.random.default_rng(_child(self._realization(realization), 3 * self.n_nodes + hop))

    def skip_link(self, realization: int, node: int) -> np.random.Generator:
        """Generator for the fallback skip link of node ``node`` (1-based sender) in ``realization``."""
        return np.random.default_rng(_child(self._realization(realization), 4 * self.n_nodes + node))

    def sensor_batch(self, realizations: int, node: int, stream: str) -> list[np.random.Generator]:
        """One generator per realization for a (node, stream): used to draw batched noise arrays."""
        return [self.sensor(r, node, stream) for r in range(realizations)]
