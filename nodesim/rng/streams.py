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
      up skip link of h   = realization.spawn(5N + ...)[5N + h]   (node h's surveys past a silent neighbour
                                                          above, to node h - 2)
      bit errors of a link = child 0 of that link's (or skip link's) SeedSequence: its key for the
                                                          counter-based bit-error stream (mac.bit_errors,
                                                          nodesim.chain.bit_errors), the first uint64 word

Realization index r of a run is ``simulation.first_realization + i`` for its i-th realization (i = 0..R-1):
a run with R realizations is exactly the R runs of one realization each with first_realization = r, and
every realization's draws are independent of R (the batched-equals-one-by-one test checks it).
Per-transmission draws on link l, in order, per attempt of a realization that attempts: the data-frame
loss uniform; with the ARQ MAC the ACK loss uniform; on a burst-loss hop the Gilbert-Elliott state and
loss uniforms.

Child ``n`` of a ``SeedSequence`` depends only on the parent entropy and ``n`` (its ``spawn_key``), so
the streams above are stable however many siblings are spawned: the stream with path (r, n, k) is
``default_rng(SeedSequence(seed, spawn_key=(r, n, k)))``.  Building thousands of them one by one costs
~10 us each in numpy; the ``*_batch`` methods build the same generators for all realizations at once with
:func:`seed_states`, numpy's SeedSequence hash (``numpy/random/bit_generator.pyx``, after O'Neill's
``seed_seq_fe``) compiled over spawn keys (tests check it bit for bit against numpy).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.random.bit_generator import ISeedSequence

from numba import njit

from nodesim import threads
from nodesim.rng import pcg64

SENSOR_STREAMS: tuple[str, ...] = ("gyro", "accel", "encoder", "magnetometer", "clock", "tilt", "gyro_samples",
                                   "accel_samples", "reference", "gyro_bias")
"""Per-node stream names, in spawn order.  Append new names at the end only."""

POOL_WORDS = 4
"""numpy's default SeedSequence pool size (32-bit words)."""
_INIT_A, _MULT_A, _INIT_B, _MULT_B = 0x43B0D7E5, 0x931E8875, 0x8B51F9DD, 0x58F38DED
_MIX_L, _MIX_R, _MASK32 = 0xCA01F9DD, 0x4973F715, 0xFFFFFFFF


def _words(value: int) -> list[int]:
    """A non-negative integer as little-endian 32-bit words (numpy's ``_coerce_to_uint32_array``; 0 -> [0])."""
    out = [value & _MASK32]
    value >>= 32
    while value:
        out.append(value & _MASK32)
        value >>= 32
    return out


_U32 = np.uint64(_MASK32)
_S16 = np.uint64(16)


@njit(cache=True, inline="always")
def _hashmix(value, const, mult):
    """hashmix: v ^= c; c *= mult; v *= c; v ^= v >> 16 in uint32 arithmetic (held in uint64 words, masked);
    returns (v, the next c)."""
    value = (value ^ const) & _U32
    const = (const * mult) & _U32
    value = (value * const) & _U32
    return value ^ (value >> _S16), const


@njit(cache=True, inline="always")
def _mix(x, y):
    """mix: r = MIX_MULT_L x - MIX_MULT_R y; r ^= r >> 16 (uint32 arithmetic, held in uint64 words, masked)."""
    r = (np.uint64(_MIX_L) * x - np.uint64(_MIX_R) * y) & _U32
    return r ^ (r >> _S16)


@njit(cache=True, nogil=True)
def _seed_words_kernel(run_words, keys, out) -> None:
    """``out[m]`` (4 uint64) = numpy's ``generate_state(4, uint64)`` of the entropy ``run_words`` (the seed's
    32-bit words, zero-padded to the pool size) followed by ``keys[m]`` (:func:`seed_states`)."""
    n_run, n_key = run_words.size, keys.shape[1]
    entropy = np.empty(n_run + n_key, np.uint64)
    entropy[:n_run] = run_words
    pool = np.empty(POOL_WORDS, np.uint64)
    word = np.empty(2 * POOL_WORDS, np.uint64)
    for m in range(keys.shape[0]):
        entropy[n_run:] = keys[m]
        const = np.uint64(_INIT_A)
        for i in range(POOL_WORDS):
            pool[i], const = _hashmix(entropy[i], const, np.uint64(_MULT_A))
        for src in range(POOL_WORDS):
            for dst in range(POOL_WORDS):
                if src != dst:
                    h, const = _hashmix(pool[src], const, np.uint64(_MULT_A))
                    pool[dst] = _mix(pool[dst], h)
        for src in range(POOL_WORDS, entropy.size):
            for dst in range(POOL_WORDS):
                h, const = _hashmix(entropy[src], const, np.uint64(_MULT_A))
                pool[dst] = _mix(pool[dst], h)
        const = np.uint64(_INIT_B)
        for i in range(2 * POOL_WORDS):
            word[i], const = _hashmix(pool[i % POOL_WORDS], const, np.uint64(_MULT_B))
        for j in range(POOL_WORDS):  # the 32-bit words read little-endian as uint64
            out[m, j] = word[2 * j] | (word[2 * j + 1] << np.uint64(32))


