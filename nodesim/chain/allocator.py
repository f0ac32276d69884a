"""Keeping freed memory for the next batched run (glibc's malloc), instead of handing it back to the kernel.

A batched run (R realizations at once) allocates and frees a few hundred MB of (R, K) arrays per call: 1000
realizations of a 20-node chain over 120 s take ~700 MB of records.  glibc serves blocks above its mmap threshold
(128 kB, raised dynamically up to 32 MB) with fresh mmaps and returns the top of its heap to the kernel above a trim
threshold, so every call touches fresh pages again: a page fault per 4 kB, ~0.15-0.3 s of such a call's ~1 s on
one thread (issue 20, ``batched_mc_speedup_one_thread``; ``MALLOC_MMAP_THRESHOLD_`` / ``MALLOC_TRIM_THRESHOLD_`` in
the environment cut the 1000-realization batch from 1.10 to 0.78 s, min of 5).

:func:`keep_freed_memory` sets both once per process (``mallopt``: blocks up to 32 MB come from the heap, and the
heap is trimmed only past 2 GB free), so a batch reuses the pages the previous one freed: the "reusing buffers
between batches" of issue 20, done by the allocator rather than by a pool of arrays (measured in one process
each, interleaved, 2026-12-03, load ~1.8: the batch's min of 5 on one thread 0.97 / 1.00 s with glibc's defaults,
0.69 / 0.71 s with these).  The price: the process's resident memory does not shrink after a batched run (what
it freed stays for reuse).  The chain engine calls it for batched runs only (R > 1); a single-realization run,
the drilling day included, keeps glibc's defaults unless a batched run came first in the process.  Elsewhere
than glibc (or without ctypes) it does nothing.  It changes where memory comes from, never a result.
"""

from __future__ import annotations

import ctypes

from nodesim.io.libc import libc_function

M_TRIM_THRESHOLD = -1  # glibc malloc.h
M_MMAP_THRESHOLD = -3
MMAP_THRESHOLD_BYTES = 32 * 2**20  # glibc's largest (HEAP_MAX_SIZE / 2 on 64-bit)
TRIM_THRESHOLD_BYTES = 2**31 - 1  # the largest mallopt takes (an int): the heap is trimmed only past 2 GB free

_done = False


def keep_freed_memory() -> bool:
    """Set glibc's mmap and trim thresholds (module docstring) once per process; True if they are set."""
    global _done
    _done = _done or _mallopt((M_MMAP_THRESHOLD, MMAP_THRESHOLD_BYTES), (M_TRIM_THRESHOLD, TRIM_THRESHOLD_BYTES))
    return _done


def _mallopt(*settings: tuple[int, int]) -> bool:
    """glibc's ``mallopt(option, value)`` for each (option, value), in order; True if every one is set (False
    where there is no mallopt)."""
    mallopt = libc_function("mallopt", [ctypes.c_int, ctypes.c_int])
    return mallopt is not None and all(bool(mallopt(option, value)) for option, value in settings)


M_ARENA_MAX = -8  # glibc malloc.h
STREAMED_ARENAS = 2

_arenas_limited = False


def limit_arenas() -> bool:
    """At most :data:`STREAMED_ARENAS` malloc arenas in the process (``mallopt(M_ARENA_MAX)``; glibc's default is 8
    per core), once per process; True if set.  A streamed run calls it before its threads start: each thread that
    allocates under contention gets an arena of its own, and the node arrays one thread makes and another frees
    stay as free blocks in the maker's arena, reused only there, so the resident memory grew with the size of
    those arrays, i.e. with the run's duration.  Measured (``/usr/bin/time``, 2026-12-05): the drilling day's first
    hour / first two hours peaked at 0.407 / 0.455 GB with glibc's default, 0.365 / 0.386 GB with 2 arenas (0.361
    / 0.385 with 1), at the same speed; the whole day 55.5-55.7 s and 0.95 GB with 2 arenas, 57.0-57.6 s and
    0.86-0.91 GB without (``malloc_trim`` every few nodes did as well on the hours, but cost the day ~7 s of page
    faults).  It changes where memory comes from, never a result; elsewhere than glibc it does nothing."""
    global _arenas_limited
    _arenas_limited = _arenas_limited or _mallopt((M_ARENA_MAX, STREAMED_ARENAS))
    return _arenas_limited
