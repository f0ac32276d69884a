"""The compiled engine's estimate frames: what each node sends, encoded, and what each receiver takes, decoded.

Phase 2 (:mod:`.engine`) runs the nodes top down; around each node's firmware loop
(:func:`.filters.run_node_firmware`):

* before it, :func:`receive_frames` decodes, per realization and tick where phase 1 gave the node a packet from
  node n - s read at its tick j, the bytes of that frame (``up_frames[s - 1][r, j]``, with the bit errors the CRC
  let through where ``mac.bit_errors`` applies them) into the yaw and P_yy words the firmware takes as its
  reference (:func:`firmware_model.frames.estimate_words`: only those two fields, no CRC, whose verdict phase 1
  made);
* after it, :func:`send_frames` encodes the frame of every tick where it transmits (an update applied, or every
  running tick with ``chain.forward = "every_tick"``) from the words the firmware recorded
  (:func:`firmware_model.frames.encode_estimate`: node id, seq = ticks since power-up, t_read_us, yaw, P_yy, rate,
  bias), the bytes the SimPy engine sends.
Two short loops of their own next to the firmware loop (which only records the rate and bias words it sends).  A
run in windows (:mod:`.time_windows`, never with bit errors) makes no bytes: :func:`receive_words` takes the words a
sent frame carries, :func:`send_frames` without frame ticks only checks that they fit it (the same words and errors, tested).  On
node 400 of the drilling day's first hour (6,795 ticks, 3,370 frames sent, as many taken): receiving ~0.02 ms
(~4 ns a tick; decoding every field and the CRC took ~0.11 ms), sending ~0.08 ms (~24 ns a frame, most of it the
CRC; ~0.11 ms with the CRC two bytes a step), beside ~0.42 ms of firmware ticks.  Numba caches these loops with the
codecs of :mod:`firmware_model.frames` compiled in: an edit there needs an edit here to take effect.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from firmware_model import frames as fr
from nodesim.errors import NodesimError


@njit(cache=True, _nrt=False, nogil=True)
def receive_frames(src_node, src_tick, k_first, k_end, up_frames, up_first, rx_yaw_raw, rx_var_raw, r_first, r_end):
    """``rx_*_raw[r, k]`` = the words of the frame taken at tick k (``src_node`` (R, K): 1 or 2, 0 for none) from
    the sender's frame of its tick j = ``src_tick[r, k]``, row j - ``up_first[s - 1]`` of ``up_frames[s - 1]`` (the
    sender's frames from its tick ``up_first`` on: 0 where they are all there)."""
    for r in range(r_first, r_end):
        for k in range(k_first, k_end):
            s = src_node[r, k]
            if s > 0:
                j = src_tick[r, k] - up_first[s - 1]
                rx_yaw_raw[r, k], rx_var_raw[r, k] = fr.estimate_words(up_frames[s - 1][r, j])


@njit(cache=True, _nrt=False, nogil=True)
def send_frames(node_id, first_tick, every_tick, running, k_first, k_end, k_base, applied, t, yaw_raw, var_raw,
                rate_raw, bias_raw, frames, words, r_first, r_end) -> int:
    """``frames[r, k]`` = the estimate frame sent at tick k (k_first .. k_end - 1, where ``applied[r, k]``, or
    ``every_tick`` and the node ran that tick (not holding)); the arrays begin at the node's tick ``k_base`` (a
    window of its ticks: its seq is k_base + k - first_tick); returns the lowest encoder status (< 0: a word did
    not fit its field).  ``frames`` with no ticks (R, 0, 27): no bytes, the same status
    (:func:`firmware_model.frames.estimate_status`), for a run whose receivers take the words
    (:func:`receive_words`): on a synthetic window of 80 k ticks sending at half of them at random (2026-12-06),
    12 ns a tick, and with :func:`receive_words` 20 ns against 46 with the bytes and :func:`receive_frames`."""
    worst = 0
    make_bytes = frames.shape[1] > 0
    for r in range(r_first, r_end):
        for k in range(k_first, k_end):
            if applied[r, k] or (every_tick and running[k]):
                seq, t_us = k_base + k - first_tick, np.int64(np.rint(t[k] * 1e6))
                if make_bytes:
                    s = fr.encode_estimate(node_id, seq, t_us, yaw_raw[r, k], var_raw[r, k], rate_raw[r, k],
                                           bias_raw[r, k], words[r], frames[r, k])
                else:
                    s = fr.estimate_status(node_id, seq, t_us, yaw_raw[r, k], var_raw[r, k], rate_raw[r, k],
                                           bias_raw[r, k], words[r])
                worst = min(worst, s)
    return worst


@njit(cache=True, _nrt=False, nogil=True)
def receive_words(src_node, src_tick, k_first, k_end, up_yaw_raw, up_var_raw, up_first, rx_yaw_raw, rx_var_raw,
                  r_first, r_end):
    """:func:`receive_frames` without the bytes, for a run whose frames arrive as they were sent (no
    ``mac.bit_errors``): ``rx_*_raw[r, k]`` = the words the sender's frame of its tick j carries
    (:func:`firmware_model.frames.estimate_words_sent` of its yaw and P_yy words ``up_*_raw[s - 1][r, j]``, row
    j - ``up_first[s - 1]``): the words :func:`firmware_model.frames.estimate_words` reads from the bytes."""
    for r in range(r_first, r_end):
        for k in range(k_first, k_end):
            s = src_node[r, k]
            if s > 0:
                j = src_tick[r, k] - up_first[s - 1]
                rx_yaw_raw[r, k], rx_var_raw[r, k] = fr.estimate_words_sent(up_yaw_raw[s - 1][r, j],
                                                                           up_var_raw[s - 1][r, j])


def check_sent(status: int, node_id: int) -> None:
    """Raise where :func:`send_frames` returned a status < 0 (a word that does not fit its field of the frame)."""
    if status < 0:
        name, width = fr.FIELDS[fr.ESTIMATE][-status - 1][:2]
        raise NodesimError(f"node {node_id}: its {name} word does not fit the estimate frame's {8 * width}-bit "
                           f"field (firmware_model/frames.py); the build's format is wider than the frame")
