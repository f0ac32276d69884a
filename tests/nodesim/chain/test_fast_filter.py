"""The chain with the fused fixed-point fast path (firmware_model.fixed_fast) gives bit-identical results to
the chain with the exact primitive-by-primitive filter (the engine before the fast path) on fixed-point
scenarios with lossy ARQ soil hops, faults (dead node with fallback, outage), drilling and a short word."""

import dataclasses

import numpy as np
import pytest

from firmware_model.fixed_filter import FixedYawFilter
from nodesim.chain.network import simulate_chain
from nodesim.chain.links import LazyStreams
from nodesim.scenario.schema import Scenario

LOSSY = {  # the perf chain's hops: 0.95 dB margin, PER 0.12 per frame, ARQ with 3 retries
    "filter.implementation": "fixed", "radio.model": "channel", "radio.kind": "soil", "radio.top_kind": "cable",
    "radio.shadowing_sigma_db": 0.0, "radio.soil.distance_m": 2.0, "radio.soil.vwc": 0.275, "mac.enabled": True,
    "simulation.realizations": 2, "metrics.window_start_s": 0.0,
    "simulation.engine": "event",  # the SimPy engine's filter objects (the compiled engine has its own kernel)
}
CASES = {
    "lossy_arq_dead_node_fallback": {**LOSSY, "chain.nodes": 4, "simulation.duration_s": 160.0,
                                     "metrics.window_end_s": 160.0, "radio.soil.distance_m": 1.0,
                                     "simulation.realizations": 1,  # the Python-int path of R = 1
                                     "faults.node_failure": [{"node": 2, "at_s": 100.0}]},
    "lossy_arq_outage_word16": {**LOSSY, "chain.nodes": 3, "simulation.duration_s": 140.0,
                                "metrics.window_end_s": 140.0, "filter.fixed_word_bits": 16,
                                "faults.link_outage": [{"hop": 2, "start_s": 80.0, "end_s": 110.0}]},
    "drilling_two_tubes": {"filter.implementation": "fixed", "motion.kind": "drilling", "chain.nodes": 2,
                           "simulation.duration_s": 440.0, "simulation.realizations": 2,
                           "metrics.window_start_s": 0.0, "metrics.window_end_s": 440.0},
}


def assert_identical(a, b, path="run"):
    if dataclasses.is_dataclass(a) and not isinstance(a, type):
        assert type(a) is type(b), path
        for f in dataclasses.fields(a):
            assert_identical(getattr(a, f.name), getattr(b, f.name), f"{path}.{f.name}")
    elif isinstance(a, (tuple, list)):
        assert len(a) == len(b), path
        for i, (x, y) in enumerate(zip(a, b)):
            assert_identical(x, y, f"{path}[{i}]")
    elif isinstance(a, dict):
        assert a.keys() == b.keys(), path
        for k in a:
            assert_identical(a[k], b[k], f"{path}[{k!r}]")
    elif isinstance(a, np.ndarray):
        assert a.dtype == b.dtype and a.shape == b.shape, path
        np.testing.assert_array_equal(a, b, err_msg=path)  # NaN equals NaN here; values bit for bit
    elif isinstance(a, LazyStreams):
        assert_identical(a.built, b.built, path)
    elif isinstance(a, np.random.Generator):  # the same draws were consumed
        assert_identical(a.bit_generator.state, b.bit_generator.state, path)
    elif a is None or b is None:
        assert a is b, path
    elif callable(a):  # the motion's closures (inputs, not results)
        assert callable(b), path
    else:
        assert a == b or (a != a and b != b), path


@pytest.mark.parametrize("case", sorted(CASES))
def test_fast_filter_chain_is_bit_identical_to_the_exact_filter_chain(case, monkeypatch):
    scenario = Scenario().with_overrides(**CASES[case])
    fast = simulate_chain(scenario)
    monkeypatch.setattr(FixedYawFilter, "_fusable", property(lambda self: False))
    exact = simulate_chain(scenario)
    assert_identical(fast, exact)
    assert any(n.update_mask.any() for n in fast.nodes)  # the filters did update
