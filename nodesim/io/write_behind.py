"""Write-behind for a large file written once from start to end: its pages leave the page cache as soon as the
disk has them, so the next blocks reuse the same memory instead of taking fresh pages.

A run's streamed timeseries table is gigabytes (the drilling day's Parquet file: 4.4 GB) that nothing reads back
while the run goes on.  Written plainly, every page of it stays in the page cache, which takes a fresh page of
memory for each 4 kB written.  On a virtual machine whose free memory goes back to the host (virtio-balloon free
page reporting, as on this project's machines), a fresh page costs far more than a reused one: writing 4 GB took
9.5-10.7 s of CPU plainly and 1.4-1.6 s with write-behind (4 MB writes, 2026-12-04, Linux 6.18, 2 vCPUs).

:class:`WriteBehind` follows the file's length as the writer appends to it (:meth:`advance`): it asks the kernel to
start writing out what is new (``sync_file_range(SYNC_FILE_RANGE_WRITE)``, which does not wait) and drops from the
cache what it started :data:`LAG_BYTES` earlier, on disk by then (``SYNC_FILE_RANGE_WAIT_*`` for what is not, then
``posix_fadvise(POSIX_FADV_DONTNEED)``).  It never changes the file's bytes, only where they are kept.  Where the
calls are missing (not Linux, no glibc) it does nothing.
"""

from __future__ import annotations

import ctypes
import os

from nodesim.io.libc import libc_function

SYNC_FILE_RANGE_WAIT_BEFORE, SYNC_FILE_RANGE_WRITE, SYNC_FILE_RANGE_WAIT_AFTER = 1, 2, 4  # <fcntl.h>

MIN_STEP_BYTES = 4 * 2**20
""":meth:`WriteBehind.advance` acts once this many new bytes have come (a system call per few MB, not per write)."""

LAG_BYTES = 32 * 2**20
"""What :meth:`WriteBehind.advance` leaves in the cache behind the file's end: it drops what it started writing out
at least this long ago.  Dropping what the previous call started (one step, ~4 MB) made the writer wait for the disk:
2.1 s of the drilling day's writer thread (2026-12-05), the thread the others queue their rows for."""

ALIGN_BYTES = 2**20  # the dropped ranges end on this boundary (whole pages: none is left behind between two calls)


def sync_file_range():
    """The C library's ``sync_file_range`` (Linux), or None (then :class:`WriteBehind` does nothing)."""
    if not hasattr(os, "posix_fadvise"):
        return None
    return libc_function("sync_file_range", [ctypes.c_int, ctypes.c_int64, ctypes.c_int64, ctypes.c_uint])


class WriteBehind:
    """Write-behind (module docstring) for the file at ``path``, which another handle appends to."""

    def __init__(self, path):
        self._call = sync_file_range()
        self._fd = os.open(path, os.O_RDONLY) if self._call is not None else None
        self._started = 0  # bytes whose writing out was started
        self._dropped = 0  # bytes dropped from the cache

    def advance(self) -> None:
        """Start writing out what the file gained since the last call and drop what was started
        :data:`LAG_BYTES` before."""
        if self._fd is None:
            return
        size = os.fstat(self._fd).st_size
        if size - self._started < MIN_STEP_BYTES:
            return
        self._call(self._fd, self._started, size - self._started, SYNC_FILE_RANGE_WRITE)
        self._started = size
        done = (size - LAG_BYTES) // ALIGN_BYTES * ALIGN_BYTES  # started at least LAG_BYTES ago: on disk, mostly
        if done > self._dropped:
            if self._call(self._fd, self._dropped, done - self._dropped,
                          SYNC_FILE_RANGE_WAIT_BEFORE | SYNC_FILE_RANGE_WRITE | SYNC_FILE_RANGE_WAIT_AFTER) == 0:
                os.posix_fadvise(self._fd, self._dropped, done - self._dropped, os.POSIX_FADV_DONTNEED)
            self._dropped = done

    def close(self) -> None:
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None
