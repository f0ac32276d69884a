"""Phase 1 of the compiled engine: every node tick in SimPy's order, with the MAC, packets and faults, no filter.

What happens on the links does not depend on any filter value: a node transmits when it applied an update (or
every running tick), an update is applied when a fresh packet arrived, a packet arrives when the MAC says so.
So the compiled engine first runs the event skeleton of :mod:`nodesim.chain.node` with all of that and records,
per node, tick and realization, which reference (if any) the node takes; phase 2
(:mod:`nodesim.chain.compiled.filters`) then runs each node's filter down the chain.

Event order is SimPy's: each node has one pending timeout; events are taken by (time, creation counter), a
tick's timeout is created when the node finishes its previous tick and is due at now + (T[k] - now), exactly
as ``env.timeout(t - env.now)`` schedules it.  Per tick of node n (lab motion: every node present from t = 0,
node 1 is the top node):
  * before ``filter_start``: nothing on the links (static bias window);
  * the first tick from ``filter_start``: the filter starts (no update, no transmission);
  * later ticks are running: the top node asks the encoder when the schedule says so (request and reply over
    hop 0); the others take, per realization, the newest fresh packet that has arrived (sequence number above
    the last one used, age <= ``max_update_age_s``; older fresh ones are dropped, duplicates and stale
    packets counted);
  * then a node that is not the bottom one transmits in the realizations that applied an update (or in all of
    them with ``chain.forward = "every_tick"``), with the fallback to the next-but-one node.
Sequence numbers are the event counter: they increase with send time, which is all the selection compares.
Status codes: 0 done; 1 a lane ran out of buffered draws (``need`` = link, realization); 2 an inbox is full.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from nodesim.chain.compiled.mac_kernel import transfer

DONE, NEED_DRAWS, INBOX_FULL = 0, 1, 2


@njit(cache=True, inline='always')
def _less(ta, ea, tb, eb) -> bool:
    return ta < tb or (ta == tb and ea < eb)


@njit(cache=True, inline='always')
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


@njit(cache=True, inline='always')
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


@njit(cache=True, inline='always')
def _deliver(inbox, receiver, r, seq, sender, tick, arrival) -> bool:
    i_seq, i_src, i_tick, i_arr, i_count = inbox
    c = i_count[receiver, r]
    if c == i_seq.shape[2]:
        return False
    i_seq[receiver, r, c], i_src[receiver, r, c], i_tick[receiver, r, c] = seq, sender, tick
    i_arr[receiver, r, c] = arrival
    i_count[receiver, r] = c + 1
    return True


@njit(cache=True, inline='always')
def _swap(inbox, n, r, i, j) -> None:
    i_seq, i_src, i_tick, i_arr, _ = inbox
    i_seq[n, r, i], i_seq[n, r, j] = i_seq[n, r, j], i_seq[n, r, i]
    i_src[n, r, i], i_src[n, r, j] = i_src[n, r, j], i_src[n, r, i]
    i_tick[n, r, i], i_tick[n, r, j] = i_tick[n, r, j], i_tick[n, r, i]
    i_arr[n, r, i], i_arr[n, r, j] = i_arr[n, r, j], i_arr[n, r, i]


@njit(cache=True, inline='always')
def _select(n, k, r, t, T, max_age_s, inbox, last_seq, stale, dup, src_node, src_tick, age) -> bool:
    """Take the packets of node n's inbox that arrived by t and apply the selection rule (module docstring);
    True if a fresh packet was taken."""
    i_seq, i_src, i_tick, i_arr, i_count = inbox
    c = i_count[n, r]
    m = 0
    for i in range(c):  # the arrived ones to the front, newest first (insertion sort; an inbox holds a few)
        if i_arr[n, r, i] <= t:
            _swap(inbox, n, r, i, m)
            j = m
            while j > 0 and i_seq[n, r, j] > i_seq[n, r, j - 1]:
                _swap(inbox, n, r, j, j - 1)
                j -= 1
            m += 1
    if m == 0:
        return False
    have = False
    seq_taken = -1
    for j in range(m):
        newer = i_seq[n, r, j] > last_seq[n, r]
        if not newer:
            dup[n, r] += 1
        t_read = T[i_src[n, r, j], i_tick[n, r, j]]
        if t - t_read > max_age_s:
            if newer and not have:
                stale[n, r] += 1
            continue
        if newer and not have:
            have = True
            seq_taken = i_seq[n, r, j]
            src_node[n, k, r], src_tick[n, k, r] = i_src[n, r, j], i_tick[n, r, j]
            age[n, k, r] = t - t_read
    if have:
        last_seq[n, r] = seq_taken
    for i in range(m, c):  # drop the arrived packets
        _swap(inbox, n, r, i - m, i)
    i_count[n, r] = c - m
    return have


@njit(cache=True)
def run_events(T, K, dead_at, filter_start, scheduled, nodes_cfg, fallback, chan, margin, draws, radio, stats, mac,
               inbox, last_seq, streak, out, need):
    """Run every tick (module docstring).  ``nodes_cfg`` = (processing_s, max_age_s, every_tick);
    ``fallback`` = (enabled (N,) bool, skip link (N,) int, after_failures, min_margin_db);
    ``out`` = (running (N, K), applied (N, K, R), age, src_node, src_tick (N, K, R), encoder t_read (K, R),
    stale (N, R), duplicate (N, R), events (1,)).  Returns a status code."""
    N, R = T.shape[0], last_seq.shape[1]
    processing_s, max_age_s, every_tick = nodes_cfg
    fb_on, fb_link, fb_after, fb_min_margin = fallback
    running, applied, age, src_node, src_tick, enc_t_read, stale, dup, events = out
    surface = N
    h_t, h_e, h_n = np.empty(N), np.empty(N, dtype=np.int64), np.empty(N, dtype=np.int64)
    size, eid = 0, 0
    next_k = np.zeros(N, dtype=np.int64)
    started = np.zeros(N, dtype=np.bool_)
    ready = np.empty(R)
    valid = np.empty(R, dtype=np.bool_)
    for n in range(N):
        if K[n] > 0 and T[n, 0] < dead_at[n]:
            size = _push(h_t, h_e, h_n, size, 0.0 + (T[n, 0] - 0.0), eid, n)
            eid += 1
    while size > 0:
        now, n, size = _pop(h_t, h_e, h_n, size)
        k = next_k[n]
        t = T[n, k]
        events[0] += 1
        seq = events[0]
        if t >= filter_start[n]:
            if not started[n]:
                started[n] = True
            else:
                running[n, k] = True
                for r in range(R):
                    ready[r] = t
                    valid[r] = every_tick
                if n == 0:
                    if scheduled[k]:
                        for r in range(R):
                            got, arr, end, short = transfer(0, r, t, n, surface, np.inf, chan, draws, radio, stats, mac)
                            if short:
                                need[0], need[1] = 0, r
                                return NEED_DRAWS
                            t_read = arr if got else t
                            enc_t_read[k, r] = t_read
                            if got:
                                have, arr2, end2, short = transfer(0, r, end, surface, n, np.inf, chan, draws, radio,
                                                                   stats, mac)
                                if short:
                                    need[0], need[1] = 0, r
                                    return NEED_DRAWS
                                if have:
                                    applied[n, k, r] = True
                                    age[n, k, r] = arr2 - t_read
                                    ready[r] = arr2
                                    valid[r] = True
                else:
                    for r in range(R):
                        if _select(n, k, r, t, T, max_age_s, inbox, last_seq, stale, dup, src_node, src_tick, age):
                            applied[n, k, r] = True
                            valid[r] = True
                if n < N - 1:
                    for r in range(R):
                        if not valid[r]:
                            continue
                        got, arr, end, short = transfer(n + 1, r, ready[r] + processing_s, n, n + 1, dead_at[n + 1],
                                                        chan, draws, radio, stats, mac)
                        if short:
                            need[0], need[1] = n + 1, r
                            return NEED_DRAWS
                        if got and not _deliver(inbox, n + 1, r, seq, n, k, arr):
                            return INBOX_FULL
                        if not fb_on[n]:
                            continue
                        if got:
                            streak[n, r] = 0
                            continue
                        streak[n, r] += 1
                        link = fb_link[n]
                        g = min(int(t / chan[3][link]), chan[2][link] - 1)
                        if streak[n, r] > fb_after and margin[link, g, r] >= fb_min_margin:
                            got, arr, end, short = transfer(link, r, end, n, n + 2, dead_at[n + 2], chan, draws,
                                                            radio, stats, mac)
                            if short:
                                need[0], need[1] = link, r
                                return NEED_DRAWS
                            if got and not _deliver(inbox, n + 2, r, seq, n, k, arr):
                                return INBOX_FULL
        k += 1
        next_k[n] = k
        if k < K[n] and T[n, k] < dead_at[n]:
            size = _push(h_t, h_e, h_n, size, now + (T[n, k] - now), eid, n)
            eid += 1
    return DONE