def seed_states(seed: int, keys: np.ndarray) -> np.ndarray:
    """``SeedSequence(seed, spawn_key=key).generate_state(4, np.uint64)`` for every row of ``keys``.

    keys: (M, S) non-negative integers < 2**32 (one 32-bit word each); returns (M, 4) uint64.  numpy's
    algorithm, compiled, one row after the other (:func:`_seed_words_kernel`): entropy = words(seed) zero-padded
    to the pool size, then the key words; pool mixing (``mix_entropy``) with the hashmix/mix functions above,
    then ``generate_state`` cycles the pool through a second hash (INIT_B, MULT_B) for 8 words viewed
    little-endian as 4 uint64.
    """
    keys = np.asarray(keys, dtype=np.int64)
    if keys.ndim != 2 or (keys.size and (keys.min() < 0 or keys.max() > _MASK32)):
        raise ValueError("spawn keys must be a 2-D array of integers in [0, 2**32)")
    run = _words(int(seed))
    run += [0] * (POOL_WORDS - len(run))
    out = np.empty((keys.shape[0], POOL_WORDS), np.uint64)
    _seed_words_kernel(np.array(run, np.uint64), keys.astype(np.uint64), out)
    return out


class _Precomputed(ISeedSequence):
    """A seed sequence whose 4-word uint64 state is already known (from :func:`seed_states`)."""

    __slots__ = ("state",)

    def __init__(self, state: np.ndarray):
        self.state = state

    def generate_state(self, n_words: int, dtype=np.uint32) -> np.ndarray:
        if n_words != POOL_WORDS or np.dtype(dtype) != np.uint64:
            raise ValueError("a precomputed seed state serves PCG64 only (4 uint64 words)")
        return self.state


VECTOR_MIN_KEYS = 16
"""Below this many keys :func:`seed_words` asks numpy's own SeedSequence (as single-realization runs always have);
the compiled hash of :func:`seed_states` would be faster there too (~6 us a call against ~17 us per key)."""


def seed_words(seed: int, keys: np.ndarray) -> np.ndarray:
    """``SeedSequence(seed, spawn_key=k).generate_state(4, uint64)`` for every row k of ``keys``, (M, 4): numpy's
    own below :data:`VECTOR_MIN_KEYS` keys, :func:`seed_states` from there on (the same words)."""
    keys = np.asarray(keys, dtype=np.int64)
    if len(keys) >= VECTOR_MIN_KEYS:
        return seed_states(seed, keys)
    words = np.zeros((len(keys), POOL_WORDS), dtype=np.uint64)
    for i, k in enumerate(keys):
        words[i] = np.random.SeedSequence(seed, spawn_key=tuple(int(x) for x in k)).generate_state(4, np.uint64)
    return words


def generators(seed: int, keys: np.ndarray) -> list[np.random.Generator]:
    """``[default_rng(SeedSequence(seed, spawn_key=k)) for k in keys]``: the same generators, seeded through
    :func:`seed_words` (~250x faster per key for 1000 keys)."""
    return [np.random.Generator(np.random.PCG64(_Precomputed(w))) for w in seed_words(seed, keys)]


def pcg64_states(seed: int, keys: np.ndarray) -> np.ndarray:
    """The PCG64 states (M, 4) of ``generators(seed, keys)``, to draw from with :mod:`nodesim.rng.pcg64`
    (the same numbers as those generators, without building them)."""
    return pcg64.seeded(seed_words(seed, keys))


