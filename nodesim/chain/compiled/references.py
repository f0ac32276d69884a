"""The references a float filter's phase 2 reads (compiled engine), for the 2-state and the 6-state loops alike."""

from __future__ import annotations

import numpy as np


def above_nodes(net, n: int) -> tuple:
    """(node above, node two above) node index ``n``: the senders of the references it may take (``src_offset`` 1,
    2); the node itself stands in where there is none (its records are then never read)."""
    node = net.nodes[n]
    return tuple(net.nodes[i] if i >= 0 else node for i in (n - 1, n - 2))


def float_references(net, n: int, encoder_reads: tuple, src_offset: np.ndarray) -> tuple:
    """Node index ``n``'s (encoder reference (R, K) at its ``ASK`` ticks, a (1, 1) stand-in where it never asks;
    how far up each tick's forwarded reference came from (R, K): 1, 2 or 0 for none; the (node above, node two
    above) tick times, yaw and variance records), from phase 1's ``src_offset`` (R, N, K): the encoder reply brought back to the tick with its rate,
    psi_ref = psi_enc(t_read) - rate_enc (t_read - T[k]) (:class:`nodesim.chain.sensing.EncoderReader`)."""
    node = net.nodes[n]
    R, K = net.R, node.t_s.size
    ask, t_read, yaw_enc, rate_enc = encoder_reads
    enc_ref = np.zeros((R, K) if ask.size else (1, 1))  # read at ASK ticks only: a stand-in for the other nodes
    if ask.size:
        enc_ref[:, ask] = yaw_enc - rate_enc * (t_read - node.t_s[ask])
    offset = src_offset[:, n, :K]
    above = above_nodes(net, n)
    up = (tuple(a.t_s for a in above), tuple(a.yaw for a in above), tuple(a.var for a in above))
    return enc_ref, offset, up
