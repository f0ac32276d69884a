"""Phase 1 of the compiled engine: every node tick in SimPy's order, with the MAC, packets and faults, no filter.

What happens on the links does not depend on any filter value: a node transmits when it applied an update (or
every running tick), an update is applied when a fresh packet arrived, a packet arrives when the MAC says so.
So the compiled engine first runs the event skeleton of :mod:`nodesim.chain.node_process` with all of that and records,
per node, tick and realization, which reference (if any) the node takes; phase 2
(:mod:`nodesim.chain.compiled.filters`) then runs each node's filter down the chain.

Event order is SimPy's: each node has one pending timeout; events are taken by (time, creation counter), a
tick's timeout is created when the node finishes its previous tick and is due at now + (T[k] - now), exactly
as ``env.timeout(t - env.now)`` schedules it.  Per tick of node n, as its plan says (:mod:`.tick_plan`):
  * in its static window (``STATIC``): nothing on the links;
  * the first tick from its filter start (``START``): the filter starts (no update, no transmission);
  * holding during a tube insertion above it (``HOLD``): its inbox is emptied, nothing is sent;
  * running: the top node of the time asks the encoder when the schedule says so (``ASK``: request and reply over
    hop 1, the surface link, whichever node is on top); the others (``RUN``) take, per realization, the newest fresh packet that has arrived
    (sequence number above the last one used, age <= ``max_update_age_s``; older fresh ones are dropped,
    duplicates and stale packets counted);
  * then a node that is not the bottom one transmits in the realizations that applied an update (or in all of
    them with ``chain.forward = "every_tick"`` on a running tick), with the fallback to the next-but-one node;
  * a node at its survey tick sends its survey up, hop by hop to the top node and the ground station, past a
    silent neighbour over the skip hop (:meth:`nodesim.chain.network.Network.send_survey`).
Sequence numbers are the event counter: they increase with send time, which is all the selection compares.
The order of the events is the same in every realization (:func:`event_order`, once), and realizations share
no state, so :func:`run_events` runs them one after the other over that order, each with its state together in
memory (arrays are realization-major), and ranges of realizations can run on parallel threads
(:mod:`nodesim.threads`).  The frame and selection kernels are inlined at numba's IR level: a call passing
~26 arrays cost as much as the work (phase 1 of 1000 realizations x 20 nodes x 2 min: 1.12 s -> 0.63 s).
Status codes: 0 done; 1 a lane ran out of buffered draws (``need`` = link, realization, event index); 2 an
inbox is full.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from nodesim.chain.compiled.mac_kernel import time_row, transfer
from nodesim.chain.compiled.tick_plan import ASK, HOLD, RUN, STATIC, TOP

DONE, NEED_DRAWS, INBOX_FULL = 0, 1, 2


@njit(cache=True)
def _less(ta, ea, tb, eb) -> bool:
    return ta < tb or (ta == tb and ea < eb)


@njit(cache=True)
def _push(h_t, h_e, h_n, size, t, e, n) -> int:
    i = size
    h_t[i], h_e[i], h_n[i] = t, e, n
    while i > 0:
        p = (i - 1) // 2
        if not _less(h_t[i], h_e[i], h_t[p], h_e[p]):
            break
        h_t[i], h_t[p] = h_t[p], h_t[i]
        h_e[i], h_e[p] = h_e[p], h_e[i]
        h_n[i], h_n[p] = h_n[p], h_n[i]
        i = p
    return size + 1


@njit(cache=True)
def _pop(h_t, h_e, h_n, size):
    t, n = h_t[0], h_n[0]
    size -= 1
    h_t[0], h_e[0], h_n[0] = h_t[size], h_e[size], h_n[size]
    i = 0
    while True:
        a, b, m = 2 * i + 1, 2 * i + 2, i
        if a < size and _less(h_t[a], h_e[a], h_t[m], h_e[m]):
            m = a
        if b < size and _less(h_t[b], h_e[b], h_t[m], h_e[m]):
            m = b
        if m == i:
            break
        h_t[i], h_t[m] = h_t[m], h_t[i]
        h_e[i], h_e[m] = h_e[m], h_e[i]
        h_n[i], h_n[m] = h_n[m], h_n[i]
        i = m
    return t, n, size


@njit(cache=True)
def _deliver(inbox, r, receiver, seq, sender, tick, arrival, c_try, c_ber) -> bool:
    i_seq, i_src, i_tick, i_arr, i_count, i_try, i_ber = inbox
    c = i_count[r, receiver]
    if c == i_seq.shape[2]:
        return False
    i_seq[r, receiver, c], i_src[r, receiver, c], i_tick[r, receiver, c] = seq, sender, tick
    i_arr[r, receiver, c] = arrival
    i_try[r, receiver, c], i_ber[r, receiver, c] = c_try, c_ber
    i_count[r, receiver] = c + 1
    return True


@njit(cache=True)
def _swap(inbox, r, n, i, j) -> None:
    i_seq, i_src, i_tick, i_arr, _, i_try, i_ber = inbox
    i_seq[r, n, i], i_seq[r, n, j] = i_seq[r, n, j], i_seq[r, n, i]
    i_src[r, n, i], i_src[r, n, j] = i_src[r, n, j], i_src[r, n, i]
    i_tick[r, n, i], i_tick[r, n, j] = i_tick[r, n, j], i_tick[r, n, i]
    i_arr[r, n, i], i_arr[r, n, j] = i_arr[r, n, j], i_arr[r, n, i]
    i_try[r, n, i], i_try[r, n, j] = i_try[r, n, j], i_try[r, n, i]
    i_ber[r, n, i], i_ber[r, n, j] = i_ber[r, n, j], i_ber[r, n, i]


@njit(cache=True, inline="always")
def _select(r, n, k, t, T, max_age_s, inbox, last_seq, stale, dup, src_node, src_tick, age, bits) -> bool:
    """Take the packets of node n's inbox that arrived by t and apply the selection rule (module docstring);
    True if a fresh packet was taken (with ``mac.bit_errors``, its corrupting try, if any, is recorded)."""
    i_seq, i_src, i_tick, i_arr, i_count, i_try, i_ber = inbox
    c = i_count[r, n]
    m = 0
    for i in range(c):  # the arrived ones to the front, newest first (insertion sort; an inbox holds a few)
        if i_arr[r, n, i] <= t:
            _swap(inbox, r, n, i, m)
            j = m
            while j > 0 and i_seq[r, n, j] > i_seq[r, n, j - 1]:
                _swap(inbox, r, n, j, j - 1)
                j -= 1
            m += 1
    if m == 0:
        return False
    have = False
    seq_taken = -1
    for j in range(m):
        newer = i_seq[r, n, j] > last_seq[r, n]
        if not newer:
            dup[r, n] += 1
        t_read = T[i_tick[r, n, j], i_src[r, n, j]]
        if t - t_read > max_age_s:
            if newer and not have:
                stale[r, n] += 1
            continue
        if newer and not have:
            have = True
            seq_taken = i_seq[r, n, j]
            src_node[r, n, k], src_tick[r, n, k] = i_src[r, n, j], i_tick[r, n, j]
            age[r, n, k] = t - t_read
            if bits[0]:
                bits[10][r, n, k], bits[11][r, n, k] = i_try[r, n, j], i_ber[r, n, j]
    if have:
        last_seq[r, n] = seq_taken
    for i in range(m, c):  # drop the arrived packets
        _swap(inbox, r, n, i - m, i)
    i_count[r, n] = c - m
    return have


@njit(cache=True)
def event_order(T, K, dead_at):
    """(node, tick) of every event in SimPy's order (module docstring), int32 each (a run's nodes and ticks stay
    far below 2^31: a day at 1.9 Hz is 164 k ticks)."""
    N = T.shape[1]
    total = 0
    for n in range(N):
        for k in range(K[n]):
            if T[k, n] < dead_at[n]:
                total += 1
    nodes, ticks = np.empty(total, dtype=np.int32), np.empty(total, dtype=np.int32)  # 8 bytes an event, not 16
    h_t, h_e, h_n = np.empty(N), np.empty(N, dtype=np.int64), np.empty(N, dtype=np.int64)
    size, eid, e = 0, 0, 0
    next_k = np.zeros(N, dtype=np.int64)
    for n in range(N):
        if K[n] > 0 and T[0, n] < dead_at[n]:
            size = _push(h_t, h_e, h_n, size, 0.0 + (T[0, n] - 0.0), eid, n)
            eid += 1
    while size > 0:
        now, n, size = _pop(h_t, h_e, h_n, size)
        k = next_k[n]
        nodes[e], ticks[e] = n, k
        e += 1
        k += 1
        next_k[n] = k
        if k < K[n] and T[k, n] < dead_at[n]:
            size = _push(h_t, h_e, h_n, size, now + (T[k, n] - now), eid, n)
            eid += 1
    return nodes, ticks


@njit(cache=True, _nrt=False, nogil=True)
def run_events(T, order, plan, dead_at, surveys, nodes_cfg, fallback, chan, margin, draws, radio, stats, mac, bits,
               scratch, inbox, last_seq, streak, out, need, cursor, r_first, r_end):
    """Run every event of ``order`` (from :func:`event_order`) in realizations ``r_first`` .. ``r_end - 1``
    (module docstring; disjoint ranges may run on parallel threads, each with its own ``need`` and ``cursor``
    (N,), the next survey of each node).  ``plan``
    (K, N): each tick's code (:mod:`.tick_plan`); ``surveys`` = (first (N,), stop (N,), tick (S,), top (S,),
    arrival (R, S), event (S,), skip (N,)): the surveys node n sends, ``first[n]`` .. ``stop[n] - 1`` in tick
    order, each at its tick, up to the top node of its time and the ground station (arrival NaN where lost; its
    event's index, written by realization 0; ``skip[h]``: node h may send a survey its neighbour above left
    unanswered on to node h - 2); ``nodes_cfg`` = (processing_s,
    max_age_s, every_tick, ask_row (N,)); ``fallback`` = (enabled (N,) bool, skip link (N,) int, after_failures,
    min_margin_db); ``bits``, ``scratch``: :mod:`.mac_kernel`; ``out`` = (running (K, N), applied (R, N, K), age,
    src_node, src_tick (R, N, K), encoder t_read (R, A, K) (row ``ask_row[n]`` of the A nodes that ever ask), stale
    (R, N), duplicate (R, N)); ``running`` is the
    same in every realization and written by realization 0.  Links: down link h = h (0: the surface link, the encoder
    exchange of whichever node is on top), skip link of node n = N + n, up link h = 2N + h, survey skip link
    of node h (up to h - 2) = 3N + h.
    Returns a status code."""
    N = T.shape[1]
    ev_node, ev_tick = order
    processing_s, max_age_s, every_tick = nodes_cfg[:3]
    fb_on, fb_link, fb_after, fb_min_margin = fallback
    s_first, s_stop, s_tick, s_top, s_arrival, s_event, s_skip = surveys
    ask_row = nodes_cfg[3]
    running, applied, age, src_node, src_tick, enc_t_read, stale, dup = out
    i_count = inbox[4]
    surface = N
    for r in range(r_first, r_end):
        for i in range(N):
            cursor[i] = s_first[i]
        for e in range(ev_node.shape[0]):
            n, k = ev_node[e], ev_tick[e]
            t = T[k, n]
            code = plan[k, n]
            seq = e + 1
            if code == STATIC:
                continue
            if code == HOLD:
                i_count[r, n] = 0  # nothing arrives from a powered-down link; the state is saved
            is_running = code == ASK or code == TOP or code == RUN
            if r == 0 and is_running:
                running[k, n] = True
            ready = t
            valid = every_tick and is_running
            if code == ASK:
                got, arr, end, short, _, _ = transfer(0, r, t, n, surface, np.inf, chan, draws, radio, stats, mac,
                                                      bits, scratch)
                if short:
                    need[0], need[1], need[2] = 0, r, e
                    return NEED_DRAWS
                t_read = arr if got else t
                enc_t_read[r, ask_row[n], k] = t_read
                if got:
                    have, arr2, end2, short, _, _ = transfer(0, r, end, surface, n, np.inf, chan, draws, radio,
                                                             stats, mac, bits, scratch)
                    if short:
                        need[0], need[1], need[2] = 0, r, e
                        return NEED_DRAWS
                    if have:
                        applied[r, n, k] = True
                        age[r, n, k] = arr2 - t_read
                        ready = arr2
                        valid = True
            elif code == RUN and _select(r, n, k, t, T, max_age_s, inbox, last_seq, stale, dup, src_node, src_tick,
                                         age, bits):
                applied[r, n, k] = True
                valid = True
            if n < N - 1 and valid:
                status = _send_estimate(r, e, n, k, seq, ready + processing_s, t, dead_at, fb_on, fb_link, fb_after,
                                        fb_min_margin, chan, margin, draws, radio, stats, mac, bits, scratch, inbox,
                                        streak, need)
                if status != DONE:
                    return status
            while cursor[n] < s_stop[n] and s_tick[cursor[n]] == k:
                s = cursor[n]
                cursor[n] = s + 1
                if r == 0:
                    s_event[s] = e
                status = _send_survey(r, e, n, s_top[s], ready, t, dead_at, s_skip, fb_min_margin, chan, margin,
                                      draws, radio, stats, mac, bits, scratch, need, s_arrival, s)
                if status != DONE:
                    return status
    return DONE


@njit(cache=True, inline="always")
def _send_estimate(r, e, n, k, seq, t_ready, t, dead_at, fb_on, fb_link, fb_after, fb_min_margin, chan, margin,
                   draws, radio, stats, mac, bits, scratch, inbox, streak, need) -> int:
    """Node n's estimate frame down its link, with the fallback to the next-but-one node (a status code)."""
    got, arr, end, short, c_try, c_ber = transfer(n + 1, r, t_ready, n, n + 1, dead_at[n + 1], chan, draws, radio,
                                                  stats, mac, bits, scratch)
    if short:
        need[0], need[1], need[2] = n + 1, r, e
        return NEED_DRAWS
    if got and not _deliver(inbox, r, n + 1, seq, n, k, arr, c_try, c_ber):
        return INBOX_FULL
    if not fb_on[n] or math.isnan(end):  # fallback off, or the queue dropped the frame (faults.Fallback)
        return DONE
    if got:
        streak[r, n] = 0
        return DONE
    streak[r, n] += 1
    link = fb_link[n]
    g = time_row(chan, link, t)
    if streak[r, n] > fb_after and margin[r, link, g] >= fb_min_margin:
        got, arr, end, short, c_try, c_ber = transfer(link, r, end, n, n + 2, dead_at[n + 2], chan, draws, radio,
                                                      stats, mac, bits, scratch)
        if short:
            need[0], need[1], need[2] = link, r, e
            return NEED_DRAWS
        if got and not _deliver(inbox, r, n + 2, seq, n, k, arr, c_try, c_ber):
            return INBOX_FULL
    return DONE


