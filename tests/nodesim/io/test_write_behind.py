"""nodesim.io.write_behind: a file written through it keeps its bytes, and what is on disk leaves the page cache."""

from __future__ import annotations

import ctypes
import mmap
import os
import sys

import pytest

from nodesim.io import write_behind
from nodesim.io.write_behind import WriteBehind
from nodesim.chain.scratch import _mount_type

MB = 2**20


def _resident_pages(path, length: int) -> list[bool]:
    """mincore(2) of the file's first ``length`` bytes mapped read-only: which pages are in the page cache."""
    libc = ctypes.CDLL("libc.so.6", use_errno=True)
    libc.mmap.restype, libc.mmap.argtypes = ctypes.c_void_p, [ctypes.c_void_p, ctypes.c_size_t, ctypes.c_int,
                                                             ctypes.c_int, ctypes.c_int, ctypes.c_long]
    libc.munmap.argtypes = [ctypes.c_void_p, ctypes.c_size_t]
    libc.mincore.argtypes = [ctypes.c_void_p, ctypes.c_size_t, ctypes.c_char_p]
    fd = os.open(path, os.O_RDONLY)
    try:
        addr = libc.mmap(None, length, mmap.PROT_READ, mmap.MAP_SHARED, fd, 0)
        pages = (length + mmap.PAGESIZE - 1) // mmap.PAGESIZE
        vec = ctypes.create_string_buffer(pages)
        assert libc.mincore(addr, length, vec) == 0, ctypes.get_errno()
        libc.munmap(addr, length)
    finally:
        os.close(fd)
    return [b & 1 == 1 for b in vec.raw]


def test_the_file_keeps_its_bytes(tmp_path, monkeypatch):
    monkeypatch.setattr(write_behind, "MIN_STEP_BYTES", 1000)
    path = tmp_path / "f.bin"
    blocks = [os.urandom(3000 + 7 * i) for i in range(20)]
    with open(path, "wb") as f:
        behind = WriteBehind(path)
        for b in blocks:
            f.write(b)
            f.flush()
            behind.advance()
        behind.close()
    assert path.read_bytes() == b"".join(blocks)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="sync_file_range and mincore are Linux calls")
def test_what_is_on_disk_leaves_the_page_cache_and_the_newest_stays(tmp_path, monkeypatch):
    if _mount_type(tmp_path) in ("tmpfs", "ramfs"):
        pytest.skip("a RAM file system keeps its pages: there is no disk to leave them to")
    path = tmp_path / "f.bin"
    step = write_behind.MIN_STEP_BYTES
    monkeypatch.setattr(write_behind, "LAG_BYTES", 2 * step)
    with open(path, "wb") as f:
        behind = WriteBehind(path)
        for _ in range(4):
            f.write(os.urandom(step))
            f.flush()
            behind.advance()
        resident = _resident_pages(path, 4 * step)
        behind.close()
    per_step = step // mmap.PAGESIZE
    first, second, third, fourth = (resident[i * per_step:(i + 1) * per_step] for i in range(4))
    assert not any(first) and not any(second)  # started two steps (LAG_BYTES) before a later call: dropped
    assert all(third) and all(fourth)  # the last LAG_BYTES of the file: still cached


def test_without_the_calls_it_does_nothing(tmp_path, monkeypatch):
    monkeypatch.setattr(write_behind, "sync_file_range", lambda: None)
    path = tmp_path / "f.bin"
    path.write_bytes(b"x" * 10)
    behind = WriteBehind(path)
    behind.advance()
    behind.close()
    assert path.read_bytes() == b"x" * 10
