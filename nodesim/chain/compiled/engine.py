"""The compiled chain engine: the SimPy engine's model and numbers, without a Python call per event.

:func:`simulate_compiled` takes a built :class:`nodesim.chain.network.Network` (clocks, sensor signals, hop
channels, links with their draw streams, faults: the same objects the SimPy engine runs on) and

1. resolves every tick, frame and packet in SimPy's event order in one compiled loop
   (:mod:`.events`, :mod:`.mac_kernel`): which reference each node takes at each tick in each realization;
2. runs each node's filter over its ticks, top node first (:mod:`.filters` with :mod:`.float_kernel` or
   :mod:`firmware_model.fixed_kernel`), since estimates only flow down;
3. fills the nodes', links' and radios' records, so :meth:`Network.result` builds the same :class:`ChainRun`.

Bit-identical to the SimPy engine (tests/nodesim/chain/test_compiled.py compares every record).  Covered: lab
and drilling motion (tube insertions: a node ticks from its insertion, its static window, the holds of the nodes
below, the top node of the time asking the encoder, survey stops and the surveys going up hop by hop to the ground
station, over the skip hop past a silent node), every schedule, simple and channel links (soil, pipe, cable), the
MAC, node failures, outages, bursts, clock steps, per-node clocks and the fallback, float and fixed filters
(default fixed-point policy), the fixed firmware's estimate frames as bytes (:mod:`.frame_pass`) and
``mac.bit_errors`` (phase 1 decides each try on its error pattern, phase 2 applies the flips the CRC let through
to the received bytes, :mod:`nodesim.chain.bit_errors`) on the estimates going down; bit errors in the survey
frames going up are the SimPy engine's only (``unsupported``).  What each node does at each tick comes from one
plan (:mod:`.tick_plan`).
Each lane of a link draws its uniforms from the link's own stream as the MAC needs them (same stream, same numbers);
phase 1 takes the events in chunks, so that neither draws nor the event order of a long run are held whole; what
it records per node-tick is 7 bytes a realization (which estimate reaches which tick).
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from nodesim import threads
from nodesim.chain.compiled import events as ev
from firmware_model import fixed_kernel
from firmware_model import frames as fr
from firmware_model import node_firmware as nf
from firmware_model import six_state_fixed as six_state
from nodesim.chain import bit_errors
from nodesim.chain import scratch as spill
from nodesim.chain.compiled import (filters, firmware_constants, float_kernel, frame_pass, six_state_fixed_node,
                                    six_state_node, time_windows)
from nodesim.chain.compiled import tick_plan as tp
from nodesim.chain.compiled.phase_one import PhaseOne, ground_surveys
from nodesim.chain.compiled.references import above_nodes, asks, encoder_reads, encoder_words, float_references
from nodesim.chain.mac import LinkStats
from nodesim.errors import NodesimError
from nodesim.scenario.schema import Scenario

INBOX_SLOTS = 8


def unsupported(scenario: Scenario) -> str | None:
    """Why the compiled engine cannot run ``scenario`` (None when it can)."""
    if scenario.motion.kind == "drilling" and scenario.mac.bit_errors:
        return ("mac.bit_errors = true with motion.kind = 'drilling' (bit errors in the survey frames going up) needs "
                "simulation.engine = 'event'")
    return None


def choose_engine(scenario: Scenario) -> str:
    """'compiled' or 'event' for ``simulation.engine`` (auto: compiled where it covers the scenario)."""
    want = scenario.simulation.engine
    why = unsupported(scenario)
    if want == "compiled" and why is not None:
        raise NodesimError(f"simulation.engine = 'compiled': {why}; allowed here: 'event' or 'auto'")
    if want == "event" or why is not None:
        return "event"
    return "compiled"


class _Links:
    """Every link phase 1 may use: down links 0..N-1 (hop h), skip links N + i (node i's fallback; its object is
    built only if phase 1 used it), up links 2N + h (hop h, surveys), survey skip links 3N + h (node h's surveys
    past a silent neighbour, to node h - 2; likewise), as realization-major arrays (:mod:`.mac_kernel`), with each
    lane's PCG64 state at the start of its stream (``states``).  ``surveys``: whether any node sends a survey."""

    def __init__(self, net, surveys: bool):
        N, R = net.n_nodes, net.R
        self.net = net
        self.links: list = list(net.down_links) + [None] * N + list(net.up_links) + [None] * N
        channels = [x.channel for x in net.down_links] + [
            net._skips[i + 1] if node.fallback.enabled else None for i, node in enumerate(net.nodes)] + [
            x.channel for x in net.up_links] + [net.up_skip_channel(h + 1) if surveys else None for h in range(N)]
        bursts = [x.burst for x in net.down_links] + [None] * N + [x.burst for x in net.up_links] + [None] * N
        outages = [x.outages for x in net.down_links] + [()] * N + [x.outages for x in net.up_links] + [()] * N
        self.up_skips = np.array([ch is not None for ch in channels[3 * N:]])
        live = [ch for ch in channels if ch is not None]
        G = max(ch.per_data_table.shape[0] for ch in live)
        O = max([len(o) for o in outages] + [1])
        L = len(channels)
        per_data, per_ack, margin = np.zeros((R, L, G)), np.zeros((R, L, G)), np.zeros((R, L, G))
        rows, step = np.ones(L, dtype=np.int64), np.ones(L)
        air, ack_air = np.zeros(L), np.zeros(L)
        burst, out, n_out = np.zeros((L, 5)), np.zeros((L, O, 2)), np.zeros(L, dtype=np.int64)
        for i, ch in enumerate(channels):
            if ch is None:
                continue
            g = ch.per_data_table.shape[0]
            per_data[:, i, :g], per_ack[:, i, :g] = ch.per_data_table.T, ch.per_ack_table.T
            margin[:, i, :ch.margin_db.shape[0]] = ch.margin_db.T
            rows[i], step[i], air[i], ack_air[i] = g, ch.step_s, ch.airtime_s, ch.ack_airtime_s
            if bursts[i] is not None:
                b = bursts[i]
                burst[i] = (1.0, b.p_good_to_bad, b.p_bad_to_good, b.loss_good, b.loss_bad)
            for j, (a, z) in enumerate(outages[i]):
                out[i, j] = (a, z)
            n_out[i] = len(outages[i])
        self.chan = (per_data, per_ack, rows, step, air, ack_air, burst, out, n_out)
        self.margin = margin
        self.bits = self._bits(channels)
        self.states = np.zeros((R, L, 4), np.uint64)  # every lane's PCG64 state where its draws start
        for i, ch in enumerate(channels):
            if ch is not None:
                self.states[:, i] = self._stream_states(i)

    def _bits(self, channels) -> tuple:
        """``mac.bit_errors`` (:mod:`.mac_kernel`): BER and preamble loss tables and the bit-error keys of the
        links that carry estimate frames (down links 1.., skip links; placeholders when off)."""
        net = self.net
        N, R, L = net.n_nodes, net.R, len(channels)
        on = net.scenario.mac.bit_errors
        G = self.chan[0].shape[2] if on else 1
        ber, per_pre = np.zeros((R, L, G) if on else (1, 1, 1)), np.zeros((R, L, G) if on else (1, 1, 1))
        keys = np.zeros((R, L) if on else (1, 1), np.uint64)
        has_bytes = np.zeros(L, dtype=bool)
        for i, ch in enumerate(channels):
            if not on or ch is None or i == 0 or i >= 2 * N:  # link 0: the encoder exchange (no frame bytes); up
                # (and survey skip) links carry survey frames, which mac.bit_errors does not reach on this engine (``unsupported``)
                continue
            g = ch.ber_table.shape[0]
            ber[:, i, :g], per_pre[:, i, :g] = ch.ber_table.T, ch.per_preamble_table.T
            keys[:, i] = (net._streams.bit_error_keys(R, i) if i < N else
                          net._streams.skip_bit_error_keys(R, i - N + 1))
            has_bytes[i] = True
        K = max(n.t_s.size for n in net.nodes)
        shape, arrays = ((R, N, K), net.scratch) if on else ((1, 1, 1), None)  # each tick's try and BER (16 bytes a
        # node-tick): on disk with the records where they are; _resolve sets the tries to -1 before each attempt
        err = (spill.zeros(arrays, shape, np.int64), spill.zeros(arrays, shape, float))
        counts = np.zeros((R, L), np.int64), np.zeros((R, L), np.int64)
        return (on, ber, per_pre, keys, has_bytes, bit_errors.zero_frame(fr.ESTIMATE), fr.ESTIMATE_LAYOUT,
                fr.ESTIMATE, *counts, *err)

    def link(self, i: int):
        """Link ``i``'s object (a skip link is built on first use, as the SimPy engine does)."""
        N = self.net.n_nodes
        if self.links[i] is None:
            self.links[i] = self.net.skip_link(i - N + 1) if i < 3 * N else self.net.up_skip_link(i - 3 * N + 1)
        return self.links[i]

    def _stream_states(self, i: int) -> np.ndarray:
        """Link ``i``'s PCG64 states (R, 4) at the start of its stream."""
        streams, N, R = self.net._streams, self.net.n_nodes, self.net.R
        if N <= i < 2 * N:
            return streams.skip_link_states(R, i - N + 1)
        if i >= 3 * N:
            return streams.skip_link_states(R, i - 3 * N + 1, up=True)
        return streams.link_states(R, i if i < N else i - N)  # down link h = h, up link h = 2N + h: links N + h

    def store(self, stats: tuple) -> None:
        frames, delivered, attempts, dropped, latency, _ = stats
        for i in range(len(self.links)):
            if self.links[i] is None and not frames[:, i].any():
                continue  # a skip link that never carried a frame (the SimPy engine does not build it either)
            x = self.link(i)
            x.stats = LinkStats(frames.shape[0])
            x.stats.frames, x.stats.delivered = frames[:, i].copy(), delivered[:, i].copy()
            x.stats.attempts, x.stats.dropped = attempts[:, i].copy(), dropped[:, i].copy()
            x.stats.latency_sum_s = latency[:, i].copy()
            if self.bits[0]:
                x.stats.crc_rejected, x.stats.undetected = self.bits[8][:, i].copy(), self.bits[9][:, i].copy()