@njit(cache=True, inline="always")
def _send_survey(r, e, n, top, at, t, dead_at, skip_on, min_margin_db, chan, margin, draws, radio, stats, mac, bits,
                 scratch, need, arrival, s) -> int:
    """Node n's survey, ready at ``at``, hop by hop up to node ``top`` and the ground station: up link 2N + h from
    node h to h - 1 (hop 1's, 2N, from the top node to the surface); a hop left unanswered goes on over node h's
    survey skip link 3N + h to h - 2 where ``skip_on[h]``, h - 2 is not above the top node and the skip hop's margin
    at t is at least ``min_margin_db`` (:meth:`nodesim.chain.network.Network.send_survey`).  ``arrival[r, s]`` = its
    arrival at the ground station (left NaN where lost); a status code."""
    N = dead_at.shape[0]
    surface = N
    h = n
    while h >= top:
        rx, up = (h - 1, 2 * N + h) if h > top else (surface, 2 * N)
        got, arr, end, short, _, _ = transfer(up, r, at, h, rx, dead_at[rx] if h > top else np.inf, chan, draws,
                                              radio, stats, mac, bits, scratch)
        if short:
            need[0], need[1], need[2] = up, r, e
            return NEED_DRAWS
        if got:
            at, h = arr, h - 1
            continue
        link = 3 * N + h
        if math.isnan(end) or not skip_on[h] or h - 2 < top or margin[r, link, time_row(chan, link, t)] < min_margin_db:
            return DONE  # lost here
        got, arr, end, short, _, _ = transfer(link, r, end, h, h - 2, dead_at[h - 2], chan, draws, radio, stats, mac,
                                              bits, scratch)
        if short:
            need[0], need[1], need[2] = link, r, e
            return NEED_DRAWS
        if not got:
            return DONE
        at, h = arr, h - 2
    arrival[r, s] = at
    return DONE
