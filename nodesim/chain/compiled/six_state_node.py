"""Phase 2 of the compiled engine for a node running the 6-state filter (``filter.states = 6``): the node's lanes
started as the SimPy engine starts them (:class:`nodesim.chain.six_state.SixStateLanes`), then
:func:`.six_state_float_kernel.run_node` over its running ticks with the references phase 1 chose."""

from __future__ import annotations

import numpy as np

from nodesim import threads
from nodesim.chain.compiled import six_state_float_kernel as ssk
from nodesim.chain.compiled.references import float_references
from nodesim.chain.six_state import SixStateLanes


def run(net, n: int, out, k_end: int, n_static: int, codes: np.ndarray, encoder_reads) -> None:
    """Node index ``n``'s 6-state filter from its start tick ``n_static`` (``encoder_reads``: the engine's
    (ask ticks, t_read, yaw, rate) of its encoder replies); writes the node's records."""
    node, sig = net.nodes[n], net.nodes[n].sig
    t, R = sig.t_s, net.R
    K = t.size
    src_tick = out.src_tick[:, n, :K]
    node.kf = kf = SixStateLanes(net.scenario, sig, n_static, net.encoder.read(t[n_static])[0])
    node._record(n_static)
    enc_ref, offset, up = float_references(net, n, encoder_reads, out.src_offset)
    rates = np.ascontiguousarray(kf.rates)

    def run_range(r0: int, r1: int) -> None:
        ssk.run_node(kf.states, kf.params, kf.singular_ticks, rates, sig.specific_force, sig.gyro_rad_s, t,
                     n_static + 1, k_end, codes,
                     enc_ref, net.encoder.variance_rad2, node.applied, offset, src_tick, *up, net.dt_s,
                     net.extrapolate_rate, sig.gyro_white_sigma_rad_s, net.offset_sigma_rad**2, node.yaw, node.var,
                     node.bias, node.ref_yaw, node.ref_var, r0, r1)

    threads.map_chunks(run_range, R)
