"""The chain network: encoder, N nodes, radio links and the ground-station sink in one SimPy environment.

``simulate_chain(scenario)`` builds the motion, each node's clock and sensor signals, the hop channels
(:mod:`nodesim.chain.radio`), the links with their MAC (:mod:`nodesim.chain.mac`; down-link l feeds node l + 1:
from the encoder when that node is the top node, else from the node above; up-link N + l carries surveys from
node l + 1 upwards), the faults (:mod:`nodesim.chain.faults`) and runs every node as a process until the end of
the scenario.  One SimPy event per node tick: a frame is resolved by the MAC when it is sent and carries its
arrival time per realization; the receiver takes it at its first tick at or after that time.
Realizations share the event skeleton (tick times, schedule, fault times) and own every random draw (sensor
noise, shadowing, packet outcomes); the SimPy event count does not depend on R.

Clocks: node n (1-based) ticks at offset_n + k dt / (1 + drift_n 1e-6), offset_n = (n - 1) x
``chain.clock_stagger_s`` by default, so a reference wave crosses several hops in one cycle.
"""

from __future__ import annotations

from typing import Callable

import math
from dataclasses import dataclass, replace
from functools import partial

import numpy as np
import simpy

from firmware_model.node_survey import MA_RING
from nodesim import threads
from firmware_model import frames as fr
from nodesim.chain import faults, scratch
from nodesim.chain.bit_errors import FrameErrors
from nodesim.chain.compiled.surveys import averaged_surveys, fixed_survey_words
from nodesim.chain.estimator import alignment_ticks, alignment_window_s, require_engine_filter
from nodesim.chain.links import LazyStreams, LossDraws
from nodesim.chain.mac import Link, RadioState, radio_energy_j
from nodesim.motion.chain_motion import build_motion
from nodesim.motion.timelines import ChainMotion
from nodesim.chain.node_process import ChainNode
from nodesim.chain.estimator import timer_us
from nodesim.chain.packets import SurveyPacket, survey_frame, survey_sigmas_rad
from nodesim.chain.records import ChainRun, GroundSurvey, NodeRun
from nodesim.chain.radio import HopChannel, hop_channels
from nodesim.chain.sensing import EncoderReader, node_signals, shared_truth
from nodesim.errors import NodesimError
from nodesim.rng.streams import RunStreams
from nodesim.scenario.schema import Scenario
from nodesim.scenario.schedules import UpdateSchedule
from nodesim.units import DEG


def schedule_of(scenario: Scenario) -> UpdateSchedule:
    s = scenario.schedule
    return UpdateSchedule(s.mode, s.update_s, s.timeout_s, s.single_rate_hz, tuple(tuple(w) for w in s.windows))


def node_clock(scenario: Scenario, node_id: int) -> tuple[float, float]:
    """(offset_s, drift_ppm) of ``node_id``: the ``[[chain.node]]`` override or the defaults."""
    c = scenario.chain
    offset, drift = (node_id - 1) * c.clock_stagger_s, c.clock_drift_ppm
    for o in c.node:
        if o.id == node_id:
            offset = o.clock_offset_s if o.clock_offset_s is not None else offset
            drift = o.clock_drift_ppm if o.clock_drift_ppm is not None else drift
    return offset, drift


def tick_period_s(drift_ppm: float, dt_s: float) -> float:
    """A node clock's true tick period: dt / (1 + drift 1e-6)."""
    return dt_s / (1.0 + drift_ppm * 1e-6)


def tick_times(offset_s: float, drift_ppm: float, dt_s: float, duration_s: float) -> np.ndarray:
    """True times of a node's ticks in [0, duration]: offset + k dt / (1 + drift 1e-6)."""
    period = tick_period_s(drift_ppm, dt_s)
    if offset_s > duration_s:
        return np.zeros(0)
    t = np.arange(int(math.floor((duration_s - offset_s) / period + 1e-9)) + 1, dtype=float)  # k exact in float
    t *= period  # in place: the same products and sums as offset + k * period, without two more arrays
    t += offset_s
    return t


