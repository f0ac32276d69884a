"""Arrays kept on disk, not in the process's memory: the whole-run tables of a streamed compiled run (issue 20).

A streamed run holds a few nodes' records at a time, but the compiled engine's phase 1 needs tables over every
node-tick of the run before phase 2 starts: the tick times (8 bytes a node-tick), the tick plan (1) and phase 1's
records (which estimate reaches which tick: 6 bytes a node-tick and realization).  Phase 1
writes them in time order, a chunk of events at a time, and phase 2 reads them a node at a time; neither needs the
rest in memory.  :class:`ScratchArrays` keeps such arrays in an unlinked temporary file (its blocks reserved at once
with ``posix_fallocate``: a full disk is a clear error before the run, never a SIGBUS in it), memory-mapped shared,
and :meth:`ScratchArrays.drop` takes their pages out of the process (``madvise(MADV_DONTNEED)``: a shared file
mapping keeps its contents in the file, and the next read maps them again).  The engine drops them after each chunk
of phase 1 and every few nodes of phase 2, so the run's peak resident memory no longer grows with its duration, and
starts writing them out to the disk as they are made (:meth:`ScratchArrays.write_out`), not in one burst later.  The
values are the same wherever they are kept: the kernel only decides where the bytes live.

The file goes to the temporary directory (``TMPDIR``); where that is a RAM file system (tmpfs), nothing is spilled
(:func:`scratch_directory`): its pages would stay in memory, only no longer counted in the process's.
"""

from __future__ import annotations

import math
import mmap
import os
import tempfile
import threading
import weakref
from pathlib import Path

import numpy as np

from nodesim.errors import NodesimError
from nodesim.io.write_behind import SYNC_FILE_RANGE_WRITE, sync_file_range

SPILL_MIN_BYTES = 64 * 2**20
"""A streamed compiled run keeps its whole-run tables on disk when they would take more than this in memory."""

FILL_BYTES = 64 * 2**20
""":meth:`ScratchArrays.fill` writes its value this many bytes at a time, dropping each slice's pages after it."""

DROP_EVERY_ROWS = 64
"""A table built a node's row at a time (tick times, tick plan) drops its pages every this many rows."""

RAM_FILE_SYSTEMS = ("tmpfs", "ramfs", "devtmpfs")


def _mount_type(path: Path) -> str | None:
    """The file system type of the mount that holds ``path`` (Linux: /proc/mounts, longest matching mount point)."""
    try:
        with open("/proc/mounts", encoding="utf-8") as f:
            mounts = [line.split()[1:3] for line in f if len(line.split()) >= 3]
    except OSError:
        return None
    path = path.resolve()
    best, kind = -1, None
    for point, fstype in mounts:
        point = point.replace("\\040", " ")
        if (path == Path(point) or Path(point) in path.parents) and len(point) > best:
            best, kind = len(point), fstype
    return kind


def scratch_directory() -> Path | None:
    """Where a run's scratch arrays go: the temporary directory, unless it is a RAM file system (or madvise is not
    there: not Linux), then None (nothing is spilled)."""
    if not hasattr(mmap, "MADV_DONTNEED"):
        return None
    directory = Path(tempfile.gettempdir())
    return None if _mount_type(directory) in RAM_FILE_SYSTEMS else directory


def whole_run_table_bytes(n_nodes: int, k_max: int, realizations: int, bit_errors: bool) -> int:
    """The bytes of a compiled run's whole-run tables (module docstring), padded to the longest node's ticks: tick
    times and plan, phase 1's records per realization (with ``mac.bit_errors``, each tick's try and BER too: 16
    bytes more)."""
    return n_nodes * k_max * (9 + realizations * (6 + (16 if bit_errors else 0)))


def spills(n_nodes: int, k_max: int, realizations: int, bit_errors: bool) -> bool:
    """Whether a streamed compiled run of this size keeps its whole-run tables on disk (:data:`SPILL_MIN_BYTES`,
    :func:`scratch_directory`)."""
    return (whole_run_table_bytes(n_nodes, k_max, realizations, bit_errors) > SPILL_MIN_BYTES
            and scratch_directory() is not None)


