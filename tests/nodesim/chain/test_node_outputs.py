"""The streamed run's output steps (engine._NodeOutputs): finished in node order, never before phase 2 is two nodes
past them, late only within the backlog of ticks (OUTPUT_BACKLOG_LONGEST_NODES), the same with one thread."""

import threading

import pytest

from nodesim import threads
from nodesim.chain.compiled import engine


class _Node:
    def __init__(self, log, n):
        self.log, self.n = log, n

    def release(self):
        self.log.append(("release", self.n))


class _Net:
    def __init__(self, n, gate):
        self.log, self.gate = [], gate
        self.nodes = [_Node(self.log, i) for i in range(n)]

    def stream_node(self, n, on_node, surveys):
        self.gate.wait()  # the output thread's step of node n, held until the test lets it go
        return f"summary {n}"


@pytest.mark.parametrize("count", [1, 2])
def test_steps_finish_in_order_within_the_backlog(monkeypatch, count):
    monkeypatch.setattr(threads, "thread_count", lambda: count)
    gate = threading.Event()
    if count == 1:
        gate.set()  # one thread: each step runs at submit
    net = _Net(6, gate)
    out = engine._NodeOutputs(net, None, [])
    for n, ticks in enumerate((10, 10, 10)):
        out.submit(n, ticks)
    if count > 1:  # 30 ticks pending, backlog 30: node 0 (its step not done) may wait
        assert out.finish_due(0, 30) == []
        assert net.log == []
    gate.set()
    out.submit(3, 100)  # 130 > 30: nodes up to 1 finish now, waited for; node 2 is past ``last``
    assert out.finish_due(1, 30) == ["summary 0", "summary 1"]
    assert net.log == [("release", 0), ("release", 1)]
    assert out.finish_due(3, -1) == ["summary 2", "summary 3"]  # the end: every pending node, in order
    assert out.ticks == 0 and not out.pending
    out.close()
