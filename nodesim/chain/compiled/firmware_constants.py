"""The fixed-point firmware's phase 2 compiled for one firmware build: the build's words as constants.

:func:`.filters.run_node_firmware` reads the build's formats and constants (``params``, ``fparams``: word lengths,
fraction bits, saturation bounds, the encoder's and the filter's constant words) from two small arrays at every
step of every tick.  :func:`firmware_for` gives the same function with the two arrays' values as compile-time
constants (numba closure variables), so that LLVM folds the shifts, the saturation bounds and the divisions by
constants: the same integer operations on the same words, so the same words and records
(tests/nodesim/chain/test_firmware_constants.py; the drilling day's outputs are byte for byte those of the arrays).
The windows' firmware step (``time_windows._firmware``: the firmware, its frames and encoder words) on the drilling
day's first 4 h, thread time, three interleaved pairs of whole runs (2026-12-06, beside a test run): 2.84 / 3.23 /
3.39 s against 3.98 / 4.10 / 4.67 s with the arrays, ~25 % less.

The price is one compilation per build: 2.8 s (2026-12-06: tests/nodesim/chain/test_firmware_constants.py took
5.9 s against 3.1 s with it cached) when numba's cache already holds the firmware's functions for tuples, ~20 s
on a checkout whose cache is empty.  numba's cache on disk keeps it, keyed by the values, so a build's later runs
load it.  A run takes it only from :data:`MIN_NODE_TICKS` node-ticks on (the drilling day: 146 M), where the
saving (~50 ns a node-tick) is larger than the compilation.  numba keys a cached function by its own file only;
the key here also holds :func:`source_stamp` (the files compiled into it), so that an edit of the firmware
compiles it again instead of loading the old one.
"""

from __future__ import annotations

import functools
import hashlib
from pathlib import Path

import numpy as np
from numba import njit

import firmware_model
from nodesim.chain.compiled import filters

MIN_NODE_TICKS = 50_000_000
"""Runs with at least this many node-ticks (times realizations) run the firmware compiled for their build."""


def source_stamp() -> int:
    """A hash of the size and modification time of the files compiled into :func:`firmware_for`'s function
    (``firmware_model/*.py`` and this package's), which its cache key holds."""
    files = sorted(Path(firmware_model.__file__).parent.glob("*.py"))
    files += sorted(Path(filters.__file__).parent.glob("*.py"))
    text = repr([(f.name, f.stat().st_size, f.stat().st_mtime_ns) for f in files]).encode()
    return int.from_bytes(hashlib.sha256(text).digest()[:7], "little")  # the same in every process


def runner(params: np.ndarray, fparams: np.ndarray, node_ticks: int, six: bool):
    """:func:`.filters.run_node_firmware`, or for the 2-state firmware (not ``six``) in a run of ``node_ticks`` >=
    :data:`MIN_NODE_TICKS` the same compiled for the build's words (:func:`firmware_for`): called with the same
    arguments, the same results.  The 6-state node keeps its arrays: its equality with the constants is not tested
    (and its day is not the speed target)."""
    if six or node_ticks < MIN_NODE_TICKS:
        return filters.run_node_firmware
    return firmware_for(tuple(int(v) for v in params), tuple(int(v) for v in fparams))


@functools.lru_cache(maxsize=4)
def firmware_for(params: tuple[int, ...], fparams: tuple[int, ...]):
    """:func:`.filters.run_node_firmware` with ``params`` and ``fparams`` as constants (its own ``params`` and
    ``fparams`` arguments are ignored: they are the same words)."""
    P, FP, stamp = params, fparams, source_stamp()

    @njit(cache=True, _nrt=False, nogil=True)
    def run_node_firmware_for_build(states, params, fparams, counts, gyro_sums, accel_sums, n_samples, t, codes,
                                    k_end, init, applied, enc_yaw_raw, enc_rate_raw, enc_back_us, src_node, src_tick,
                                    up_t, rx_yaw_raw, rx_var_raw, inp, out, yaw_raw, var_raw, rate_raw, bias_raw, yaw,
                                    var, bias, ref_yaw, ref_var, r_first, r_end, six, params6, lane0, work) -> None:
        stamp  # noqa: B018 - in the closure, so in numba's cache key (module docstring)
        filters.run_node_firmware(states, P, FP, counts, gyro_sums, accel_sums, n_samples, t, codes, k_end, init,
                                  applied, enc_yaw_raw, enc_rate_raw, enc_back_us, src_node, src_tick, up_t,
                                  rx_yaw_raw, rx_var_raw, inp, out, yaw_raw, var_raw, rate_raw, bias_raw, yaw, var,
                                  bias, ref_yaw, ref_var, r_first, r_end, six, params6, lane0, work)

    return run_node_firmware_for_build