def tick_span(offset_s: float, drift_ppm: float, dt_s: float, duration_s: float,
              present_from_s: float) -> tuple[int, int, float]:
    """(j0, j1, period): the ticks of :func:`tick_times` inside [0, duration] from ``present_from_s`` on (a clock
    without steps: :meth:`Network._tick_times`) are its k-th values for j0 <= k < j1, float(k) period + offset
    (the same doubles), found without the array: k estimated, then moved while the doubles say so."""
    period = tick_period_s(drift_ppm, dt_s)
    if offset_s > duration_s:
        return 0, 0, period
    n = int(math.floor((duration_s - offset_s) / period + 1e-9)) + 1

    def first(x: float, above: bool) -> int:  # the first k in [0, n] whose tick is >= x (> x when above)
        if math.isnan(x) or x == math.inf:
            return n
        k = 0 if x == -math.inf else min(max(math.ceil((x - offset_s) / period), 0), n)
        while k > 0 and (float(k - 1) * period + offset_s > x if above else float(k - 1) * period + offset_s >= x):
            k -= 1
        while k < n and (float(k) * period + offset_s <= x if above else float(k) * period + offset_s < x):
            k += 1
        return k

    j1 = first(duration_s, True)
    return min(max(first(0.0, False), first(present_from_s, False)), j1), j1, period