@dataclass(frozen=True)
class RunStreams:
    """Factory of the named random streams of one run (root seed -> realizations -> nodes/links).

    Each stream has a spawn-key path (module docstring); ``sensor``/``link``/... build one generator the
    numpy way, the ``*_batch`` methods build one per realization with :func:`generators`."""

    seed: int
    n_nodes: int
    first_realization: int = 0

    def _one(self, *path: int) -> np.random.Generator:
        return np.random.default_rng(np.random.SeedSequence(self.seed, spawn_key=path))

    def _keys(self, realizations: int, *path: int) -> np.ndarray:
        r = np.arange(self.first_realization, self.first_realization + realizations)
        return np.column_stack([r] + [np.full(realizations, p) for p in path]) if realizations else np.zeros((0, 1 + len(path)))

    def _batch(self, realizations: int, *path: int) -> list[np.random.Generator]:
        return generators(self.seed, self._keys(realizations, *path))

    def _sensor_path(self, node: int, stream: str) -> tuple[int, int]:
        return node, SENSOR_STREAMS.index(stream)

    def sensor(self, realization: int, node: int, stream: str) -> np.random.Generator:
        """Generator for sensor ``stream`` (one of :data:`SENSOR_STREAMS`) of ``node`` in ``realization``."""
        return self._one(self.first_realization + realization, *self._sensor_path(node, stream))

    def sensor_states(self, realizations: int, node: int, stream: str) -> np.ndarray:
        """(realizations, 4): the PCG64 states of each realization's :meth:`sensor` stream, to draw from in a
        compiled kernel (:mod:`nodesim.rng.pcg64`; the same numbers as the generators)."""
        return pcg64_states(self.seed, self._keys(realizations, *self._sensor_path(node, stream)))

    def sensor_normals(self, realizations: int, node: int, stream: str, n: int) -> np.ndarray:
        """(realizations, n): the first ``n`` ``standard_normal()`` draws of each realization's :meth:`sensor`
        stream, drawn by the compiled PCG64 kernel (ranges of realizations on threads, :mod:`nodesim.threads`)."""
        out = np.empty((realizations, n))
        states = self.sensor_states(realizations, node, stream)
        threads.map_chunks(lambda r0, r1: pcg64.fill_normals(states[r0:r1], out[r0:r1]), realizations)
        return out

    def _link_child(self, link: int) -> int:
        """Realization child index of link ``link``'s stream (after the node children)."""
        return self.n_nodes + link

    def _skip_child(self, node: int, up: bool = False) -> int:
        """Realization child index of node ``node``'s fallback skip-link stream (after the radio hops; ``up``: its
        survey skip link up to node - 2, after those)."""
        return (5 if up else 4) * self.n_nodes + node

    def link(self, realization: int, link: int) -> np.random.Generator:
        """Generator for link ``link`` (0 = encoder/top hop) in ``realization``."""
        return self._one(self.first_realization + realization, self._link_child(link))

    def link_batch(self, realizations: int, link: int) -> list[np.random.Generator]:
        """:meth:`link` for realizations 0..realizations-1."""
        return self._batch(realizations, self._link_child(link))

    def link_states(self, realizations: int, link: int) -> np.ndarray:
        """:meth:`link_batch` as PCG64 states (realizations, 4) for :mod:`nodesim.rng.pcg64`."""
        return pcg64_states(self.seed, self._keys(realizations, self._link_child(link)))

    def radio(self, realization: int, hop: int) -> np.random.Generator:
        """Generator for the radio hop ``hop`` (0 = surface to the top node) in ``realization``."""
        return self._one(self.first_realization + realization, 3 * self.n_nodes + hop)

    def radio_batch(self, realizations: int, hop: int) -> list[np.random.Generator]:
        """:meth:`radio` for realizations 0..realizations-1."""
        return self._batch(realizations, 3 * self.n_nodes + hop)

    def skip_link(self, realization: int, node: int) -> np.random.Generator:
        """Generator for the fallback skip link of node ``node`` (1-based sender) in ``realization``."""
        return self._one(self.first_realization + realization, self._skip_child(node))

    def skip_link_batch(self, realizations: int, node: int, up: bool = False) -> list[np.random.Generator]:
        """:meth:`skip_link` for realizations 0..realizations-1 (``up``: node ``node``'s survey skip link)."""
        return self._batch(realizations, self._skip_child(node, up))

    def skip_link_states(self, realizations: int, node: int, up: bool = False) -> np.ndarray:
        """:meth:`skip_link_batch` as PCG64 states (realizations, 4) for :mod:`nodesim.rng.pcg64`."""
        return pcg64_states(self.seed, self._keys(realizations, self._skip_child(node, up)))

    def bit_error_keys(self, realizations: int, link: int) -> np.ndarray:
        """Link ``link``'s bit-error keys (realizations,) uint64 (module docstring: child 0 of its stream)."""
        return seed_words(self.seed, self._keys(realizations, self._link_child(link), 0))[:, 0].copy()

    def skip_bit_error_keys(self, realizations: int, node: int, up: bool = False) -> np.ndarray:
        """The bit-error keys of node ``node``'s fallback skip link (1-based sender; ``up``: its survey skip link)."""
        return seed_words(self.seed, self._keys(realizations, self._skip_child(node, up), 0))[:, 0].copy()