def _survey_plan(net, plan: np.ndarray) -> tuple:
    """The surveys the nodes send (:class:`nodesim.motion.timelines.SurveyStop`), as :meth:`ChainNode.process` sends
    them: at a node's first tick inside [t_survey, end) of its stop where it is not in its static window, up to the
    top node present then.  (stops, first (N,), stop (N,), tick (S,), top (S,)), sorted by node then tick."""
    N = net.n_nodes
    rows = []  # (node index, tick, top index, stop)
    for n, node in enumerate(net.nodes):
        t, codes = node.t_s, plan[n, :node.t_s.size]
        for stop in node.stops:  # the ticks in [t_survey, end) by bisection: the node's whole row is not read
            lo, hi = np.searchsorted(t, [stop.t_survey_s, stop.end_s], side="left").tolist()
            k = lo + np.flatnonzero((codes[lo:hi] != tp.STATIC) & (codes[lo:hi] != tp.ABSENT))
            if k.size:
                top = net.motion.top_node_id(t[k[0]]) - 1
                rows.append((n, int(k[0]), top, stop))
    rows.sort(key=lambda x: (x[0], x[1]))
    nodes = np.array([x[0] for x in rows], dtype=np.int64)
    first = np.searchsorted(nodes, np.arange(N), side="left").astype(np.int64)
    last = np.searchsorted(nodes, np.arange(N), side="right").astype(np.int64)
    ticks = np.array([x[1] for x in rows], dtype=np.int64)
    tops = np.array([x[2] for x in rows], dtype=np.int64)
    return [(x[0], x[1], x[3]) for x in rows], first, last, ticks, tops


