"""What every node does at each of its ticks, as one small code per (tick, node): both phases of the compiled engine
read it instead of asking the node's timeline.

The codes follow the branches of :meth:`nodesim.chain.node_process.ChainNode.process`, in its order of tests:
  * ``STATIC``: before the node's filter start (its static window: it averages the gyro, reports the encoder);
  * ``START``: its first tick from the filter start (the filter starts from an encoder yaw; no update);
  * ``HOLD``: a tube insertion above it (state saved, inbox emptied, no update, nothing sent);
  * ``ASK``: it is the top node and the schedule asks the encoder this tick;
  * ``TOP``: it is the top node, no encoder request this tick (predict only);
  * ``RUN``: any other node, running: it takes the newest fresh estimate from above.
``ABSENT`` pads the ticks a node does not have (a shorter clock), those after its death and any before it is in
its tube.  Lab motion: node 1
is the top node for the whole run, nothing holds.  Drilling: a node is the top node from its insertion until the
next tube's insertion starts (:class:`nodesim.motion.timelines.NodeTimeline`), and holds in every later one.
"""

from __future__ import annotations

import numpy as np

from nodesim.chain import scratch as spill

ABSENT, STATIC, START, HOLD, ASK, TOP, RUN = 0, 1, 2, 3, 4, 5, 6
RUNNING = (ASK, TOP, RUN)  # the ticks the SimPy engine marks ``running``


def node_codes(t_s: np.ndarray, timeline, scheduled: np.ndarray, dead_at_s: float) -> np.ndarray:
    """(K,) int8 codes of one node's ticks ``t_s`` (increasing; module docstring); ``scheduled`` (K,) the encoder
    schedule.  Each time window [a, b) is the slice of ticks searchsorted gives (a node holds in every later
    insertion: a mask over all its ticks per hold cost the drilling day ~12 s)."""
    t = np.asarray(t_s, dtype=float)

    def ticks(a: float, b: float) -> slice:  # the ticks a <= t < b
        return slice(*np.searchsorted(t, (a, b), side="left"))

    codes = np.full(t.size, RUN, dtype=np.int8)
    top = ticks(timeline.present_from_s, timeline.top_until_s)
    codes[top] = np.where(scheduled[top], ASK, TOP)
    if timeline.holds:  # every hold's slice from one searchsorted each way (a drilling day's node has ~200)
        a, b = np.array(timeline.holds, dtype=float).T
        for lo, hi in zip(np.searchsorted(t, a, side="left").tolist(), np.searchsorted(t, b, side="left").tolist()):
            codes[lo:hi] = HOLD
    n_static = int(np.searchsorted(t, timeline.filter_start_s, side="left"))  # the ticks t < filter start
    codes[:n_static] = STATIC
    if n_static < t.size:
        codes[n_static] = START
    codes[ticks(-np.inf, timeline.present_from_s)] = ABSENT
    codes[ticks(dead_at_s, np.inf)] = ABSENT
    return codes


def tick_plan(nodes, Kmax: int, arrays=None) -> np.ndarray:
    """(N, Kmax) int8 codes of every node (a row per node, as its tick times), ``ABSENT`` (0) past a node's end; in
    ``arrays`` (:class:`nodesim.chain.scratch.ScratchArrays`) when given, its rows dropped from memory as they go."""
    plan = spill.zeros(arrays, (len(nodes), Kmax), np.int8)
    for n, node in enumerate(nodes):
        t = node.t_s
        spill.write(arrays, plan[n, :t.size], node_codes(t, node.timeline, node.scheduled, node.dead_at_s))
        if n % spill.DROP_EVERY_ROWS == spill.DROP_EVERY_ROWS - 1:
            spill.drop(arrays)
    spill.write_out(arrays)  # its pages to the disk now, while a core is idle (:meth:`.ScratchArrays.write_out`)
    return plan