class Network:
    """The SimPy world of one run (built by :func:`simulate_chain`)."""

    def __init__(self, scenario: Scenario, attach_signals: bool = True, spill: bool = False, whole_truth: bool = True):
        self.scenario = scenario
        self.env = simpy.Environment()
        self.events = 0
        self.engine = "event"
        c = scenario.chain
        self.n_nodes = c.nodes
        self.dt_s = 1.0 / c.firmware_rate_hz
        self.max_age_s = c.max_update_age_s
        self.processing_s = c.processing_s
        self.offset_sigma_rad = c.offset_sigma_deg * DEG
        self.extrapolate_rate = c.rate_compensation == "extrapolated"
        self.forward_every_tick = c.forward == "every_tick"
        self.motion = build_motion(scenario)
        self._truth = None
        if spill and whole_truth:  # a streamed compiled run node by node: the sensors' shared truth on another core
            # from here on (build_shared_truth); a run in windows of time builds a truth per window
            from concurrent.futures import ThreadPoolExecutor

            pool = ThreadPoolExecutor(1, thread_name_prefix="nodesim-truth")
            self._truth = pool.submit(shared_truth, scenario, self.motion, self.dt_s)
            pool.shutdown(wait=False)  # its thread ends with the task
        self.encoder = EncoderReader.from_scenario(scenario, self.motion)
        R = self.R = scenario.simulation.realizations
        streams = RunStreams(seed=scenario.seed, n_nodes=c.nodes, first_realization=scenario.simulation.first_realization)
        self.hops, skips = hop_channels(scenario, streams, R)
        mac = scenario.mac

        def link(channel, gens, h, errors=None):
            return Link(channel, LossDraws(gens), mac, faults.burst(scenario, h), faults.outages(scenario, h),
                        errors=errors)

        def errors(keys):  # mac.bit_errors on a link carrying estimate frames (hop 0 carries the encoder exchange)
            return FrameErrors(fr.ESTIMATE, keys()) if mac.bit_errors else None

        self.down_links = [link(self.hops[h], LazyStreams(partial(streams.link_batch, R, h), R), h,
                                errors(partial(streams.bit_error_keys, R, h)) if h else None)
                           for h in range(c.nodes)]
        # up links carry survey frames: their airtime and PER from the survey frame's length
        survey_bits = mac.frame_bits(fr.SURVEY_BYTES)
        self.up_links = [link(self.hops[h].for_frame(survey_bits, scenario.radio.bit_rate_bps),
                              LazyStreams(partial(streams.link_batch, R, c.nodes + h), R), h,
                              FrameErrors(fr.SURVEY, streams.bit_error_keys(R, c.nodes + h)) if mac.bit_errors else None)
                         for h in range(c.nodes)]
        self._skips, self._skip_links, self._make_link, self._streams = skips, {}, link, streams
        self._up_skip_links: dict[int, Link] = {}
        self._up_skip_channels: dict[int, HopChannel | None] = {}
        self._errors = errors
        self.surface = RadioState(R, mac.queue_length)
        self.seq = 0
        schedule = schedule_of(scenario)
        self.nodes: list[ChainNode] = []
        # every node's tick times as a row of one table (N, K_max), the node's t_s a view of its row (past its K
        # ticks the row is left unset and never read): the compiled engine's phase 1 reads the table as it is, and no
        # second copy of the run's tick times (8 bytes a node-tick) is ever held;
        # the sizes come first (tick_span, without the arrays where the clocks do not step).  ``spill`` (a streamed
        # run on the compiled engine): the whole-run tables (this one, the tick plan, phase 1's records) go to disk
        # where they are large (:mod:`nodesim.chain.scratch`)
        spans = [self._tick_span(i) for i in range(c.nodes)]
        sizes = [span[1] - span[0] if span else self._tick_times(i).size for i, span in enumerate(spans)]
        self.scratch = None
        if spill and scratch.spills(c.nodes, max(sizes), R, mac.bit_errors):
            self.scratch = scratch.ScratchArrays(scratch.scratch_directory())
        self.tick_table = scratch.zeros(self.scratch, (c.nodes, max(sizes)), float)
        self.node_ticks = sum(sizes)  # every node's ticks, summed (the run's size)
        # node n's tick k is (k + first[n]) period[n] + offset[n] (tick_times' two roundings), where every clock
        # is such: phase 1 then computes the tick times instead of reading the table (Network.tick_clock)
        affine = not scenario.faults.clock_step
        first, period, offset = np.zeros(c.nodes, np.int64), np.zeros(c.nodes), np.zeros(c.nodes)
        base, row = np.arange(max(x[1] if x else 0 for x in spans), dtype=float), np.empty(max(sizes))
        for i, size in enumerate(sizes):
            t = self.tick_table[i, :size]
            if spans[i]:  # tick_times' doubles from k = j0 on, in one buffer (no array of every node's ticks)
                j0, j1, p, off = spans[i]
                ticks = np.multiply(base[j0:j1], p, out=row[:size])
                ticks += off
            else:
                ticks = self._tick_times(i)
            scratch.write(self.scratch, t, ticks)  # (to the file where the table is on disk: no page faults)
            affine = affine and self._affine_clock(i, ticks, first, period, offset)
            if i % scratch.DROP_EVERY_ROWS == scratch.DROP_EVERY_ROWS - 1:
                scratch.drop(self.scratch)  # the rows written so far leave memory
            node = ChainNode(self, i + 1, self.motion.timelines[i], t, schedule.mask(t, self.dt_s))
            node.dead_at_s = faults.death_time_s(scenario, i + 1)
            node.radio = RadioState(R, mac.queue_length)
            node.fallback = faults.Fallback.new(scenario, skips[i + 1] if i + 1 < c.nodes else None, R)
            self.nodes.append(node)
        scratch.write_out(self.scratch)  # the table's pages to the disk now, while a core is idle (write_out)
        self._clock = (affine, first, period, offset)
        self.sent: list[SurveyPacket] = []
        self.ground: list[GroundSurvey] = []
        self._survey_hops: list[list] = []
        self._pending: list = []  # (node indices, their readings when called): prepare_signals'
        self._ready: dict = {}  # node index -> its readings, computed, not yet attached
        self._ground_by_node: dict[int, list[int]] | None = None  # surveys_of's grouping of ground
        if attach_signals:
            self.attach_signals(range(c.nodes))

    def attach_signals(self, indices) -> None:
        """Sensor readings (:func:`nodesim.chain.sensing.node_signals`) and per-tick records of the nodes ``indices``
        (0-based), on threads (:func:`nodesim.threads.map_nodes`): every node at once for the SimPy engine, node by
        node as phase 2 reaches it for the compiled engine, which names the nodes it will need next beforehand
        (:meth:`prepare_signals`).  Each node's readings are its own draws: the same bits whenever computed."""
        for batch in [b for b in self._pending if any(i in b[0] for i in indices)]:
            self._pending.remove(batch)
            self._ready.update(zip(batch[0], batch[1]()))
        todo = [i for i in indices if self.nodes[i].sig is None and i not in self._ready]
        if todo:
            self._ready.update(zip(todo, self._signals_later(todo)()))
        for i in indices:
            if self.nodes[i].sig is None:
                self.nodes[i].attach(self._ready.pop(i))

    def prepare_signals(self, indices) -> None:
        """Start the readings of the nodes ``indices`` on the worker threads (:func:`nodesim.threads.map_nodes_later`)
        for :meth:`attach_signals` to take later: phase 2's sensors run beside its filters, and only the node being
        run holds its per-tick records."""
        queued = {i for b in self._pending for i in b[0]}
        todo = [i for i in indices if self.nodes[i].sig is None and i not in self._ready and i not in queued]
        if todo:
            self._pending.append((todo, self._signals_later(todo)))

    def build_shared_truth(self) -> None:
        """Compute the per-sample truth the nodes' readings share (:func:`nodesim.chain.sensing.shared_truth`, kept
        for the run) now, or wait for it: a streamed compiled run has it built on another thread from its start
        (~1.5 s of the drilling day, beside the rest of the set-up, which runs on one core, and phase 1)."""
        if self._truth is not None:
            self._truth.result()  # (raises what the thread raised)
            return
        shared_truth(self.scenario, self.motion, self.dt_s)

    def _signals_later(self, todo: list[int]):
        scenario, motion, streams, dt = self.scenario, self.motion, self._streams, self.dt_s  # not self in the task:
        self.build_shared_truth()  # built once before the threads (if not yet)
        nodes = self.nodes  # (the nodes refer to the network weakly)
        return threads.map_nodes_later(
            lambda j: node_signals(scenario, motion, streams, todo[j], nodes[todo[j]].t_s, dt), len(todo), self.R)

    def tick_clock(self) -> tuple:
        """(affine, first (N,), period (N,), offset (N,)): with ``affine``, node index n's tick k is at exactly
        float(k + first[n]) * period[n] + offset[n] (:func:`tick_times`' product and sum, the same doubles), so
        that phase 1 of the compiled engine computes it instead of reading the tick table (a read maps the pages
        around it: the whole table on a run of a few hours, :mod:`nodesim.chain.scratch`); not affine where a clock
        steps (``faults.clock_step``)."""
        return self._clock

    def _affine_clock(self, i: int, ticks: np.ndarray, first: np.ndarray, period: np.ndarray,
                      offset: np.ndarray) -> bool:
        """Node index ``i``'s (first, period, offset) of :meth:`tick_clock` from its tick times, into row i of those
        arrays; whether the formula gives them (checked at both ends)."""
        off, drift = node_clock(self.scenario, i + 1)
        p = tick_period_s(drift, self.dt_s)
        j = int(round((ticks[0] - off) / p))
        first[i], period[i], offset[i] = j, p, off
        return float(j) * p + off == ticks[0] and float(j + ticks.size - 1) * p + off == ticks[-1]

    def _tick_span(self, i: int) -> tuple[int, int, float, float] | None:
        """(j0, j1, period, offset) of node index ``i``'s ticks (:func:`tick_span`) where its clock does not step and
        it has ticks; else None (:meth:`_tick_times` makes them, or says why there are none)."""
        scenario = self.scenario
        if any(x.node == i + 1 for x in scenario.faults.clock_step):
            return None
        offset, drift = node_clock(scenario, i + 1)
        j0, j1, period = tick_span(offset, drift, self.dt_s, scenario.simulation.duration_s,
                                   self.motion.timelines[i].present_from_s)
        return (j0, j1, period, offset) if j1 > j0 else None

    def _tick_times(self, i: int) -> np.ndarray:
        """Node index ``i``'s true tick times: its clock, its clock steps, from its insertion on (a node not yet in
        its tube does not tick)."""
        scenario = self.scenario
        offset, drift = node_clock(scenario, i + 1)
        t = tick_times(offset, drift, self.dt_s, scenario.simulation.duration_s)
        t = faults.stepped_ticks(scenario, i + 1, t, scenario.simulation.duration_s)
        t = t[np.searchsorted(t, self.motion.timelines[i].present_from_s, side="left"):]  # increasing: a view
        if t.size == 0:
            steps = [(x.at_s, x.step_s) for x in scenario.faults.clock_step if x.node == i + 1]
            raise NodesimError(
                f"node {i + 1} has no firmware tick inside the run [0, {scenario.simulation.duration_s} s] "
                f"(clock offset {offset} s, faults.clock_step (at_s, step_s) {steps}): lengthen "
                "simulation.duration_s or shorten chain.clock_stagger_s / chain.clock_offset_s / the step")
        return t

    def skip_link(self, node_id: int) -> Link:
        """The fallback link from ``node_id`` to the node after its neighbour (built on first use; its draws
        come from its own streams, so when it is built does not matter)."""
        if node_id not in self._skip_links:
            gens = LazyStreams(partial(self._streams.skip_link_batch, self.R, node_id), self.R)
            self._skip_links[node_id] = self._make_link(self._skips[node_id], gens, -1, self._errors(
                partial(self._streams.skip_bit_error_keys, self.R, node_id)))
        return self._skip_links[node_id]

    def next_seq(self) -> int:
        """Sequence numbers are network-wide and increase with send time (a fallback receiver compares
        packets of two senders)."""
        self.seq += 1
        return self.seq

    def send_survey(self, packet: SurveyPacket, ready_s) -> None:
        """Hop by hop from the surveying node to the top node and on to the ground station, resolved by the
        MAC at once (arrival per realization).  A hop that stays unanswered after its tries (a dead node above)
        goes on over the skip hop to the node two above, as the fallback carries estimates down
        (:meth:`up_skip_open`); otherwise the survey is lost there."""
        t = self.env.now
        top = self.motion.top_node_id(t)
        at = np.broadcast_to(np.asarray(ready_s, dtype=float), (self.R,)).copy()  # after the node's own exchange
        valid = packet.valid.copy()
        holder = np.full(self.R, packet.node_id)  # the node that has the survey, per realization (top - 1: ground)
        hops = []  # (link, transfer) per hop: the frame's bytes are made after the run (_survey_frames)
        for node_id in range(packet.node_id, top - 1, -1):
            sending = valid & (holder == node_id)
            if not sending.any():
                continue
            node, above = self.nodes[node_id - 1], self.nodes[node_id - 2] if node_id > top else None
            link = self.up_links[node_id - 1 if above else 0]  # the top node's hop to the surface is hop 1
            tr = link.transfer(np.where(sending, at, np.nan), sending, node.radio,
                               above.radio if above else self.surface, above.dead_at_s if above else np.inf)
            hops.append((link, tr))
            got = tr.delivered
            at, holder = np.where(got, tr.arrival_s, at), np.where(got, node_id - 1, holder)
            skip = sending & ~got & ~np.isnan(tr.end_s) & self.up_skip_open(node_id, top, t)
            if skip.any():
                to = self.nodes[node_id - 3]
                link = self.up_skip_link(node_id)
                tr = link.transfer(np.where(skip, tr.end_s, np.nan), skip, node.radio, to.radio, to.dead_at_s)
                hops.append((link, tr))
                at, holder = np.where(tr.delivered, tr.arrival_s, at), np.where(tr.delivered, node_id - 2, holder)
                got = got | tr.delivered
            valid &= ~sending | got
        self.received_survey(packet, np.where(valid & (holder == top - 1), at, np.nan), hops)

    def up_skip_open(self, node_id: int, top: int, t_s: float) -> np.ndarray:
        """(R,) where a survey unanswered by ``node_id``'s neighbour above may go on to node ``node_id - 2``: a
        node there below the top one, ``faults.fallback`` on with the ARQ MAC, and the skip hop's margin (shadowing
        included) at least ``faults.fallback_min_margin_db`` (the estimates' rule, :class:`faults.Fallback`,
        without its streak: a survey is sent once)."""
        skip = self.up_skip_channel(node_id) if node_id - 2 >= top else None
        if skip is None:
            return np.zeros(self.R, dtype=bool)
        return faults.skip_margin_ok(skip, t_s, self.scenario.faults.fallback_min_margin_db)

    def up_skip_channel(self, node_id: int) -> HopChannel | None:
        """The skip hop between ``node_id`` and ``node_id - 2`` for survey frames (None where there is none or the
        fallback is off)."""
        if node_id not in self._up_skip_channels:  # built once: every survey hop that fails asks
            f, mac = self.scenario.faults, self.scenario.mac
            skip = self._skips[node_id - 2] if 1 <= node_id - 2 else None
            self._up_skip_channels[node_id] = None if skip is None or not (f.fallback and mac.enabled) else replace(
                skip.for_frame(mac.frame_bits(fr.SURVEY_BYTES), self.scenario.radio.bit_rate_bps),
                name=f"skip{node_id}-{node_id - 2}")
        return self._up_skip_channels[node_id]

    def up_skip_link(self, node_id: int) -> Link:
        """The survey skip link from ``node_id`` up to node ``node_id - 2`` (over the skip hop between them, for
        the survey frame's length; built on first use, its draws from its own streams)."""
        if node_id not in self._up_skip_links:
            mac, streams, channel = self.scenario.mac, self._streams, self.up_skip_channel(node_id)
            errors = FrameErrors(fr.SURVEY, streams.skip_bit_error_keys(self.R, node_id, up=True)) if mac.bit_errors else None
            self._up_skip_links[node_id] = self._make_link(
                channel, LazyStreams(partial(streams.skip_link_batch, self.R, node_id, up=True), self.R), -1, errors)
        return self._up_skip_links[node_id]

    def received_survey(self, packet: SurveyPacket, arrival_s: np.ndarray, hops: list) -> None:
        """Record a survey sent and what reached the ground station: ``arrival_s`` (R,), NaN where it was lost;
        ``hops``: (link, transfer) per hop, whose bit errors its frame's bytes get (:meth:`_survey_frames`)."""
        self.sent.append(packet)
        self.ground.append(GroundSurvey(packet.lost_where(np.isnan(arrival_s)), arrival_s))
        self._survey_hops.append(hops)
        self._ground_by_node = None  # surveys_of groups them again

    def run(self, progress: Callable[[float], None] | None = None, steps: int = 200,
            on_node: Callable | None = None) -> ChainRun:
        """Run the world to the end.  With ``progress``, the run stops at ``steps`` evenly spaced simulated
        times to report the fraction done; stopping and resuming SimPy does not reorder any event, so the
        results are identical with or without a callback.  ``on_node``: a streamed run
        (:func:`nodesim.chain.compiled.engine.simulate_compiled`), node by node after the run."""
        for node in self.nodes:
            self.env.process(node.process())
        if progress is not None:
            duration = self.scenario.simulation.duration_s
            for k in range(1, steps):
                self.env.run(until=duration * k / steps)
                progress(k / steps)
        self.env.run()
        if progress is not None:
            progress(1.0)
        if on_node is None:
            return self.result()
        surveys, summaries = list(self.ground), []  # every node's records exist until here: streamed after the run
        for n in range(self.n_nodes):
            summaries.append(self.stream_node(n, on_node, surveys))
            self.nodes[n].release()
        return self.result(runs=(), surveys=surveys, summaries=tuple(summaries))

    def survey_frame(self, i: int, run: NodeRun, k_base: int = 0, survey_raw: tuple | None = None) -> GroundSurvey:
        """Survey ``i`` (of :attr:`ground`, in send order) as the ground station got it: the fixed firmware's as a
        25-byte survey frame (:func:`nodesim.chain.packets.survey_frame`) from the surveying node's I and A words at
        the survey tick, relayed hop by hop (each hop's undetected bit errors, :meth:`nodesim.chain.mac.Link.received`,
        stay in the bytes); the float filter's as sent.  Made from the surveying node's records (``run``, its
        :class:`NodeRun`): the moving-averaged survey words are resolved from them.  A window of the node's ticks
        (:mod:`nodesim.chain.compiled.time_windows`): ``run`` from its tick ``k_base`` on, ``survey_raw`` its (first
        tick of the words, I words, A words)."""
        g, hops = self.ground[i], self._survey_hops[i]
        p = g.packet
        node = self.nodes[p.node_id - 1]
        survey_raw = getattr(node, "survey_raw", None) if survey_raw is None else survey_raw
        if survey_raw is None:
            return g
        first, inc_raw, azi_raw = survey_raw
        tick = p.tick - k_base
        k = tick - first
        sig_i, sig_a = survey_sigmas_rad(run.accel_sigma_m_s2, self.scenario.filter.moving_average_points,
                                         run.true_inclination_rad[tick], run.yaw_var_rad2[:, tick])
        frame = survey_frame(p.station, p.node_id, int(timer_us(p.t_s)), inc_raw[:, k], azi_raw[:, k], sig_i, sig_a)
        for link, tr in hops:
            frame = link.received(frame, tr)
        return GroundSurvey(p, g.arrival_s, frame)

    def surveys_of(self, index: int) -> list[int]:
        """The indices in :attr:`ground` of the surveys node index ``index`` (0-based) sent (grouped on the first
        call after a survey was added)."""
        if self._ground_by_node is None:
            self._ground_by_node = {}
            for i, g in enumerate(self.ground):
                self._ground_by_node.setdefault(g.packet.node_id - 1, []).append(i)
        return self._ground_by_node.get(index, [])

    def stream_node(self, index: int, on_node: Callable, surveys: list[GroundSurvey]):
        """A streamed run's step for node index ``index`` once its records are complete: its :class:`NodeRun`, its
        surveys as the ground station got them (set in ``surveys``, the run's list in :attr:`ground` order), and
        ``on_node(run, its surveys)``, whose value it returns (the node's summary)."""
        run = self.node_run(index)
        mine = self.surveys_of(index)
        for i in mine:
            surveys[i] = self.survey_frame(i, run)
        return on_node(run, [surveys[i] for i in mine])

    def node_run(self, index: int) -> NodeRun:
        """Node index ``index``'s records as a :class:`NodeRun` (after its last tick)."""
        return _node_run(self.nodes[index], self.scenario.filter.moving_average_points)

    def result(self, runs: tuple[NodeRun, ...] | None = None, surveys: list[GroundSurvey] | None = None,
               summaries: tuple = ()) -> ChainRun:
        """The run's records (after :meth:`run`, or after the compiled engine filled them in).  A streamed run
        passes its surveys (made node by node, :meth:`survey_frame`) and its nodes' summaries, and no records
        (``runs = ()``)."""
        points = self.scenario.filter.moving_average_points
        if runs is None:
            nodes = self.nodes  # (not self in the task: the nodes refer to the network weakly)
            runs = tuple(threads.map_nodes(lambda i: _node_run(nodes[i], points), self.n_nodes, self.R))
            surveys = [self.survey_frame(i, runs[g.packet.node_id - 1]) for i, g in enumerate(self.ground)]
        skips = tuple(s for links in (self._skip_links, self._up_skip_links) for _, s in sorted(links.items())
                      if s.stats.frames.any())
        lost = sum(link.stats.lost for link in self.down_links + self.up_links + list(skips))
        return ChainRun(
            nodes=runs,
            motion=self.motion,
            surveys=tuple(surveys),
            rotation_end_s=self.motion.rotation_end_s,
            lost_packets=lost,
            simpy_events=self.events,
            moving_average_points=points,
            hops=tuple(self.hops),
            down_links=tuple(self.down_links),
            up_links=tuple(self.up_links),
            skip_links=skips,
            radio_energy_j=np.stack([radio_energy_j(n.radio, self.scenario.mac) for n in self.nodes]),
            engine=self.engine,
            summaries=tuple(summaries),
        )


