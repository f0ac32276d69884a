"""A sensor node as a SimPy process: the execution cycle of thesis 4.2.2 (Fig. 4.10) at the firmware rate.

Every tick at the node's own clock (true time T[k] = offset + k dt / (1 + drift 1e-6)):
  1. sync: wake at the tick (holding nodes keep their saved state during a tube insertion);
  2. static window: average the gyro for the initial bias; at its end start the filter from an encoder yaw;
  3. read sensors, time update with the tick-averaged gyro rate (Euler, nominal dt);
  4. reference: the top node asks the encoder when the schedule says so (request and reply legs over its
     link; psi_ref(T[k]) = psi_enc(t_read) - rate_enc (t_read - T[k]), R = q^2 / 12); every other node takes
     the newest fresh packet from the node above (``select_reference``):
         psi_ref(T[k]) = psi_hat_{n-1}(t_read) + omega_hat_n (T[k] - t_read)       (thesis eq 3.29)
         R = P_{n-1} + ((T[k] - t_read) sigma_rate)^2 + sigma_off^2               (thesis digest 2.6 / 9.7)
     with omega_hat_n the node's own bias-corrected gyro rate (the mean over its last tick, i.e. the rate at
     T[k] - dt/2; ``chain.rate_compensation = "extrapolated"`` extrapolates it linearly from the last two
     ticks to the middle of the transfer, which removes the lag (dt - transfer)/2 x angular acceleration that
     otherwise adds up hop by hop during rotation ramps);
  5. measurement update in the realizations that got a reference;
  6. transmit (yaw, P_psipsi, rate, seq, t_read = T[k]) to the next node down, only in ticks where the node
     applied an update (so one reference wave runs down the chain per update; in timeouts all nodes coast).
     The SimPy event is sent whenever a reference reached the node this tick (the schedule for the top node,
     a packet in the inbox for the others), so the event skeleton is the same for every realization; the
     packet is ``valid`` only in the realizations that applied the update, and only they draw its loss.
     ``chain.forward = "every_tick"`` forwards every running tick instead (the post-time-update estimate
     when there was no reference; thesis digest 5.3 (iv) reads the two-node experiment that way);
  7. the bottom node sends its survey up at a survey stop.
Frames go through the hop's MAC at once (:mod:`nodesim.chain.mac`): a packet carries its arrival time per
realization and waits in the receiver's inbox until its first tick at or after it.  A failed node
(:mod:`nodesim.chain.faults`) stops ticking; a node whose neighbour below stops answering may fall back to the
next-but-one node.
Arrays are (R,): the event skeleton is shared by all realizations.
"""

from __future__ import annotations

import weakref

from dataclasses import replace
from typing import Any, Protocol

import numpy as np

from firmware_model import fixed_kernel as fk
from firmware_model import frames as fr
from firmware_model import node_firmware as nf
from nodesim.chain.estimator import forwarded_reference, new_filter, rate_estimate, timer_us, yaw_rad_of_raw
from nodesim.motion.timelines import NodeTimeline
from nodesim.chain.packets import EstimatePacket, SurveyPacket, estimate_frame, select_reference
from nodesim.chain.sensing import NodeSignals
from nodesim.chain.six_state import SixStateLanes
from nodesim.chain.six_state_firmware_lanes import firmware_lanes


class ChainWorld(Protocol):
    """What a node process uses of the network that runs it (:class:`nodesim.chain.network.Network`)."""

    env: Any  # simpy.Environment
    events: int
    scenario: Any  # nodesim.scenario.schema.Scenario
    motion: Any  # nodesim.motion.timelines.ChainMotion
    encoder: Any  # nodesim.chain.sensing.EncoderReader
    n_nodes: int
    nodes: list
    dt_s: float
    max_age_s: float
    processing_s: float
    offset_sigma_rad: float
    extrapolate_rate: bool
    forward_every_tick: bool
    down_links: list
    surface: Any  # nodesim.chain.mac.RadioState
    sent: list

    def next_seq(self) -> int: ...

    def send_survey(self, packet: SurveyPacket, ready_s) -> None: ...

    def skip_link(self, node_id: int) -> Any: ...


