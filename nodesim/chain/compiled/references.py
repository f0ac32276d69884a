"""The references phase 2 reads (compiled engine): the float filter's, for the 2-state and the 6-state loops alike,
and the encoder's replies and words the fixed firmware reads."""

from __future__ import annotations

import numpy as np

from nodesim.chain.compiled import tick_plan as tp
from nodesim.chain.estimator import timer_us


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


def asks(n: int, codes: np.ndarray, out, before: int = 0) -> tuple[np.ndarray, slice]:
    """Node index ``n``'s ``ASK`` ticks among ``codes`` (a window of its plan) and where their requests are in
    phase 1's ``out.ask_*`` (:class:`.events.Records`), ``before`` of its requests coming before the window."""
    ask = np.flatnonzero(codes == tp.ASK)
    first = int(out.ask_first[n]) + before
    return ask, slice(first, first + ask.size)


def encoder_reads(net, n: int, t: np.ndarray, codes: np.ndarray, out, before: int = 0):
    """Node index ``n``'s encoder replies at its ``ASK`` ticks (:func:`asks`; ``t`` the ticks' times): (those ticks,
    t_read (R, A), yaw (R, A), rate (R, A)), read at the request's arrival (at the tick itself where the request was
    lost)."""
    ask, rows = asks(n, codes, out, before)
    if not ask.size:
        return ask, None, None, None
    t_read = out.ask_t_read[:, rows]
    yaw, rate = net.encoder.read_many(t_read)
    return ask, t_read, yaw, rate


def encoder_words(config, R: int, t: np.ndarray, at_tick: np.ndarray, enc_yaw, reads: tuple) -> tuple:
    """The fixed firmware's encoder inputs (R, K) at the ticks ``t``: (yaw word, rate word, reply delay [us]).  The
    yaw is read at the tick itself at ``at_tick`` (the static window and the start: ``enc_yaw``) and at the top
    node's requests the reply read at its arrival (``reads``: :func:`encoder_reads`); no other tick reads it
    (``config``: the firmware's :class:`firmware_model.config.FirmwareConfig`)."""
    K = t.size
    yaw_enc, enc_rate, back_us = np.zeros((R, K), np.int64), np.zeros((R, K), np.int64), np.zeros((R, K), np.int64)
    if at_tick.size:
        yaw_enc[:, at_tick] = config.encoder_yaw_raw(enc_yaw)
    ask, t_read, yaw, rate = reads
    if ask.size:
        yaw_enc[:, ask] = config.encoder_yaw_raw(yaw)
        enc_rate[:, ask], back_us[:, ask] = config.encoder_rate_raw(rate), timer_us(t_read - t[ask])
    return yaw_enc, enc_rate, back_us