def _node_run(node: ChainNode, points: int) -> NodeRun:
    """Resolve the survey (thesis eqs 1.1-1.3) and apply the firmware moving average from the node's first tick,
    with the mid-window yaw and the alignment offset over ``firmware.alignment``'s window
    (:func:`nodesim.chain.estimator.alignment_window_s`): the fixed firmware (``node.yaw_raw`` set) as the MCU
    does it, :func:`nodesim.chain.compiled.surveys.fixed_survey_words` on the accelerometer count sums and the yaw word
    (``[firmware] survey_math``, ``cordic_iterations``); the float filter by
    :func:`nodesim.chain.compiled.surveys.averaged_surveys`."""
    R, K = node.yaw.shape
    inc, azi = np.empty((R, K)), np.empty((R, K))  # NaN before the node's first tick, the survey's from it
    first = int(np.searchsorted(node.sig.t_s, node.timeline.present_from_s))
    inc[:, :first] = azi[:, :first] = np.nan
    lo, hi = alignment_ticks(alignment_window_s(node.net.scenario), node.sig.t_s[first:])
    if first < K and getattr(node, "yaw_raw", None) is not None:
        # the fixed firmware: survey from the accelerometer count sums and the yaw word, CORDIC or float32
        states = np.zeros((R, MA_RING + 4 * points), np.int64)  # each realization's from ma_reset (first tick)
        inc_raw, azi_raw = fixed_survey_words(node.fw.config, node.sig.accel_counts, node.yaw_raw, node.sig.samples,
                                              first, 0, (lo, hi), points, states, inc, azi)
        node.survey_raw = (first, inc_raw, azi_raw)  # the survey frames' words (Network._survey_frames)
    elif first < K:
        def run(r0: int, r1: int) -> None:
            averaged_surveys(node.sig.specific_force[r0:r1, first:], node.yaw[r0:r1, first:], lo, hi, points,
                             inc[r0:r1, first:], azi[r0:r1, first:])

        threads.map_chunks(run, R)
    return NodeRun(
        node_id=node.node_id,
        t_s=node.sig.t_s,
        running=node.running,
        update_mask=node.applied,
        update_age_s=node.age,
        true_yaw_rad=node.sig.true_yaw_rad,
        true_inclination_rad=node.sig.true_inclination_rad,
        true_azimuth_rad=node.sig.true_azimuth_rad,
        yaw_est_rad=node.yaw,
        yaw_var_rad2=node.var,
        true_bias_rad_s=node.sig.true_bias_rad_s,
        bias_est_rad_s=node.bias,
        inclination_rad=inc,
        azimuth_rad=azi,
        stale_packets=node.stale,
        duplicate_packets=node.duplicate,
        filter_start_s=node.timeline.filter_start_s,
        accel_sigma_m_s2=node.sig.accel_sigma_m_s2,
        firmware_overflows=_overflows(node),
        gyro_counts=node.sig.gyro_counts,
        accel_counts=node.sig.accel_counts,
        samples=node.sig.samples,
        ref_yaw_rad=node.ref_yaw,
        ref_var_rad2=node.ref_var,
        present_from_s=node.timeline.present_from_s,
        adc_clipped_samples=node.sig.gyro_clipped_samples + node.sig.accel_clipped_samples,
        estimate_frames=node.frames,
        reference_error_rad=node.sig.reference_error_rad,
        singular_ticks=getattr(node.kf if node.kf is not None else node.fw, "singular_ticks", None),
        readings=node.sig,
    )


