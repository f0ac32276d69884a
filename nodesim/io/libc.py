"""The C library's functions that Python's ``os`` module lacks, through ctypes, where they exist (Linux, glibc):
``renameat2`` (:mod:`nodesim.io.rundir`), ``sync_file_range`` (:mod:`nodesim.io.write_behind`), ``mallopt``
(:mod:`nodesim.chain.allocator`).  Each caller has a fallback for where :func:`libc_function` returns None."""

from __future__ import annotations

import ctypes
import ctypes.util
import sys


def libc_function(name: str, argtypes: list, restype=ctypes.c_int):
    """The C library's function ``name`` with these argument and result types, or None where there is none (not
    Linux, no C library found, no such function); errno is kept for ``ctypes.get_errno``."""
    if not sys.platform.startswith("linux"):
        return None
    try:
        function = getattr(ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True), name)
    except (OSError, AttributeError):
        return None
    function.argtypes, function.restype = argtypes, restype
    return function
