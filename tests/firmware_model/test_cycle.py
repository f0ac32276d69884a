"""Execution cycle (thesis 4.2.2 fig 4.10 event list; digest 5.1 default durations)."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from firmware_model.cycle import CycleTiming, ExecutionCycle, Step
from firmware_model.errors import FirmwareError


def test_tick_sequence_follows_the_thesis_event_list():
    cycle = ExecutionCycle()
    names = [s.name for s, _, _ in cycle.steps(True)]
    assert names == ["SYNC", "REQUEST_REFERENCE", "READ_REFERENCE", "RECEIVE", "PROCESS_FILTER", "TRANSMIT", "IDLE"]
    assert [s.name for s, _, _ in cycle.steps(False)] == ["SYNC", "PROCESS_FILTER", "TRANSMIT", "IDLE"]
    assert cycle.timing.period_s == pytest.approx(0.526, abs=1e-3)  # 1.9 Hz


def test_what_the_node_does_at_time_t():
    cycle = ExecutionCycle(start_s=10.0)
    p = cycle.timing.period_s
    t = 10.0 + 3 * p + np.array([0.001, 0.010, 0.018, 0.025, 0.036, 0.045, 0.2])
    expected = [Step.SYNC, Step.REQUEST_REFERENCE, Step.READ_REFERENCE, Step.RECEIVE, Step.PROCESS_FILTER, Step.TRANSMIT, Step.IDLE]
    assert cycle.step_at(t).tolist() == [int(s) for s in expected]
    t_no_ref = 10.0 + 3 * p + np.array([0.001, 0.005, 0.018])
    assert cycle.step_at(t_no_ref, with_reference=False).tolist() == [Step.SYNC, Step.PROCESS_FILTER, Step.TRANSMIT]
    mixed = cycle.step_at(t[[4, 4]], with_reference=np.array([True, False]))
    assert mixed.tolist() == [Step.PROCESS_FILTER, Step.IDLE]


def test_estimate_ready_and_reference_latency():
    timing = CycleTiming()
    cycle = ExecutionCycle(timing)
    k = np.array([0, 5])
    ready = cycle.estimate_ready_s(k)
    np.testing.assert_allclose(ready, k * timing.period_s + 0.002 + 0.015 + 0.002 + 0.015 + 0.005)
    np.testing.assert_allclose(cycle.estimate_ready_s(k, with_reference=False), k * timing.period_s + 0.007)
    np.testing.assert_allclose(cycle.transmit_end_s(k) - ready, 0.015)
    assert cycle.reference_latency_s == pytest.approx(ready[0] - timing.filter_s - cycle.reference_read_s(0))


@settings(max_examples=60, deadline=None)
@given(st.floats(0.0, 1e4), st.floats(0.001, 0.05), st.floats(0.0, 0.02))
def test_step_is_consistent_with_tick_and_step_boundaries(t, leg_s, start):
    timing = CycleTiming(request_s=leg_s, receive_s=leg_s, transmit_s=leg_s)
    cycle = ExecutionCycle(timing, start_s=start)
    t = start + t
    k = int(cycle.tick_index(t))
    assert cycle.tick_start_s(k) <= t + 1e-9 and t < cycle.tick_start_s(k + 1) + 1e-9
    step = Step(int(cycle.step_at(np.array([t]))[0]))
    offset = t - cycle.tick_start_s(k)
    for s, a, b in cycle.steps(True):
        if s is step:
            assert a - 1e-9 <= offset <= b + 1e-9


@pytest.mark.parametrize(
    "kw, match",
    [
        (dict(period_s=0.0), "period_s"),
        (dict(read_s=-0.001), "read_s"),
        (dict(filter_s=math.nan), "filter_s"),
        (dict(request_s=0.3, receive_s=0.3), "longer than period_s"),
    ],
)
def test_bad_timing_is_rejected(kw, match):
    with pytest.raises(FirmwareError, match=match):
        CycleTiming(**kw)


def test_bad_times_are_rejected():
    cycle = ExecutionCycle(start_s=1.0)
    with pytest.raises(FirmwareError, match="before the first tick"):
        cycle.step_at(np.array([0.5]))
    with pytest.raises(FirmwareError, match="non-finite"):
        cycle.step_at(np.array([np.nan]))
    with pytest.raises(FirmwareError, match="tick index"):
        cycle.estimate_ready_s(-1)
