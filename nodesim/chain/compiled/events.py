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
The events come in chunks (:func:`next_events` resumes SimPy's queue where the last chunk ended, :func:`run_events`
takes a chunk in every realization, each realization's state kept between chunks), so that the order of a long run
is never held whole (8 bytes an event: 1.2 GB for the 1000-tube drilling day).  Each link's uniform draws come from
its own PCG64 stream as the MAC needs them (:mod:`.mac_kernel`).  Status codes: 0 done; 2 an inbox is full (the
caller starts again with more slots).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from nodesim.chain.compiled.mac_kernel import time_row, transfer
from nodesim.chain.compiled.prefetch import AHEAD, prefetch
from nodesim.chain.compiled.tick_plan import ASK, HOLD, RUN, STATIC, TOP

DONE, INBOX_FULL = 0, 2


class Records(NamedTuple):
    """Phase 1's records, what phase 2 reads (N nodes, K ticks, R realizations, A encoder requests of the run)."""

    applied: np.ndarray  # (R, N, K) bool: the node took a reference
    src_offset: np.ndarray  # (R, N, K) int8: it came from node n - 1 (1) or n - 2 (2); 0 none or the encoder's
    src_tick: np.ndarray  # (R, N, K) int32: the sender's tick it was read at (where src_offset > 0; else 0)
    ask_t_read: np.ndarray  # (R, A): each encoder request's read time (its arrival; the tick itself where lost)
    ask_age: np.ndarray  # (R, A): the reply's arrival - t_read, NaN where none came back
    stale: np.ndarray  # (R, N) int64
    duplicate: np.ndarray  # (R, N) int64
    ask_first: np.ndarray  # (N,) int64: node n's first request in ``ask_*`` (its requests follow in tick order)


CHUNK_EVENTS = 1 << 18
"""Events per chunk (a chunk is run in every realization before the next is made): two chunks' buffers, 23 bytes an
event (its node, tick, time and plan code; its records), are phase 1's own memory, ~12 MB at this size.  Smaller
chunks cost nothing once the scratch tables' pages are dropped every :data:`.engine.DROP_EVERY_EVENTS` instead of
after every chunk (the day's phase 1: 7.7 s with 1 M-event chunks against 7.2-8.4 s with 4 M, and 9.0-9.2 s with
1 M dropping after each; 2026-12-05, one run each).  2^18, not 2^20, since phase 1 runs beside phase 2's windows
(:mod:`.phase_one`), its memory on top of theirs: the drilling day's first 2 h (two windows) peaked at 534 MB with
1 M-event chunks against 496 MB for its first hour (one window, phase 1 first), and at 498-499 MB against 482 MB with
256 k (whole processes' max RSS, 2026-12-06)."""


def running_ticks(codes: np.ndarray, t_s: np.ndarray, dead_at_s: float) -> np.ndarray:
    """(K,) bool: the node ran that tick (the same in every realization): a :data:`.tick_plan.RUNNING` code on a
    tick that was an event, before the node's death (:func:`next_events` queues a node's ticks while T < dead_at).
    One compiled pass (:func:`_fill_running`), not numpy's look-up ``table[codes] & (t_s < dead_at_s)``, whose int8
    index array is first converted to intp: that took ~6 % of the drilling day's main thread (py-spy, 8 h slice)."""
    out = np.empty(codes.shape[0], np.bool_)
    _fill_running(np.ascontiguousarray(codes), np.ascontiguousarray(t_s, dtype=np.float64), float(dead_at_s), out)
    return out


@njit(cache=True, _nrt=False, nogil=True)
def _fill_running(codes, t_s, dead_at_s, out) -> None:
    for k in range(codes.shape[0]):
        out[k] = _running(codes[k]) and t_s[k] < dead_at_s


@njit(cache=True, inline="always")
def _running(code) -> bool:
    """Whether a tick of plan ``code`` is a running one (:data:`.tick_plan.RUNNING`: ``ASK``, ``TOP``, ``RUN``)."""
    return code == ASK or code == TOP or code == RUN


@njit(cache=True, nogil=True)
def _less(ta, ea, tb, eb) -> bool:
    return ta < tb or (ta == tb and ea < eb)


@njit(cache=True, nogil=True)
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


@njit(cache=True, nogil=True)
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
def _deliver(inbox, r, receiver, seq, sender, tick, t_read, arrival, c_try, c_ber) -> bool:
    i_seq, i_src, i_tick, i_arr, i_count, i_try, i_ber, i_read = inbox
    c = i_count[r, receiver]
    if c == i_seq.shape[2]:
        return False
    i_seq[r, receiver, c], i_src[r, receiver, c], i_tick[r, receiver, c] = seq, sender, tick
    i_arr[r, receiver, c], i_read[r, receiver, c] = arrival, t_read
    i_try[r, receiver, c], i_ber[r, receiver, c] = c_try, c_ber
    i_count[r, receiver] = c + 1
    return True


@njit(cache=True)
def _swap(inbox, r, n, i, j) -> None:
    i_seq, i_src, i_tick, i_arr, _, i_try, i_ber, i_read = inbox
    i_seq[r, n, i], i_seq[r, n, j] = i_seq[r, n, j], i_seq[r, n, i]
    i_src[r, n, i], i_src[r, n, j] = i_src[r, n, j], i_src[r, n, i]
    i_tick[r, n, i], i_tick[r, n, j] = i_tick[r, n, j], i_tick[r, n, i]
    i_arr[r, n, i], i_arr[r, n, j] = i_arr[r, n, j], i_arr[r, n, i]
    i_try[r, n, i], i_try[r, n, j] = i_try[r, n, j], i_try[r, n, i]
    i_ber[r, n, i], i_ber[r, n, j] = i_ber[r, n, j], i_ber[r, n, i]
    i_read[r, n, i], i_read[r, n, j] = i_read[r, n, j], i_read[r, n, i]


@njit(cache=True, inline="always")
def _select(r, n, k, i_ev, t, max_age_s, inbox, last_seq, stale, dup, ev_offset, ev_src, bits) -> bool:
    """Take the packets of node n's inbox that arrived by t and apply the selection rule (module docstring);
    True if a fresh packet was taken: where it came from into the chunk's records at event ``i_ev``
    (:func:`scatter_records`; with ``mac.bit_errors``, its corrupting try, if any, at (r, n, k)).  A packet's age is
    t - T[sender, its tick], that tick time carried in the inbox (``i_read``)."""
    i_seq, i_src, i_tick, i_arr, i_count, i_try, i_ber, i_read = inbox
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
        if t - i_read[r, n, j] > max_age_s:
            if newer and not have:
                stale[r, n] += 1
            continue
        if newer and not have:
            have = True
            seq_taken = i_seq[r, n, j]
            ev_offset[r, i_ev], ev_src[r, i_ev] = n - i_src[r, n, j], i_tick[r, n, j]
            if bits[0]:
                bits[10][r, n, k], bits[11][r, n, k] = i_try[r, n, j], i_ber[r, n, j]
    if have:
        last_seq[r, n] = seq_taken
    for i in range(m, c):  # drop the arrived packets
        _swap(inbox, r, n, i - m, i)
    i_count[r, n] = c - m
    return have


def table_clock(N: int) -> tuple:
    """The ``clock`` argument of :func:`first_events` / :func:`next_events` that reads every tick time from T."""
    return False, np.zeros(N, np.int64), np.zeros(N), np.zeros(N)


@njit(cache=True, inline="always")
def tick_time(T, clock, n, k):
    """Node n's tick k: float(k + first[n]) * period[n] + offset[n] where ``clock`` = (affine, first, period,
    offset) is affine (:meth:`nodesim.chain.network.Network.tick_clock`: the same double as the table's), else
    T[n, k]."""
    if clock[0]:
        return float(k + clock[1][n]) * clock[2][n] + clock[3][n]
    return T[n, k]


def tick_times(T, clock: tuple, n: int, k0: int, k1: int) -> np.ndarray:
    """Node index ``n``'s ticks k0 .. k1 - 1 (:func:`tick_time`, a new array): computed where the clock is affine,
    without mapping the tick table's pages (a copy of its row read them back from the scratch file: ~2.5 % of the
    drilling day's main thread, py-spy, 8 h slice)."""
    out = np.empty(max(k1 - k0, 0))
    _fill_tick_times(T, clock, n, k0, out)
    return out


@njit(cache=True, nogil=True)
def _fill_tick_times(T, clock, n, k0, out) -> None:
    for i in range(out.size):
        out[i] = tick_time(T, clock, n, k0 + i)


def first_events(T, K, dead_at, clock) -> tuple:
    """SimPy's event queue at t = 0 (each node's first tick): (queue (heap times, creation counters, nodes; ring
    times, creation counters, nodes: :func:`next_events`), counters [heap size, next creation counter, ring head,
    ring size], next tick (N,)).  The first ticks go into the heap (a node inserted later waits there)."""
    N = T.shape[0]
    queue = (np.empty(N), np.empty(N, dtype=np.int64), np.empty(N, dtype=np.int64),
             np.empty(N), np.empty(N, dtype=np.int64), np.empty(N, dtype=np.int64))
    counters, next_k = np.zeros(4, dtype=np.int64), np.zeros(N, dtype=np.int64)
    _first_events(T, K, dead_at, clock, queue, counters)
    return queue, counters, next_k


@njit(cache=True, nogil=True)
def _first_events(T, K, dead_at, clock, queue, counters) -> None:
    h_t, h_e, h_n = queue[0], queue[1], queue[2]
    size, eid = 0, 0
    for n in range(T.shape[0]):
        if K[n] == 0:
            continue
        t0 = tick_time(T, clock, n, 0)
        if t0 < dead_at[n]:
            size = _push(h_t, h_e, h_n, size, 0.0 + (t0 - 0.0), eid, n)
            eid += 1
    counters[0], counters[1] = size, eid


@njit(cache=True, nogil=True)
def next_events(T, K, dead_at, plan, queue, counters, next_k, nodes, ticks, times, codes, clock) -> int:
    """The next events in SimPy's order (module docstring), resuming the queue of :func:`first_events`: (node, tick)
    into ``nodes``, ``ticks`` (int32: a run's nodes and ticks stay far below 2^31; a day at 1.9 Hz is 164 k ticks),
    the tick's time T[n, k] into ``times`` and its code plan[n, k] into ``codes``, as many as fit; returns how many
    (0: the run is over).  A node's next tick is queued at now + (T - now), as ``env.timeout(t - env.now)``
    schedules it; its ticks are events while T < its ``dead_at`` (the running flags phase 2 needs follow from that
    and the plan: :func:`running_ticks`).

    The chunk carries each event's time and code, read here, because this runs on its own thread beside
    :func:`run_events`: T and plan are (N, K) tables, node-major, and events come in time order, one node after
    another, so each of those reads lands on another node's row (a cache and TLB miss each; T[n, k] alone was ~30 %
    of phase 1 on the drilling day when :func:`run_events` read it): the entries of the event :data:`.prefetch.AHEAD`
    on in the ring are prefetched (5.4 -> 3.5 s for the day's 146.5 M events).  Where ``clock`` is affine
    (:func:`tick_time`) the tick times are computed, not read: T is not touched.

    The queue is a ring of events in (time, creation counter) order plus a heap of the rest; the next event is
    the smaller head of the two.  A new event has the largest counter yet, so it goes at the end of the ring when
    its time is not before the ring's last one (a node's next tick, one period on, nearly always is: every node
    ticks at 1.9 Hz), else into the heap (a clock that gained on its neighbour, a node inserted later).  That is
    the order of one heap of all of them (the same (time, counter) keys, merged), at O(1) an event instead of
    O(log N): the 1000-tube day's event order took ~22 s with the heap alone."""
    h_t, h_e, h_n, r_t, r_e, r_n = queue
    N = r_t.shape[0]
    size, eid, head, ring = counters[0], counters[1], counters[2], counters[3]
    e = 0
    while (size > 0 or ring > 0) and e < nodes.shape[0]:
        if ring > AHEAD:  # the entries of the event AHEAD on in the ring, asked for now (:mod:`.prefetch`)
            a = head + AHEAD if head + AHEAD < N else head + AHEAD - N
            m = r_n[a]
            if not clock[0]:
                prefetch(T, (m, next_k[m]))
            prefetch(plan, (m, next_k[m]))
        if ring > 0 and (size == 0 or _less(r_t[head], r_e[head], h_t[0], h_e[0])):
            now, n = r_t[head], r_n[head]
            head = head + 1 if head + 1 < N else 0
            ring -= 1
        else:
            now, n, size = _pop(h_t, h_e, h_n, size)
        k = next_k[n]
        nodes[e], ticks[e], times[e] = n, k, tick_time(T, clock, n, k)
        code = plan[n, k]
        codes[e] = code
        e += 1
        k += 1
        next_k[n] = k
        tk = tick_time(T, clock, n, k) if k < K[n] else np.inf  # the node's next tick (none: never scheduled)
        if tk < dead_at[n]:
            t = now + (tk - now)
            tail = head + ring if head + ring < N else head + ring - N  # the slot after the ring's last event
            if ring == 0 or t >= r_t[tail - 1 if tail > 0 else N - 1]:
                r_t[tail], r_e[tail], r_n[tail] = t, eid, n
                ring += 1
            else:
                size = _push(h_t, h_e, h_n, size, t, eid, n)
            eid += 1
    counters[0], counters[1], counters[2], counters[3] = size, eid, head, ring
    return e


@njit(cache=True, _nrt=False, nogil=True)
def forwarded_ages(t, src_offset, src_tick, t_above, t_two_above, age) -> None:
    """``age[r, k]`` = t[k] - t_(n-s)[j] where phase 1 gave the node the estimate node n - s (``src_offset`` s = 1, 2)
    read at its tick j (``src_tick``): the age :func:`_select` compared with ``max_update_age_s`` and the SimPy
    engine records (the same two doubles subtracted); NaN at the other ticks (no forwarded estimate)."""
    for r in range(src_offset.shape[0]):
        for k in range(src_offset.shape[1]):
            s = src_offset[r, k]
            if s == 1:
                age[r, k] = t[k] - t_above[src_tick[r, k]]
            elif s == 2:
                age[r, k] = t[k] - t_two_above[src_tick[r, k]]
            else:
                age[r, k] = np.nan


@njit(cache=True, _nrt=False, nogil=True)
def scatter_records(chunk, rec, applied, src_offset, src_tick) -> None:
    """Put a chunk's records by event (``rec`` = (applied, offset, source tick) (R, chunk size), :func:`run_events`)
    in place in the node-major (R, N, K) tables of :class:`Records` and zero them for the next chunk.  A separate
    pass on the events thread: the events come in time order, one node after another, so each write lands on
    another node's row (a cache and TLB miss each, ~17 % of phase 1 on the drilling day where :func:`run_events`
    made them); a record is set only where a reference was applied (an offset only with a forwarded one)."""
    ev_node, ev_tick = chunk[0], chunk[1]
    ev_applied, ev_offset, ev_src = rec
    for r in range(ev_applied.shape[0]):
        for i in range(ev_node.shape[0]):
            if ev_applied[r, i]:
                n, k = ev_node[i], ev_tick[i]
                applied[r, n, k] = True
                ev_applied[r, i] = False
                if ev_offset[r, i] > 0:
                    src_offset[r, n, k], src_tick[r, n, k] = ev_offset[r, i], ev_src[r, i]
                    ev_offset[r, i], ev_src[r, i] = 0, 0


@njit(cache=True, _nrt=False, nogil=True)
def run_events(N, chunk, e_first, dead_at, surveys, nodes_cfg, fallback, chan, margin, draws, radio, stats, mac,
               bits, scratch, inbox, last_seq, streak, out, rec, cursor, r_first, r_end):
    """Run the events ``chunk`` = (nodes, ticks, times, codes) from :func:`next_events` (each event's tick time and
    plan code, :mod:`.tick_plan`, come with it), the run's events ``e_first`` on, in realizations ``r_first`` ..
    ``r_end - 1`` (module docstring; disjoint ranges may run on parallel threads), ``N`` the number of nodes.
    ``cursor`` = (next survey (R, N), next encoder request (R, N)) of each node, kept from chunk to chunk (start:
    ``surveys`` first, ``out.ask_first``).  ``surveys`` = (first (N,), stop (N,), tick (S,), top (S,),
    arrival (R, S), event (S,), skip (N,)): the surveys node n sends, ``first[n]`` .. ``stop[n] - 1`` in tick
    order, each at its tick, up to the top node of its time and the ground station (arrival NaN where lost; its
    event's index, written by realization 0; ``skip[h]``: node h may send a survey its neighbour above left
    unanswered on to node h - 2); ``nodes_cfg`` = (processing_s, max_age_s, every_tick);
    ``fallback`` = (enabled (N,) bool, skip link (N,) int, after_failures, min_margin_db); ``draws`` (R, L, 4): each
    link's PCG64 state, ``bits``, ``scratch``: :mod:`.mac_kernel`; ``out``: the :class:`Records` it fills (the
    encoder requests node by node), except
    applied, src_offset and src_tick: those go by event into ``rec`` = (applied, offset, source tick) (R, chunk
    size), zero where nothing was taken, which :func:`scatter_records` puts in place.  The age
    of a forwarded reference is not kept: it is T[n, k] - T[n - s, j], which phase 2 computes again.  Links: down
    link h = h (0: the surface link, the encoder exchange of whichever node is on top), skip link of node n = N + n,
    up link h = 2N + h, survey skip link of node h (up to h - 2) = 3N + h.
    Returns a status code."""
    ev_node, ev_tick, ev_time, ev_code = chunk
    processing_s, max_age_s, every_tick = nodes_cfg
    fb_on, fb_link, fb_after, fb_min_margin = fallback
    s_first, s_stop, s_tick, s_top, s_arrival, s_event, s_skip = surveys
    ask_t_read, ask_age, stale, dup = out.ask_t_read, out.ask_age, out.stale, out.duplicate
    ev_applied, ev_offset, ev_src = rec
    s_cursor, a_cursor = cursor
    i_count = inbox[4]
    surface = N
    for r in range(r_first, r_end):
        for i in range(ev_node.shape[0]):
            e = e_first + i
            n, k = ev_node[i], ev_tick[i]
            t, code = ev_time[i], ev_code[i]
            seq = e + 1
            if code == STATIC:
                continue
            if code == HOLD:
                i_count[r, n] = 0  # nothing arrives from a powered-down link; the state is saved
            ready = t
            valid = every_tick and _running(code)
            if code == ASK:
                got, arr, end, _, _ = transfer(0, r, t, n, surface, np.inf, chan, draws, radio, stats, mac, bits,
                                               scratch)
                t_read = arr if got else t
                a = a_cursor[r, n]
                a_cursor[r, n] = a + 1
                ask_t_read[r, a] = t_read
                if got:
                    have, arr2, end2, _, _ = transfer(0, r, end, surface, n, np.inf, chan, draws, radio, stats, mac,
                                                      bits, scratch)
                    if have:
                        ev_applied[r, i] = True
                        ask_age[r, a] = arr2 - t_read
                        ready = arr2
                        valid = True
            elif code == RUN and _select(r, n, k, i, t, max_age_s, inbox, last_seq, stale, dup, ev_offset, ev_src,
                                         bits):
                ev_applied[r, i] = True
                valid = True
            if n < N - 1 and valid:
                status = _send_estimate(r, e, n, k, seq, ready + processing_s, t, dead_at, fb_on, fb_link, fb_after,
                                        fb_min_margin, chan, margin, draws, radio, stats, mac, bits, scratch, inbox,
                                        streak)
                if status != DONE:
                    return status
            while s_cursor[r, n] < s_stop[n] and s_tick[s_cursor[r, n]] == k:
                s = s_cursor[r, n]
                s_cursor[r, n] = s + 1
                if r == 0:
                    s_event[s] = e
                _send_survey(r, n, s_top[s], ready, t, dead_at, s_skip, fb_min_margin, chan, margin, draws, radio,
                             stats, mac, bits, scratch, s_arrival, s)
    return DONE


@njit(cache=True, inline="always")
def _send_estimate(r, e, n, k, seq, t_ready, t, dead_at, fb_on, fb_link, fb_after, fb_min_margin, chan, margin,
                   draws, radio, stats, mac, bits, scratch, inbox, streak) -> int:
    """Node n's estimate frame down its link, with the fallback to the next-but-one node (a status code)."""
    got, arr, end, c_try, c_ber = transfer(n + 1, r, t_ready, n, n + 1, dead_at[n + 1], chan, draws, radio, stats,
                                           mac, bits, scratch)
    if got and not _deliver(inbox, r, n + 1, seq, n, k, t, arr, c_try, c_ber):
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
        got, arr, end, c_try, c_ber = transfer(link, r, end, n, n + 2, dead_at[n + 2], chan, draws, radio, stats,
                                               mac, bits, scratch)
        if got and not _deliver(inbox, r, n + 2, seq, n, k, t, arr, c_try, c_ber):
            return INBOX_FULL
    return DONE


@njit(cache=True, inline="always")
def _send_survey(r, n, top, at, t, dead_at, skip_on, min_margin_db, chan, margin, draws, radio, stats, mac, bits,
                 scratch, arrival, s) -> None:
    """Node n's survey, ready at ``at``, hop by hop up to node ``top`` and the ground station: up link 2N + h from
    node h to h - 1 (hop 1's, 2N, from the top node to the surface); a hop left unanswered goes on over node h's
    survey skip link 3N + h to h - 2 where ``skip_on[h]``, h - 2 is not above the top node and the skip hop's margin
    at t is at least ``min_margin_db`` (:meth:`nodesim.chain.network.Network.send_survey`).  ``arrival[r, s]`` = its
    arrival at the ground station (left NaN where lost)."""
    N = dead_at.shape[0]
    surface = N
    h = n
    while h >= top:
        rx, up = (h - 1, 2 * N + h) if h > top else (surface, 2 * N)
        got, arr, end, _, _ = transfer(up, r, at, h, rx, dead_at[rx] if h > top else np.inf, chan, draws, radio,
                                       stats, mac, bits, scratch)
        if got:
            at, h = arr, h - 1
            continue
        link = 3 * N + h
        if math.isnan(end) or not skip_on[h] or h - 2 < top or margin[r, link, time_row(chan, link, t)] < min_margin_db:
            return  # lost here
        got, arr, end, _, _ = transfer(link, r, end, h, h - 2, dead_at[h - 2], chan, draws, radio, stats, mac, bits,
                                       scratch)
        if not got:
            return
        at, h = arr, h - 2
    arrival[r, s] = at
