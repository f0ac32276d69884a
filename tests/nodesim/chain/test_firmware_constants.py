"""The fixed firmware compiled for its build's words (nodesim.chain.compiled.firmware_constants) gives the run the
firmware with its words in arrays gives, word for word, and a run takes it only from MIN_NODE_TICKS node-ticks on."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from nodesim.api import simulate_scenario
from nodesim.chain.compiled import filters, firmware_constants
from nodesim.scenario.schema import load_scenario

FIELD = Path(__file__).resolve().parents[3] / "scenarios" / "field" / "drilling_10_tubes.toml"


def test_a_run_with_the_build_compiled_in_is_the_run_with_the_words_in_arrays(monkeypatch):
    scenario = load_scenario(FIELD)[0].with_overrides(**{"chain.nodes": 6, "simulation.realizations": 2,
                                                           "filter.implementation": "fixed"})
    arrays = simulate_scenario(scenario, None)
    built = []
    monkeypatch.setattr(firmware_constants, "MIN_NODE_TICKS", 0)
    real = firmware_constants.firmware_for
    monkeypatch.setattr(firmware_constants, "firmware_for", lambda p, f: built.append((p, f)) or real(p, f))
    constants = simulate_scenario(scenario, None)
    assert len(built) == scenario.chain.nodes  # every node's firmware ran compiled for its build
    arrays.summary.pop("timing"), constants.summary.pop("timing")
    assert arrays == constants  # every record, survey, hop and metric, value for value (Run.__eq__)
    assert any(n.yaw_est_rad.size and np.isfinite(n.yaw_est_rad).any() for n in constants.chain.nodes)


def test_the_build_is_compiled_in_only_for_a_large_run_of_the_two_state_firmware():
    params, fparams = np.arange(10, dtype=np.int64), np.arange(50, dtype=np.int64)
    small = firmware_constants.runner(params, fparams, firmware_constants.MIN_NODE_TICKS - 1, False)
    assert small is filters.run_node_firmware
    six = firmware_constants.runner(params, fparams, firmware_constants.MIN_NODE_TICKS, True)
    assert six is filters.run_node_firmware  # the 6-state node keeps its arrays
    large = firmware_constants.runner(params, fparams, firmware_constants.MIN_NODE_TICKS, False)
    assert large is firmware_constants.firmware_for(tuple(range(10)), tuple(range(50)))  # one per build (cached)
    assert large is not filters.run_node_firmware


def test_the_cache_key_follows_the_firmware_sources_and_is_the_same_in_every_process():
    """numba keys a cached function by its own file only: the stamp of the files compiled in is in the key, the
    same in another process (no salted hash), and another when a firmware file changes."""
    import os
    import subprocess
    import sys

    import firmware_model

    stamp = firmware_constants.source_stamp()
    other = subprocess.run([sys.executable, "-c", "from nodesim.chain.compiled import firmware_constants as f; "
                            "print(f.source_stamp())"], capture_output=True, text=True, check=True)
    assert int(other.stdout) == stamp
    path = Path(firmware_model.__file__).parent / "fixed_kernel.py"
    before = path.stat()
    try:
        os.utime(path, ns=(before.st_atime_ns, before.st_mtime_ns + 1_000_000_000))
        assert firmware_constants.source_stamp() != stamp
    finally:
        os.utime(path, ns=(before.st_atime_ns, before.st_mtime_ns))  # numba's own cache stamps stay valid
    assert firmware_constants.source_stamp() == stamp