def _overflows(node) -> dict:
    """The node's fixed-point saturations per site: its firmware's (fixed) or its filter's (empty for float)."""
    if node.fw is not None:
        return node.fw.overflow_counts
    return dict(node.kf.overflow_counts) if node.kf is not None else {}


def simulate_chain(scenario: Scenario, progress: Callable[[float], None] | None = None,
                   on_node: Callable | None = None) -> ChainRun:
    """Run ``scenario``: R realizations of the encoder-aided chain (a single node is a chain of one), on the
    engine ``simulation.engine`` names (``auto``: the compiled engine where it covers the scenario, else the
    SimPy event engine; both give the same numbers).  ``progress(fraction)`` is called as the run advances.
    ``on_node(run, surveys)`` streams the run (:mod:`nodesim.chain.streaming`): called with each node's records as
    they are complete, what it returns becomes the node's summary and the ChainRun keeps no per-tick records."""
    from nodesim.chain.allocator import keep_freed_memory, limit_arenas
    from nodesim.chain.compiled.engine import choose_engine, simulate_compiled
    from nodesim.chain.compiled.time_windows import windowed

    require_engine_filter(scenario)  # filter.states = 6: its tuning checked before any work (issue 24)
    if scenario.simulation.realizations > 1:
        keep_freed_memory()  # a batch reuses the pages the last one freed (nodesim.chain.allocator)
    if on_node is not None:
        limit_arenas()  # the nodes' arrays are freed where they are reused: memory flatter in the duration
    if choose_engine(scenario) == "compiled":
        held = [Network(scenario, attach_signals=False, spill=on_node is not None,
                        whole_truth=not windowed(scenario, on_node))]
        try:
            return simulate_compiled(held[0], progress, on_node)
        finally:
            if on_node is not None:
                _release_later(held)
    return Network(scenario).run(progress, on_node=on_node)


def _release_later(held: list) -> None:
    """Drop the network in ``held`` (its only reference) on a thread of its own: a streamed run's whole-run tables
    are files mapped into memory (:mod:`nodesim.chain.scratch`), and freeing them (the drilling day's 2.5 GB: their
    pages and blocks) took ~0.8 s after the run, before its outputs could be written; the run's end now overlaps it.
    The interpreter waits for the thread before it exits."""
    import threading

    threading.Thread(target=held.clear, name="nodesim-release").start()