def _resolve(net, links: _Links, T: np.ndarray, K: np.ndarray, plan: np.ndarray, survey_plan: tuple,
             beside: PhaseOne | None = None):
    """Phase 1 (:mod:`.events`): the events chunk by chunk, each chunk over ranges of realizations on threads
    (:mod:`nodesim.threads`) while the next chunk is made on another; started again with more inbox slots until
    every range completes.  (events, :class:`.events.Records`, radio, stats, (survey arrival (R, S), event (S,))).
    ``beside`` (phase 1 beside phase 2, :mod:`.phase_one`) is told, once each chunk's records are in place, up to
    which time they are final (not after a chunk that found an inbox full)."""
    N, R = net.n_nodes, net.R
    c, m = net.scenario.chain, net.scenario.mac
    Kmax = int(K.max())
    dead_at = np.array([n.dead_at_s for n in net.nodes], dtype=float)
    _, s_first, s_stop, s_tick, s_top = survey_plan
    fb = net.scenario.faults
    fallback = (np.array([n.fallback.enabled for n in net.nodes]), np.arange(N, 2 * N, dtype=np.int64),
                fb.fallback_after_failures, fb.fallback_min_margin_db)
    asks = (plan == tp.ASK).sum(axis=1)  # each node's encoder requests, node by node in the records
    ask_first = np.concatenate(([0], np.cumsum(asks)[:-1])).astype(np.int64)
    A = max(int(asks.sum()), 1)
    nodes_cfg = (c.processing_s, c.max_update_age_s, net.forward_every_tick)
    mac = np.array([float(m.enabled), m.max_retries, m.queue_length, m.turnaround_s, m.ack_timeout_s, m.duty_cycle])
    slots = INBOX_SLOTS
    L, radios = len(links.links), N + 1
    while True:
        radio = (np.full((R, radios), -np.inf), np.full((R, radios), -np.inf), np.full((R, radios), -np.inf),
                 np.full((R, radios, m.queue_length), -np.inf), np.zeros((R, radios)), np.zeros((R, radios)))
        stats = (np.zeros((R, L), np.int64), np.zeros((R, L), np.int64), np.zeros((R, L), np.int64),
                 np.zeros((R, L), np.int64), np.zeros((R, L)), np.zeros((R, L), dtype=bool))
        inbox = (np.zeros((R, N, slots), np.int64), np.zeros((R, N, slots), np.int64),
                 np.zeros((R, N, slots), np.int64), np.zeros((R, N, slots)), np.zeros((R, N), np.int64),
                 np.full((R, N, slots), -1, np.int64), np.zeros((R, N, slots)), np.zeros((R, N, slots)))
        bits = links.bits
        for a in bits[8:10]:
            a[:] = 0
        spill.fill(net.scratch, bits[10], -1)  # the whole-run tables: on disk where they are large (net.scratch)
        out = ev.Records(spill.zeros(net.scratch, (R, N, Kmax), bool),
                         spill.zeros(net.scratch, (R, N, Kmax), np.int8),
                         spill.zeros(net.scratch, (R, N, Kmax), np.int32),
                         np.full((R, A), np.nan), np.full((R, A), np.nan), np.zeros((R, N), np.int64),
                         np.zeros((R, N), np.int64), ask_first)
        surveys = (s_first, s_stop, s_tick, s_top, np.full((R, s_tick.size), np.nan), np.zeros(s_tick.size, np.int64),
                   links.up_skips)
        draws, last_seq, streak = links.states.copy(), np.full((R, N), -1, np.int64), np.zeros((R, N), np.int64)
        cursor = (np.repeat(s_first[None, :], R, axis=0), np.repeat(ask_first[None, :], R, axis=0))

        size = _chunk_events(K, R)
        recs = [(np.zeros((R, size), bool), np.zeros((R, size), np.int8), np.zeros((R, size), np.int32))
                for _ in range(2)]  # a chunk's records by event, two: one filled while the other is put in place

        full = [False]  # a chunk found an inbox full: its records and those after it are not final

        def run(chunk: tuple, e_first: int, slot: int) -> int:  # one chunk in every realization, ranges on threads
            if beside is not None:
                beside.check()  # phase 2 failed: stop here
            def lanes(r0: int, r1: int) -> int:
                scratch = (np.zeros(fr.ESTIMATE_BYTES, np.uint8), np.zeros(len(fr.FIELDS[fr.ESTIMATE]), np.int64))
                return ev.run_events(N, chunk, e_first, dead_at, surveys, nodes_cfg, fallback, links.chan,
                                     links.margin, draws, radio, stats, mac, bits, scratch, inbox, last_seq, streak,
                                     out, recs[slot], cursor, r0, r1)
            status = max(threads.map_chunks(lanes, R))
            full[0] = full[0] or status != ev.DONE
            if (e_first + chunk[0].size) // DROP_EVERY_EVENTS > e_first // DROP_EVERY_EVENTS:
                spill.drop(net.scratch)  # the pages of the tables read and written so far leave the process
                spill.write_out(net.scratch)  # and go to the disk now, not in one burst later (ScratchArrays.write_out)
            return status

        def scatter(chunk: tuple, slot: int) -> None:
            ev.scatter_records(chunk, recs[slot], out.applied, out.src_offset, out.src_tick)
            if beside is not None and not full[0]:  # every event before this chunk's last one is done
                beside.publish(out, surveys[4:6], float(chunk[2][-1]))

        events, status = _each_chunk(T, K, dead_at, plan, net.tick_clock(), size, run, scatter)
        if status == ev.DONE:
            return events, out, radio, stats, surveys[4:6]
        slots *= 2