class ScratchArrays:
    """Arrays in an unlinked file of ``directory`` (module docstring); each :meth:`empty` / :meth:`full` maps a
    region of its own.  ``drop()`` takes every array's pages out of the process's resident memory."""

    def __init__(self, directory: Path):
        self.directory = Path(directory)
        self._maps: list[mmap.mmap] = []
        self._regions: list[tuple[int, int, int]] = []  # (address, bytes, descriptor) of each array's mapping
        self.nbytes = 0

    def empty(self, shape: tuple, dtype) -> np.ndarray:
        """A new array of ``shape`` and ``dtype`` in the file, every byte 0 (the file's unwritten blocks)."""
        dtype = np.dtype(dtype)
        size = max(math.prod(shape) * dtype.itemsize, 1)
        with tempfile.TemporaryFile(dir=self.directory, prefix="nodesim-scratch-") as f:
            try:
                os.posix_fallocate(f.fileno(), 0, size)
            except OSError as err:
                free = free_disk_bytes(self.directory)[0]
                raise NodesimError(
                    f"the run's whole-run tables need {size / 1e9:.3g} GB more of scratch space in {self.directory} "
                    f"(the temporary directory; TMPDIR chooses it) and it has {free / 1e9:.3g} GB free ({err.strerror}): "
                    "free some, point TMPDIR elsewhere, or lower chain.nodes / simulation.duration_s") from None
            m = mmap.mmap(f.fileno(), size)  # shared, read-write; the mapping outlives the (unlinked) file's descriptor
            fd = os.dup(f.fileno())  # for write(); closed with this object
            weakref.finalize(self, os.close, fd)
        if hasattr(mmap, "MADV_RANDOM"):  # a read maps its page, not the large folio around it (up to ~1 MB on Linux 6)
            m.madvise(mmap.MADV_RANDOM)
        self._maps.append(m)
        self.nbytes += size
        a = np.frombuffer(m, dtype=dtype, count=math.prod(shape)).reshape(shape)
        self._regions.append((a.ctypes.data, size, fd))
        return a

    def write(self, a: np.ndarray, values: np.ndarray) -> None:
        """``a[...] = values`` for ``a`` a contiguous part of one of these arrays, written to the file
        (``pwrite``) instead of through the mapping: the kernel copies the bytes in without a page fault per 4 kB
        page of the process (a mapped page's first write faults).  The drilling day's tick table (1.3 GB):
        0.46-0.49 s against 1.35-1.42 s through the mapping (2026-12-06).  The mapping reads the same bytes."""
        if not a.flags.c_contiguous:
            raise ValueError("ScratchArrays.write: the target is not contiguous")
        if a.size == 0:
            return
        data = np.ascontiguousarray(np.broadcast_to(values, a.shape), dtype=a.dtype)
        address = a.ctypes.data
        for start, size, fd in self._regions:
            if start <= address and address + a.nbytes <= start + size:
                view, at = memoryview(data).cast("B"), address - start
                while view.nbytes:
                    done = os.pwrite(fd, view, at)
                    view, at = view[done:], at + done
                return
        raise ValueError("ScratchArrays.write: the target is not one of these arrays")

    def fill(self, a: np.ndarray, value) -> None:
        """Set every element of ``a`` (one of these arrays, contiguous) to ``value``, :data:`FILL_BYTES` at a time,
        dropping the pages after each slice."""
        flat = a.reshape(-1)  # a view (contiguous)
        step = max(FILL_BYTES // max(a.itemsize, 1), 1)
        for i in range(0, flat.size, step):
            flat[i:i + step] = value
            self.drop()

    def drop(self) -> None:
        """Take every array's pages out of the process (their values stay in the file: the next read maps them)."""
        for m in self._maps:
            m.madvise(mmap.MADV_DONTNEED)

    def write_out(self) -> None:
        """Start writing the arrays' pages written so far to the file, on a thread of its own
        (``sync_file_range(SYNC_FILE_RANGE_WRITE)``, which waits only for the disk's queue), and return at once: the
        values stay where they are (the kernel writes its page cache out, nothing more).  A table written whole
        before the run's work (the tick times, the tick plan) is written out at once, on the core the set-up and
        the start of phase 1 leave idle, and phase 1's records as it goes (each time it drops their pages), instead
        of when their pages are ~30 s old: the kernel then wrote the drilling day's ~1.9 GB of dirty pages in one
        burst 33-43 s in, its flusher taking CPU from the run's threads, every thread slower for 1-2 s.  Measured
        (the day as a whole process, /proc/meminfo's Dirty and the threads' CPU time every 0.5 s, 2026-12-07): dirty
        pages at most ~40 MB against 1.9 GB, and the cores left idle after phase 1 4.0 core-seconds against 8.0 and
        8.0 (5.5 with only the tick times and plan written out)."""
        call = sync_file_range()
        if call is None:
            return
        descriptors = [fd for _, _, fd in self._regions]
        threading.Thread(target=lambda: [call(fd, 0, 0, SYNC_FILE_RANGE_WRITE) for fd in descriptors],
                         name="nodesim-write-out", daemon=True).start()


def free_disk_bytes(directory) -> tuple[float, int | None]:
    """(free bytes, device) of the file system that holds ``directory`` (its nearest existing parent); (inf, None)
    where it cannot be read."""
    path = Path(directory).resolve()
    while not path.exists() and path != path.parent:
        path = path.parent
    try:
        st = os.statvfs(path)
        return float(st.f_bavail * st.f_frsize), os.stat(path).st_dev
    except OSError:
        return float("inf"), None


def zeros(arrays: ScratchArrays | None, shape: tuple, dtype) -> np.ndarray:
    """A zero array of ``shape``: in ``arrays`` (:meth:`ScratchArrays.empty`), or in memory where it is None."""
    return np.zeros(shape, dtype) if arrays is None else arrays.empty(shape, dtype)


def fill(arrays: ScratchArrays | None, a: np.ndarray, value) -> None:
    """Set every element of ``a`` to ``value`` (:meth:`ScratchArrays.fill` a slice at a time where it is in them)."""
    if arrays is None:
        a[...] = value
    else:
        arrays.fill(a, value)


def write(arrays: ScratchArrays | None, a: np.ndarray, values: np.ndarray) -> None:
    """``a[...] = values``: :meth:`ScratchArrays.write` where ``a`` is in them, else in memory."""
    if arrays is None:
        a[...] = values
    else:
        arrays.write(a, values)


def drop(arrays: ScratchArrays | None) -> None:
    """:meth:`ScratchArrays.drop`; nothing where the tables are in memory."""
    if arrays is not None:
        arrays.drop()


def write_out(arrays: ScratchArrays | None) -> None:
    """:meth:`ScratchArrays.write_out`; nothing where the tables are in memory."""
    if arrays is not None:
        arrays.write_out()
