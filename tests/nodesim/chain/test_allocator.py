"""nodesim.chain.allocator: glibc keeps the memory a batched run frees; results never change."""

from __future__ import annotations

import dataclasses
import sys

import numpy as np
import pytest

from nodesim.chain import allocator
from nodesim.chain.network import simulate_chain
from nodesim.scenario.schema import Scenario


def _counted(monkeypatch, setter: str, flag: str):
    """(calls, the real setter, a small scenario): ``allocator.<setter>`` counted, its ``flag`` reset."""
    calls = []
    monkeypatch.setattr(allocator, flag, False)
    real = getattr(allocator, setter)
    monkeypatch.setattr(allocator, setter, lambda: calls.append(1) or real())
    return calls, real, Scenario().with_overrides(**{"simulation.duration_s": 60.0, "chain.nodes": 2,
                                                     "metrics.window_start_s": 10.0, "metrics.window_end_s": 60.0})


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's mallopt")
def test_the_thresholds_are_set_once_and_a_batched_run_sets_them(monkeypatch):
    calls, real, scenario = _counted(monkeypatch, "keep_freed_memory", "_done")
    simulate_chain(scenario)
    assert calls == [] and not allocator._done  # one realization: glibc's defaults
    simulate_chain(scenario.with_overrides(**{"simulation.realizations": 3}))
    assert calls == [1] and allocator._done and real()  # set; asking again changes nothing


def test_keeping_freed_memory_changes_no_result(monkeypatch):
    """The same batched run with glibc's defaults and with the thresholds set: every record equal."""
    scenario = Scenario().with_overrides(**{"simulation.duration_s": 60.0, "chain.nodes": 3,
                                            "simulation.realizations": 4, "metrics.window_start_s": 10.0,
                                            "metrics.window_end_s": 60.0})
    monkeypatch.setattr(allocator, "_done", True)  # as if set: simulate_chain leaves the thresholds alone
    before = simulate_chain(scenario)
    monkeypatch.setattr(allocator, "_done", False)
    assert allocator.keep_freed_memory() or not sys.platform.startswith("linux")
    after = simulate_chain(scenario)
    for a, b in zip(before.nodes, after.nodes, strict=True):
        names = [f.name for f in dataclasses.fields(a)] + ["gyro_rad_s", "specific_force"]  # (properties)
        arrays = [name for name in names if isinstance(getattr(a, name), np.ndarray)]
        assert "yaw_est_rad" in arrays
        for name in arrays:
            x, y = getattr(a, name), getattr(b, name)
            assert np.array_equal(x, y, equal_nan=x.dtype.kind == "f"), name


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's mallopt")
def test_a_streamed_run_limits_the_arenas_once_and_a_kept_run_does_not(monkeypatch):
    """``limit_arenas``: set by a streamed run (``on_node``), not by a run that keeps its records; set once."""
    calls, real, scenario = _counted(monkeypatch, "limit_arenas", "_arenas_limited")
    simulate_chain(scenario)
    assert calls == [] and not allocator._arenas_limited
    simulate_chain(scenario, on_node=lambda run, surveys: None)
    assert calls == [1] and allocator._arenas_limited and real()