class ChainNode:
    """Node ``node_id`` (1 = top of the final chain) and its per-tick records."""

    def __init__(self, net: ChainWorld, node_id: int, timeline: NodeTimeline, t_s: np.ndarray,
                 scheduled: np.ndarray, signals: NodeSignals | None = None):
        # a weak reference: the network holds its nodes, and a node -> network cycle would keep every R-sized array
        # of a run alive until Python's cyclic collector ran (which counts objects, not bytes)
        self.net = weakref.proxy(net)
        self.node_id = node_id
        self.index = node_id - 1
        self.timeline = timeline
        self.t_s = t_s  # (K,) true tick times
        self.scheduled = scheduled  # (K,) encoder schedule evaluated at this node's ticks
        self.dead_at_s = np.inf
        self.radio = None  # mac.RadioState, set by the network
        self.fallback = None  # faults.Fallback, set by the network
        self.ready_s = 0.0  # when this tick's estimate is ready to send (scalar or (R,))
        self.kf = None
        self.fixed = net.scenario.filter.implementation == "fixed"  # the integer firmware pipeline
        self.first_tick = int(np.searchsorted(t_s, timeline.present_from_s))  # power-up: the frames' seq 0
        self.stops = [s for s in net.motion.stops if s.node_id == node_id]
        self.surveyed: set[tuple[int, int]] = set()  # (station, node id) of the surveys it sent
        self.opportunity = False  # a reference reached this tick (in any realization): the wave moves on
        self.sig = None
        if signals is not None:
            self.attach(signals)

    def attach(self, signals: NodeSignals) -> None:
        """The node's sensor readings and its per-tick records (R, K): the SimPy engine attaches every node's at
        once; the compiled engine can attach them node by node as its phase 2 reaches the node
        (:meth:`release` drops them again)."""
        R, K = signals.shape
        net = self.net
        self.sig = signals
        self.inbox: list[EstimatePacket] = []
        self.last_seq = np.full(R, -1, dtype=np.int64)
        self.fw = firmware_lanes(net.scenario, R) if self.fixed else None  # 2- or 6-state
        # the fixed firmware's binary angle and P_yy raws per tick (the survey and the frames use them)
        self.yaw_raw = np.zeros((R, K), dtype=np.int64) if self.fixed else None
        self.var_raw = np.zeros((R, K), dtype=np.int64) if self.fixed else None
        # the estimate frames it sent, (R, K, 27) uint8, all zero where it sent none (type byte 0)
        self.frames = np.zeros((R, K, fr.ESTIMATE_BYTES), dtype=np.uint8) if self.fixed else None
        self.bias_sum = np.zeros(R)
        self.bias_n = 0
        self.stale = np.zeros(R, dtype=np.int64)
        self.duplicate = np.zeros(R, dtype=np.int64)
        self.yaw = np.full((R, K), np.nan)
        self.var = np.full((R, K), np.nan)
        self.bias = np.full((R, K), np.nan)
        # which references it took and their ages (R, K): the SimPy engine's made when its process starts
        # (:meth:`process`), the compiled engine's are views of phase 1's records (no (R, K) array made and dropped)
        self.applied = self.age = None
        self.ref_yaw = np.full((R, K), np.nan)  # the reference each update used (replay logs record it)
        self.ref_var = np.full((R, K), np.nan)
        self.running = np.zeros(K, dtype=bool)  # filter running and not holding

    def release(self) -> None:
        """Drop the sensor readings and the per-tick records (a streamed run, once the node's results are out and
        the nodes below no longer read its estimates)."""
        for name in ("sig", "fw", "yaw_raw", "var_raw", "frames", "yaw", "var", "bias", "applied", "age", "ref_yaw",
                     "ref_var", "running", "kf", "survey_raw"):
            setattr(self, name, None)

    def deliver(self, packet: EstimatePacket) -> None:
        self.inbox.append(packet)

    def process(self):
        env, sig, tl = self.net.env, self.sig, self.timeline
        self.applied = np.zeros(sig.shape, dtype=bool)
        self.age = np.full(sig.shape, np.nan)
        for k, t in enumerate(self.t_s):
            if t >= self.dead_at_s:
                return
            yield env.timeout(t - env.now)
            self.net.events += 1
            self.opportunity = False
            self.ready_s = t
            if t < tl.present_from_s:
                continue
            if self.fixed:
                if not self._firmware_tick(k, t):
                    continue  # static window
            elif t < tl.filter_start_s:  # static window: initial bias
                self.bias_sum += sig.gyro_rad_s[:, k]
                self.bias_n += 1
                self.yaw[:, k] = self.net.encoder.read(t)[0]
                continue
            elif self.kf is None:
                bias0 = self.bias_sum / self.bias_n if self.bias_n else 0.0
                if self.net.scenario.filter.states == 6:  # the 6-state filter: 3-axis gyro, levelled start
                    self.kf = SixStateLanes(self.net.scenario, sig, k, self.net.encoder.read(t)[0])
                else:
                    self.kf = new_filter(self.net.scenario, self.yaw.shape[0], self.net.encoder.read(t)[0], bias0)
            elif tl.holding(t):
                self.inbox.clear()  # nothing arrives from a powered-down link; the state is saved
            else:
                if self.net.scenario.filter.states == 6:  # the time update, then the levelling at a static tick
                    self.kf.predict(self.kf.rates[:, k], sig.specific_force[:, k])
                else:
                    self.kf.predict(sig.gyro_rad_s[:, k])
                if tl.is_top(t):
                    if self.scheduled[k]:
                        self._encoder_update(k, t)
                else:
                    self._forwarded_update(k, t)
                self.running[k] = True
            self._record(k)
            if self.node_id < self.net.n_nodes:
                if self.net.forward_every_tick and self.running[k]:
                    self._transmit(k, t, np.ones(self.yaw.shape[0], dtype=bool))
                elif self.opportunity:
                    self._transmit(k, t, self.applied[:, k])
            for stop in self.stops:
                if stop.t_survey_s <= t < stop.end_s and (stop.station, stop.node_id) not in self.surveyed:
                    self.surveyed.add((stop.station, stop.node_id))
                    self.net.send_survey(SurveyPacket(stop.station, stop.md_m, self.node_id, k, t,
                                                      np.ones(self.yaw.shape[0], dtype=bool)), self.ready_s)

    def _firmware_tick(self, k: int, t: float) -> bool:
        """One tick of the fixed-point firmware (:class:`nodesim.chain.estimator.FirmwareLanes`): the same steps
        as the float path below, on the tick's gyro counts; False in the static window."""
        fw, sig, tl = self.fw, self.sig, self.timeline
        gz, n = sig.gyro_counts[:, k, 2], sig.samples[k]
        fw.read_sensors(sig, k)
        if t < tl.filter_start_s:
            fw.tick(nf.STATIC, gz, n)
            self.yaw[:, k] = self.net.encoder.read(t)[0]
            self.yaw_raw[:, k] = fw.config.encoder_yaw_raw(self.yaw[:, k])  # the static window reports the encoder
            return False
        if fw.states[0, nf.S_RUNNING] == 0:
            fw.tick(nf.START, gz, n, yaw0_raw=fw.config.encoder_yaw_raw(self.net.encoder.read(t)[0]))
        elif tl.holding(t):
            self.inbox.clear()  # nothing arrives from a powered-down link; the state is saved
            fw.tick(nf.HOLD, gz, n)
        else:
            if tl.is_top(t):
                if self.scheduled[k]:
                    self._encoder_exchange(k, t)
                else:
                    fw.tick(nf.RUN, gz, n)
            else:
                self._forwarded_firmware(k, t)
            self.running[k] = True
        return True

    def _encoder_exchange(self, k: int, t: float):
        """Request and reply over hop 1 (the surface link: in a drilling run it reaches whichever node is on top);
        (have (R,), t_read (R,), reference yaw (R,), rate (R,)) as read by the
        encoder, the reply's arrival set as this tick's ready time (the float path's :meth:`_encoder_update` and
        the fixed path share it)."""
        self.opportunity = True
        link, surface = self.net.down_links[0], self.net.surface  # hop 1: the surface to whichever node is on top
        R = self.yaw.shape[0]
        request = link.transfer(t, np.ones(R, dtype=bool), self.radio, surface)
        t_read = np.where(request.delivered, request.arrival_s, t)
        # the reply goes out when the request's exchange (its ACK) is over: the node is half duplex
        reply = link.transfer(np.where(request.delivered, request.end_s, t), request.delivered, surface, self.radio)
        have = reply.delivered
        yaw_enc, rate_enc = self.net.encoder.read_many(t_read)
        self.applied[:, k] = have
        self.age[:, k] = np.where(have, reply.arrival_s - t_read, np.nan)
        self.ready_s = np.where(have, reply.arrival_s, t)
        if self.fixed:
            fw, cfg = self.fw, self.fw.config
            out = fw.tick(nf.RUN, self.sig.gyro_counts[:, k, 2], self.sig.samples[k], ref=np.where(have, nf.ENCODER_REF, nf.NO_REF),
                          ref_yaw_raw=cfg.encoder_yaw_raw(yaw_enc), ref_aux_raw=cfg.encoder_rate_raw(rate_enc),
                          transfer_us=timer_us(t_read - t))
            self._record_firmware_reference(k, have, out)
            return
        ref = yaw_enc - rate_enc * (t_read - t)
        self.kf.update(ref, self.net.encoder.variance_rad2, mask=have)
        self._record_reference(k, have, ref, self.net.encoder.variance_rad2)

    def _record_firmware_reference(self, k: int, have, out) -> None:
        """The reference each applied update used, from the firmware's raws."""
        fp = self.fw.fparams
        ref = yaw_rad_of_raw(out[:, nf.OUT_REF], fp)
        var = np.ldexp(out[:, nf.OUT_R].astype(float), -int(fp[fk.W_YY + 1])) / fk.RAD2_TO_DEG2
        self._record_reference(k, have, ref, var)

    def _forwarded_firmware(self, k: int, t: float) -> None:
        arrived = self._arrived(t)
        self.opportunity = bool(arrived)
        sel = select_reference(arrived, self.last_seq, t, self.net.max_age_s)
        self.stale += sel.stale
        self.duplicate += sel.duplicate
        fw, sig = self.fw, self.sig
        if not sel.have.any():
            fw.tick(nf.RUN, sig.gyro_counts[:, k, 2], sig.samples[k])
            return
        transfer = np.where(sel.have, t - sel.t_read_s, 0.0)
        out = fw.tick(nf.RUN, sig.gyro_counts[:, k, 2], sig.samples[k], ref=np.where(sel.have, nf.FORWARDED_REF, nf.NO_REF),
                      ref_yaw_raw=sel.yaw_raw, ref_aux_raw=sel.var_raw, transfer_us=timer_us(transfer))
        self._record_firmware_reference(k, sel.have, out)
        self.last_seq = np.where(sel.have, sel.seq, self.last_seq)
        self.applied[:, k] = sel.have
        self.age[:, k] = np.where(sel.have, transfer, np.nan)

    def _encoder_update(self, k: int, t: float) -> None:
        """Request and reply over hop 1 (both on its down link's draws); the encoder answers the requests it
        received, read at their arrival t_read and brought back to the tick with its rate; the age of the
        reference is the reply's arrival minus t_read."""
        self._encoder_exchange(k, t)

    def _arrived(self, t: float) -> list[EstimatePacket]:
        """The inbox's packets as far as they have arrived by ``t``; the rest stays for a later tick."""
        now, later = [], []
        for p in self.inbox:
            arrived = p.arrival_s <= t
            if arrived[p.valid].all():
                now.append(p)
                continue
            if (p.valid & arrived).any():
                now.append(replace(p, valid=p.valid & arrived))
            later.append(replace(p, valid=p.valid & ~arrived))
        self.inbox = later
        return now

    def _forwarded_update(self, k: int, t: float) -> None:
        arrived = self._arrived(t)
        self.opportunity = bool(arrived)
        sel = select_reference(arrived, self.last_seq, t, self.net.max_age_s)
        self.stale += sel.stale
        self.duplicate += sel.duplicate
        if not sel.have.any():
            return
        transfer = np.where(sel.have, t - sel.t_read_s, 0.0)
        omega = rate_estimate(self.kf, self.sig.gyro_rad_s[:, k])
        if self.net.extrapolate_rate and k > 0:
            # the tick mean is the rate at T[k] - dt/2; extrapolate it to the transfer's middle, T[k] - transfer/2
            slope = (self.sig.gyro_rad_s[:, k] - self.sig.gyro_rad_s[:, k - 1]) / self.net.dt_s
            omega = omega + slope * 0.5 * (self.net.dt_s - transfer)
        var_in = np.where(sel.have, sel.yaw_var_rad2, 1.0)
        ref, var = forwarded_reference(sel.yaw_rad, var_in, omega, transfer, self.sig.gyro_white_sigma_rad_s,
                                       self.net.offset_sigma_rad)
        self.kf.update(ref, var, mask=sel.have)
        self._record_reference(k, sel.have, ref, var)
        self.last_seq = np.where(sel.have, sel.seq, self.last_seq)
        self.applied[:, k] = sel.have
        self.age[:, k] = np.where(sel.have, transfer, np.nan)

    def _record_reference(self, k: int, have: np.ndarray, ref, var) -> None:
        """The reference each applied update used (NaN in the realizations without an update)."""
        self.ref_yaw[:, k] = np.where(have, ref, np.nan)
        self.ref_var[:, k] = np.where(have, var, np.nan)

    def _record(self, k: int) -> None:
        if self.fixed:
            self.yaw_raw[:, k], self.var_raw[:, k] = self.fw.yaw_raw, self.fw.var_raw
            self.yaw[:, k] = self.fw.yaw_rad
            self.var[:, k] = self.fw.yaw_variance_rad2
            self.bias[:, k] = self.fw.bias_rad_s
            return
        self.yaw[:, k] = self.kf.yaw_rad
        self.var[:, k] = self.kf.yaw_variance_rad2
        self.bias[:, k] = self.kf.bias_rad_s

    def _transmit(self, k: int, t: float, valid: np.ndarray) -> None:
        """Send the estimate to the node below (or, where this node fell back, to the one after it)."""
        net = self.net
        seq = net.next_seq()
        if self.fixed:  # the estimate frame's bytes (binary angle, P_yy, bias-corrected rate, bias); seq = the
            rate_raw = self.fw.outputs[:, nf.OUT_RATE]  # ticks since power-up
            raws = dict(frame=estimate_frame(self.node_id, k - self.first_tick, timer_us(t), self.fw.yaw_raw, self.fw.var_raw,
                                             rate_raw, self.fw.states[:, fk.I_BIAS]))
            self.frames[valid, k] = raws["frame"][valid]
            rate = self.fw.rate_rad_s(rate_raw)
        else:
            raws, rate = {}, rate_estimate(self.kf, self.sig.gyro_rad_s[:, k])
        pkt = EstimatePacket(
            sender=self.node_id,
            seq=seq,
            t_read_s=float(t),
            yaw_rad=self.yaw[:, k].copy(),  # recorded this tick (the filter's state after the update)
            yaw_var_rad2=self.var[:, k].copy(),
            rate_rad_s=rate,
            valid=valid,
            **raws,
        )
        t_ready = self.ready_s + net.processing_s
        below = net.nodes[self.index + 1]
        link = net.down_links[self.index + 1]
        tr = link.transfer(t_ready, valid, self.radio, below.radio, below.dead_at_s)
        skip = self.fallback.record(valid & ~np.isnan(tr.end_s), tr.delivered, t)
        if tr.delivered.any():
            below.deliver(_received(pkt, link, tr))
        if skip.any():  # the neighbour did not answer: on to the node after it, once the exchange is over
            skip_to = net.nodes[self.index + 2]
            link = net.skip_link(self.node_id)
            tr = link.transfer(np.where(skip, tr.end_s, t_ready), skip, self.radio, skip_to.radio, skip_to.dead_at_s)
            if tr.delivered.any():
                skip_to.deliver(_received(pkt, link, tr))


def _received(pkt: EstimatePacket, link, tr) -> EstimatePacket:
    """The packet as the receiver got it over ``link`` (its bytes with the bit errors the CRC let through)."""
    frame = pkt.frame if pkt.frame is None else link.received(pkt.frame, tr)
    return replace(pkt, valid=tr.delivered, arrival_s=tr.arrival_s, frame=frame)
