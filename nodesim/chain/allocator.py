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
    if _done:
        return True
    mallopt = libc_function("mallopt", [ctypes.c_int, ctypes.c_int])
    if mallopt is None:
        return False
    _done = bool(mallopt(M_MMAP_THRESHOLD, MMAP_THRESHOLD_BYTES)) and bool(mallopt(M_TRIM_THRESHOLD,
                                                                                   TRIM_THRESHOLD_BYTES))
    return _done