DROP_EVERY_EVENTS = 1 << 22
"""Phase 1 takes the scratch tables' pages out of the process (:func:`nodesim.chain.scratch.drop`) each time its
events pass a multiple of this: what stays mapped in between (~15 bytes an event: the tick tables read, the records
written) is bounded, and a node's partly written page is not read back from the file after every chunk."""

RECORD_BUFFER_BYTES = 64 * 2**20
"""Phase 1's records by event (:func:`.events.scatter_records`, 6 bytes an event and realization) take at most about
this much per chunk: a run of many realizations takes its events in smaller chunks."""


def _chunk_events(K: np.ndarray, R: int) -> int:
    """Events per chunk of phase 1: :data:`.events.CHUNK_EVENTS`, fewer for many realizations
    (:data:`RECORD_BUFFER_BYTES`), at most the run's ticks (at least its events)."""
    return max(min(ev.CHUNK_EVENTS, max(RECORD_BUFFER_BYTES // (6 * R), 4096), int(K.sum())), 1)


def _each_chunk(T, K, dead_at, plan, clock: tuple, size: int, run: Callable, finish: Callable) -> tuple[int, int]:
    """``run(chunk, first event, slot)`` over the run's events in chunks of at most ``size`` (:func:`.events.next_events`:
    nodes, ticks, tick times (from ``clock`` where it is affine), plan codes), then ``finish(chunk, slot)``; ``slot`` (0, 1)
    alternates from chunk to chunk.  One worker thread makes the next chunk while ``run`` takes the last one, and
    runs ``finish`` after it (in that order: the chunk after next, in the same slot, is made after the finish of
    this one); every ``finish`` is done when this returns (events, the first status that is not DONE, else DONE)."""
    from concurrent.futures import ThreadPoolExecutor

    queue, counters, next_k = ev.first_events(T, K, dead_at, clock)
    buffers = [(np.empty(size, np.int32), np.empty(size, np.int32), np.empty(size), np.empty(size, np.int8))
               for _ in range(2)]

    def make(i: int) -> tuple:
        chunk = buffers[i % 2]
        count = ev.next_events(T, K, dead_at, plan, queue, counters, next_k, *chunk, clock)
        return tuple(a[:count] for a in chunk)

    done = 0
    with ThreadPoolExecutor(1, thread_name_prefix="nodesim-events") as pool:
        coming = pool.submit(make, 0)
        i = 0
        while True:
            chunk = coming.result()
            if not chunk[0].size:
                return done, ev.DONE
            slot = i % 2
            i += 1
            coming = pool.submit(make, i)  # into the other buffer, while this one runs
            status = run(chunk, done, slot)
            done += chunk[0].size
            pool.submit(finish, chunk, slot)
            if status != ev.DONE:
                coming.result()
                return done, status


def _attach_records(net, n: int, out: ev.Records, codes: np.ndarray) -> None:
    """Node index ``n``'s records from phase 1: running, applied (a view), stale and duplicate packets, and each
    update's age: the encoder reply's from phase 1, a forwarded estimate's t_n[k] - t_(n-s)[j] again
    (:func:`.events.forwarded_ages`: the same subtraction phase 1 made)."""
    node = net.nodes[n]
    K = node.t_s.size
    node.running[:] = ev.running_ticks(codes, node.t_s, node.dead_at_s)
    node.applied = out.applied[:, n, :K]
    node.stale, node.duplicate = out.stale[:, n].copy(), out.duplicate[:, n].copy()
    above = above_nodes(net, n)
    node.age = np.empty((net.R, K))  # every tick written below
    ev.forwarded_ages(node.t_s, out.src_offset[:, n, :K], out.src_tick[:, n, :K], above[0].t_s, above[1].t_s, node.age)
    ask, rows = asks(n, codes, out)
    if ask.size:
        node.age[:, ask] = out.ask_age[:, rows]


def _run_node(net, n: int, out, bits, codes: np.ndarray) -> None:
    """Phase 2 for node index ``n`` (module docstring); writes the node's records."""
    from nodesim.chain.estimator import new_filter

    node, sig = net.nodes[n], net.nodes[n].sig
    t, R = sig.t_s, net.R
    K = t.size
    k_end = int(np.searchsorted(t, node.dead_at_s, side="left"))
    starts = np.flatnonzero(codes == tp.START)
    _attach_records(net, n, out, codes)
    # the ticks that read the encoder at the tick itself (the static window, the start), as indices: read once;
    # a boolean index over the node's (R, K) records would count and find them again at each use
    at_tick = np.flatnonzero((codes == tp.STATIC) | (codes == tp.START))
    static = codes[at_tick] == tp.STATIC
    enc_yaw = net.encoder.read_many(t[at_tick])[0] if at_tick.size else None
    if static.any():
        node.yaw[:, at_tick[static]] = enc_yaw[static]
    if not starts.size:
        return
    n_static = int(starts[0])
    if net.scenario.filter.states == 6 and net.scenario.filter.implementation != "fixed":  # float 6-state (issue 24)
        six_state_node.run(net, n, out, k_end, n_static, codes, encoder_reads(net, n, t, codes, out))
        return
    if net.scenario.filter.implementation == "fixed":
        _run_node_firmware(net, n, out, k_end, n_static, codes, bits, at_tick, enc_yaw)
        return
    bias0 = filters.sequential_sum(sig.gyro_rad_s, n_static) / n_static if n_static else 0.0
    node.kf = new_filter(net.scenario, R, net.encoder.read(t[n_static])[0], bias0)
    node._record(n_static)
    state, params = float_kernel.lane_states(node.kf), float_kernel.kernel_params(node.kf)
    enc_ref, offset, up = float_references(net, n, encoder_reads(net, n, t, codes, out), out.src_offset)
    src_tick = out.src_tick[:, n, :K]

    def run(r0: int, r1: int) -> np.ndarray:
        counts = np.zeros(len(fixed_kernel.SITES), dtype=np.int64)  # per range of realizations, summed below
        filters.run_node(state, params, counts, sig.gyro_rad_s, t, n_static + 1, k_end,
                         codes, enc_ref, net.encoder.variance_rad2, node.applied, offset, src_tick, *up,
                         net.dt_s, net.extrapolate_rate, sig.gyro_white_sigma_rad_s, net.offset_sigma_rad**2,
                         node.yaw, node.var, node.bias, node.ref_yaw, node.ref_var, r0, r1)
        return counts

    counts = sum(threads.map_chunks(run, R))
    for site, count in fixed_kernel.counts_dict(counts).items():
        node.kf.ctx.counter.record(site, count)


def _received_frames(net, n: int, above, offset, src_tick, bits) -> tuple:
    """The estimate frames node index ``n`` received from the nodes above (``offset`` 1) and two above (2): theirs,
    with ``mac.bit_errors`` flips the CRC let through (phase 1's records) applied in a copy where there are any."""
    frames = [a.frames for a in above]
    if not bits[0]:
        return tuple(frames)
    K = offset.shape[1]
    tries, bers = bits[10][:, n, :K], bits[11][:, n, :K]
    for s in (1, 2):
        r, k = np.nonzero((tries >= 0) & (offset == s))
        if r.size:
            link = n if s == 1 else net.n_nodes + n - 2  # the down link into n, or the skip link of node n - 2
            j = src_tick[r, k]
            got = frames[s - 1][r, j].copy()  # one frame per (r, j): a sender's frame is taken once per receiver
            bit_errors.apply_flips(bits[3][r, link], tries[r, k], bers[r, k], got)
            frames[s - 1] = frames[s - 1].copy()
            frames[s - 1][r, j] = got
    return tuple(frames)


def _run_node_firmware(net, n: int, out, k_end: int, n_static: int, codes: np.ndarray, bits, at_tick: np.ndarray,
                       enc_yaw: np.ndarray) -> None:
    """Phase 2 of the fixed-point firmware for node index ``n`` (:func:`.filters.run_node_firmware`); its filter
    starts at tick ``n_static``; ``enc_yaw`` the encoder's yaw read at the ticks ``at_tick`` (their indices: the
    static window and the start; :func:`_run_node` reads it once for the float records and the firmware)."""
    node, sig = net.nodes[n], net.nodes[n].sig
    t, R, fw = sig.t_s, net.R, node.fw
    K = t.size
    offset, src_tick = out.src_offset[:, n, :K], out.src_tick[:, n, :K]
    # the encoder's binary angle is read at the tick itself in the static window and at the start; at the top
    # node's requests, the reply read at the request's arrival; no other tick reads it
    yaw_enc, enc_rate, back_us = encoder_words(fw.config, R, t, at_tick, enc_yaw, encoder_reads(net, n, t, codes, out))
    above = above_nodes(net, n)
    # node.yaw_raw, node.var_raw and node.frames: the zero arrays :meth:`ChainNode.attach` made (not made again)
    rate_raw, bias_raw = np.zeros((R, K), np.int64), np.zeros((R, K), np.int64)
    rx = np.zeros((R, K), np.int64), np.zeros((R, K), np.int64)
    up_frames = _received_frames(net, n, above, offset, src_tick, bits)
    inp, res = np.zeros((R, len(fw.INPUTS)), np.int64), np.zeros((R, len(nf.OUTPUTS)), np.int64)
    six = six_state_fixed_node.build(fw)  # (is 6-state, its build, initial lane): the fixed 6-state node's tick
    words = np.zeros((R, len(fr.FIELDS[fr.ESTIMATE])), np.int64)
    k_first = n_static + 1  # the first tick that may take a reference or send a frame
    firmware = firmware_constants.runner(fw.params, fw.fparams, R * net.node_ticks, six[0])

    def run(r0: int, r1: int) -> np.ndarray:
        counts = np.zeros(len(fw.SITES), dtype=np.int64)  # per range of realizations, summed below
        if n > 0:
            frame_pass.receive_frames(offset, src_tick, k_first, k_end, up_frames, WHOLE_FRAMES, *rx, r0, r1)
        firmware(fw.states, fw.params, fw.fparams, counts, sig.gyro_counts, sig.accel_counts, sig.samples, t, codes,
                 k_end, True, node.applied, yaw_enc, enc_rate, back_us, offset, src_tick,
                 tuple(a.t_s for a in above), *rx, inp, res, node.yaw_raw, node.var_raw, rate_raw, bias_raw,
                 node.yaw, node.var, node.bias, node.ref_yaw, node.ref_var, r0, r1, *six, six_state.new_work())
        return counts

    fw.counts += sum(threads.map_chunks(run, R))
    if n < net.n_nodes - 1:  # the bottom node sends nothing
        status = min(threads.map_chunks(lambda r0, r1: frame_pass.send_frames(
            node.node_id, node.first_tick, net.forward_every_tick, node.running, k_first, k_end, 0, node.applied, t,
            node.yaw_raw, node.var_raw, rate_raw, bias_raw, node.frames, words, r0, r1), R))
        frame_pass.check_sent(status, node.node_id)


WHOLE_FRAMES = np.zeros(2, np.int64)
""":func:`.frame_pass.receive_frames`' ``up_first`` where the senders' frames are there from their first tick."""


ATTACH_AHEAD = 2
"""A streamed run's phase 2 computes the sensor readings of this many nodes at a time on the worker threads, a batch
ahead of the node it runs (:meth:`Network.prepare_signals`), and gives a node its readings and records as it reaches
it (:meth:`Network.attach_signals`): it holds two batches' readings and three nodes' records (the node and the two
above it that the nodes below read), not the chain's, and its sensors run beside its filters.  A run that keeps every
record gains nothing from that and attaches every node's before phase 1, as before streamed runs existed (a
1000-realization batch timed ~10-15 % slower attaching them as phase 2 went, at load ~2; not isolated).  Two, not
four: the drilling day peaked at 3.885 / 3.886 GB in 102.4 / 111.9 s with two, 3.999 GB in 115.1 s with four (one
`nodesim run` each, interleaved, 2026-12-03)."""


DROP_EVERY_NODES = 8
"""Phase 2 drops the whole-run tables' pages (when they are on disk, :mod:`nodesim.chain.scratch`) every this many
nodes: a node's rows of them are read once, as it is run (~2.6 MB for a node of the drilling day)."""


def simulate_compiled(net, progress: Callable[[float], None] | None = None, on_node: Callable | None = None):
    """Run the built network ``net`` on the compiled engine (module docstring) and return its ChainRun.

    ``on_node(run, surveys)``, when given, streams the run: it is called with each node's records (a
    :class:`~nodesim.chain.records.NodeRun`, top node first) and the surveys it sent as the ground station got
    them, as soon as phase 2 has finished the node; what it returns is kept as the node's summary
    (:class:`~nodesim.chain.records.NodeSummary`) and the node's arrays are dropped once the nodes below no longer
    read them (two nodes later: the fallback reads the next-but-one).  The ChainRun then has no ``nodes``."""
    K = np.array([n.t_s.size for n in net.nodes], dtype=np.int64)
    T = net.tick_table  # (N, K_max): node n's tick times T[n, :K[n]] (its t_s)
    # (streamed: the sensors' shared truth is being built on another core since the network was made; the first
    # readings phase 2 asks for wait for it, Network.build_shared_truth)
    plan = tp.tick_plan(net.nodes, int(K.max()), net.scratch)
    survey_plan = _survey_plan(net, plan)
    links = _Links(net, bool(survey_plan[0]))
    spill.drop(net.scratch)  # the whole-run tables' pages read so far leave memory (where they are on disk)
    if on_node is None:  # every record is kept anyway: every node's readings at once, on threads, as before
        net.attach_signals(range(net.n_nodes))
    windowed = time_windows.windowed(net.scenario, on_node)
    resolve = lambda beside: _resolve(net, links, T, K, plan, survey_plan, beside)  # noqa: E731
    if windowed and threads.thread_count() > 1:  # phase 1 on its own thread, phase 2 a window behind it
        phase1 = PhaseOne(resolve)
    else:
        phase1 = PhaseOne(done=resolve(None))
        if not windowed:  # (the windows add their surveys as they go, phase 1 first or beside them)
            ground_surveys(net, survey_plan[0], phase1.result()[4])
            _phase_one_done(net, links, phase1.result())
    if progress is not None:
        progress(0.5)  # phase 1 done (or under way beside phase 2); phase 2 reports node by node
    if windowed:  # phase 2 window by window of time (issue 20)
        try:
            surveys, summaries = time_windows.run_windows(net, phase1, plan, K, on_node, survey_plan[0], progress)
        except BaseException:
            phase1.cancel()  # (phase 1 beside it stops at its next chunk)
            raise
        _phase_one_done(net, links, phase1.result())
        return net.result(runs=(), surveys=surveys, summaries=summaries)
    out = phase1.result()[1]
    N = net.n_nodes
    surveys, summaries = list(net.ground), []
    streams = _NodeOutputs(net, on_node, surveys) if on_node is not None else None
    try:
        for n in range(N):
            if n % ATTACH_AHEAD == 0:  # this batch of nodes' readings (if not yet) and the next's, on the workers
                net.prepare_signals(range(n, min(N, n + ATTACH_AHEAD)))
                net.prepare_signals(range(n + ATTACH_AHEAD, min(N, n + 2 * ATTACH_AHEAD)))
            net.attach_signals([n])
            _run_node(net, n, out, links.bits, plan[n, :K[n]])
            if streams is not None:
                streams.submit(n, int(K[n]))
                # the nodes below n - 1 no longer read node n - 2's estimates: it (and those above) may finish
                summaries.extend(streams.finish_due(n - 2, OUTPUT_BACKLOG_LONGEST_NODES * int(K.max())))
            if n % DROP_EVERY_NODES == DROP_EVERY_NODES - 1:
                spill.drop(net.scratch)  # the rows of the nodes done (and those being run, read again as they go on)
            if progress is not None:
                progress(0.5 + 0.5 * (n + 1) / N)
        if streams is None:
            return net.result()
        summaries.extend(streams.finish_due(N - 1, -1))
    finally:
        if streams is not None:
            streams.close()
    return net.result(runs=(), surveys=surveys, summaries=tuple(summaries))


OUTPUT_BACKLOG_LONGEST_NODES = 2
"""A streamed run's phase 2 lets the output thread fall behind by nodes that together tick at most this many times
the longest node (:meth:`_NodeOutputs.finish_due`): two long nodes, as many short ones as add up to that.  A drilling
day starts phase 2 with the ~215 nodes inserted during the day, the first ones short, whose output steps (per node
costs in Python: rows, metrics, survey rows) outlast their filters: with a fixed lag of two nodes, the filters
waited for them (~1 s at one core); with long nodes it is the same two as before, so the same peak memory."""


class _NodeOutputs:
    """A streamed run's node steps (:meth:`Network.stream_node`: the node's records, its surveys' frames, ``on_node``)
    on one worker thread while phase 2 goes on with the next nodes, in node order (the table's order); with one
    thread (``NODESIM_THREADS = 1``) in the calling thread.  :meth:`finish_due` waits for nodes' steps, drops their
    arrays and returns their summaries, in node order: the same values either way."""

    def __init__(self, net, on_node: Callable, surveys: list):
        from concurrent.futures import ThreadPoolExecutor

        self.net, self.on_node, self.surveys = net, on_node, surveys
        self.pool = ThreadPoolExecutor(1, thread_name_prefix="nodesim-outputs") if threads.thread_count() > 1 else None
        self.pending: dict = {}  # node index -> (its step: a future, or its summary with one thread; its ticks)
        self.ticks = 0  # of the pending nodes

    def submit(self, n: int, ticks: int) -> None:
        if self.pool is None:
            step = self.net.stream_node(n, self.on_node, self.surveys)
        else:
            step = self.pool.submit(self.net.stream_node, n, self.on_node, self.surveys)
        self.pending[n] = (step, ticks)
        self.ticks += ticks

    def finish_due(self, last: int, backlog_ticks: int) -> list:
        """The summaries of the pending nodes up to index ``last``, oldest first, each once its step is done or
        while the pending nodes' ticks exceed ``backlog_ticks`` (then waited for); their arrays dropped."""
        out = []
        while self.pending:
            n = next(iter(self.pending))
            step, ticks = self.pending[n]
            if n > last or not (self.ticks > backlog_ticks or self.pool is None or step.done()):
                break
            del self.pending[n]
            self.ticks -= ticks
            out.append(step if self.pool is None else step.result())
            self.net.nodes[n].release()
        return out

    def close(self) -> None:
        if self.pool is not None:
            self.pool.shutdown(wait=True)


def _phase_one_done(net, links: _Links, result: tuple) -> None:
    """The network's event count, link statistics and radio times from phase 1's ``result`` (:func:`_resolve`)."""
    net.events, _, radio, stats, _ = result
    spill.drop(net.scratch)
    net.engine = "compiled"
    links.store(stats)
    for i, node in enumerate(net.nodes):
        node.radio.tx_s, node.radio.rx_s = radio[4][:, i].copy(), radio[5][:, i].copy()
    net.surface.tx_s, net.surface.rx_s = radio[4][:, -1].copy(), radio[5][:, -1].copy()
