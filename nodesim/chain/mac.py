"""MAC: stop-and-wait ARQ over a hop, batched over realizations, with no SimPy event per frame.

A frame handed to the MAC at ``t_ready`` is resolved at once for every realization (the event skeleton stays
that of the node ticks; what differs between realizations is arrays):

* queue: a radio holds at most ``mac.queue_length`` frames (the one on air included); a frame finding it full
  is dropped (tail drop);
* start = max(t_ready, the radio's free time: end of its previous frame and duty-cycle off time);
* attempt a at time t: the data frame (airtime T_d = mac.data_frame_bits / bit_rate, the estimate frame's
  bytes plus the preamble) arrives unless
  u_data < PER_data(t), the hop is in an outage, the receiver is dead, a Gilbert-Elliott burst loses it, or
  the receiver's radio is busy with its own frame (half duplex: its last ARQ exchange overlaps [t, t + T_d));
  the ACK (T_a = ack_bits / bit_rate, after the turnaround) arrives unless u_ack < PER_ack(t) (or an outage);
  the attempt takes T_d + turnaround + T_a when acknowledged, else T_d + ack_timeout; the next attempt starts
  no sooner than t + T_d / duty_cycle (the 868 MHz duty-cycle off time);
* up to 1 + ``max_retries`` attempts; the receiver has the frame from the end of the first data frame that got
  through (a lost ACK makes the sender repeat a frame the receiver already has: a duplicate);
* energy: E = V (I_tx t_tx + I_rx t_rx): the sender transmits T_d per attempt and listens for the ACK
  (T_a + turnaround, or the timeout); the receiver listens T_d per attempt that reaches it and sends T_a per
  ACK.  Idle listening is not counted.

``mac.bit_errors``: a link whose frames have bytes (``Link.errors``) replaces the data draw by the preamble's
loss and the frame's bit errors decoded by the receiver (:mod:`nodesim.chain.bit_errors`); the same PER.

``mac.enabled = false``: one attempt, no ACK, no queue, no duty cycle, no half duplex, duration = the hop's
airtime (the simple links' fixed delay).  Uniform draws: see :mod:`nodesim.rng.streams` (data, ACK, burst state,
burst loss per attempt of a realization that attempts).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from nodesim.chain.bit_errors import FrameErrors, apply_flips
from nodesim.chain.links import LossDraws
from nodesim.chain.radio import HopChannel
from nodesim.scenario.radio_sections import BurstLoss, MacSection


@dataclass
class RadioState:
    """One node's (or the surface station's) radio, per realization."""

    R: int
    queue: int
    busy_start: np.ndarray = None
    busy_end: np.ndarray = None
    free_at: np.ndarray = None
    queue_end: np.ndarray = None  # (R, queue) end times of the frames it holds
    tx_s: np.ndarray = None
    rx_s: np.ndarray = None

    def __post_init__(self) -> None:
        R = self.R
        self.busy_start = np.full(R, -np.inf)
        self.busy_end = np.full(R, -np.inf)
        self.free_at = np.full(R, -np.inf)
        self.queue_end = np.full((R, self.queue), -np.inf)
        self.tx_s = np.zeros(R)
        self.rx_s = np.zeros(R)


@dataclass
class LinkStats:
    """What one directed link carried, per realization."""

    R: int
    frames: np.ndarray = None
    delivered: np.ndarray = None
    attempts: np.ndarray = None
    dropped: np.ndarray = None
    latency_sum_s: np.ndarray = None

    def __post_init__(self) -> None:
        self.frames, self.delivered, self.attempts, self.dropped = (np.zeros(self.R, np.int64) for _ in range(4))
        self.crc_rejected, self.undetected = np.zeros(self.R, np.int64), np.zeros(self.R, np.int64)  # bit errors
        self.latency_sum_s = np.zeros(self.R)

    @property
    def lost(self) -> np.ndarray:
        return self.frames - self.delivered


@dataclass
class Transfer:
    delivered: np.ndarray  # bool (R,)
    arrival_s: np.ndarray  # (R,), NaN where not delivered
    end_s: np.ndarray  # (R,) when the sender's exchange ended (NaN where it did not send)
    corrupt_try: np.ndarray | None = None  # (R,) the delivered try's number where its flips passed the CRC, else -1
    corrupt_ber: np.ndarray | None = None  # (R,) its BER (bit_errors.apply_flips regenerates the flips)


@dataclass
class Link:
    """A directed link over a hop channel with its own draws (stream of :meth:`RunStreams.link`)."""

    channel: HopChannel
    draws: LossDraws
    mac: MacSection
    burst: BurstLoss | None = None
    outages: tuple[tuple[float, float], ...] = ()
    stats: LinkStats = None
    bad: np.ndarray = None  # Gilbert-Elliott state per realization
    errors: FrameErrors | None = None  # mac.bit_errors on a link whose frames have bytes
    _lanes: np.ndarray = field(default=None, repr=False)

    def __post_init__(self) -> None:
        R = len(self.draws.generators)
        self.stats = LinkStats(R)
        self.bad = np.zeros(R, dtype=bool)

    def _in_outage(self, t: np.ndarray) -> np.ndarray:
        out = np.zeros(t.shape, dtype=bool)
        for a, b in self.outages:
            out |= (t >= a) & (t < b)
        return out

    def _burst_lost(self, trying: np.ndarray, u_state: np.ndarray, u_loss: np.ndarray) -> np.ndarray:
        b = self.burst
        flip = np.where(self.bad, u_state < b.p_bad_to_good, u_state < b.p_good_to_bad)
        self.bad = np.where(trying, self.bad ^ flip, self.bad)
        return trying & (u_loss < np.where(self.bad, b.loss_bad, b.loss_good))

    def received(self, frame: np.ndarray, tr: Transfer) -> np.ndarray:
        """The bytes the receiver got of ``frame`` (R, n) sent by :meth:`transfer` ``tr``: the sent ones, with the
        flips of the accepted try where a corruption passed the CRC (a copy then)."""
        if self.errors is None or not (tr.corrupt_try >= 0).any():
            return frame
        frame = frame.copy()
        apply_flips(self.errors.keys, tr.corrupt_try, tr.corrupt_ber, frame)
        return frame

    def transfer(self, t_ready, sending: np.ndarray, tx: RadioState | None, rx: RadioState | None,
                 rx_dead_at_s: float = np.inf) -> Transfer:
        """Send one frame at ``t_ready`` (scalar or (R,)) in the ``sending`` realizations (module docstring)."""
        m, ch, st = self.mac, self.channel, self.stats
        R = sending.shape[0]
        t_ready = np.full(R, t_ready, dtype=float) if np.ndim(t_ready) == 0 else np.asarray(t_ready, dtype=float)
        sending = sending.copy()
        st.frames += sending
        if m.enabled and tx is not None:
            full = sending & ((tx.queue_end > t_ready[:, None]).sum(axis=1) >= m.queue_length)
            st.dropped += full
            sending &= ~full
            start = np.maximum(t_ready, tx.free_at)
        else:
            start = t_ready.copy()
        attempts = 1 + m.max_retries if m.enabled else 1
        per_attempt = (2 if m.enabled else 1) + (2 if self.burst is not None else 0)
        t = start.copy()
        done = np.zeros(R, dtype=bool)
        arrival = np.full(R, np.nan)
        n_att = np.zeros(R, dtype=np.int64)
        heard = np.zeros(R, dtype=np.int64)  # attempts that reached a live receiver's radio
        wait_sum = np.zeros(R)
        corrupt_try, corrupt_ber = np.full(R, -1, dtype=np.int64), np.zeros(R)
        alive_always = rx_dead_at_s == np.inf
        half_duplex = m.enabled and rx is not None
        for _ in range(attempts):
            trying = sending & ~done
            if not trying.any():
                break
            n_att += trying
            u = self.draws.next_uniforms(per_attempt, trying)  # data[, ack][, burst state, burst loss]
            ok = trying & (u[:, 0] >= (ch.per_data(t) if self.errors is None else ch.per_preamble(t)))
            if not alive_always:
                alive = t < rx_dead_at_s
                ok &= alive
                heard += trying & alive
            if self.outages:
                ok &= ~self._in_outage(t)
            if self.burst is not None:
                ok &= ~self._burst_lost(trying, u[:, -2], u[:, -1])
            if half_duplex:
                ok &= ~((t < rx.busy_end) & (t + ch.airtime_s > rx.busy_start))
            if self.errors is not None:  # the receiver decodes the frame with the try's bit errors
                ber = ch.ber(t)
                tries = st.attempts + n_att - 1
                flips, accepted = self.errors.tries(tries, ber, ok)
                st.crc_rejected += ok & ~accepted
                bad_first = ok & accepted & (flips > 0)
                st.undetected += bad_first
                bad_first &= np.isnan(arrival)
                corrupt_try[bad_first], corrupt_ber[bad_first] = tries[bad_first], ber[bad_first]
                ok &= accepted
            arrival[ok & np.isnan(arrival)] = (t + ch.airtime_s)[ok & np.isnan(arrival)]
            if not m.enabled:
                done |= trying
                t = np.where(trying, t + ch.airtime_s, t)
                break
            acked = ok & (u[:, 1] >= ch.per_ack(t))
            if self.outages:
                acked &= ~self._in_outage(t)
            wait = np.where(acked, m.turnaround_s + ch.ack_airtime_s, m.ack_timeout_s)
            wait_sum += trying * wait
            done |= acked
            t = np.where(trying, np.maximum(t + ch.airtime_s + wait, t + ch.airtime_s / m.duty_cycle), t)
        st.attempts += n_att
        if m.enabled:
            if alive_always:
                heard = n_att
            _energy(tx, n_att * ch.airtime_s, wait_sum)
            _energy(rx, done * ch.ack_airtime_s, heard * ch.airtime_s)
        delivered = ~np.isnan(arrival)
        st.delivered += delivered
        st.latency_sum_s += np.where(delivered, arrival - t_ready, 0.0)
        end = np.where(sending, t, np.nan)
        if m.enabled and tx is not None:
            tx.busy_start = np.where(sending, start, tx.busy_start)
            tx.busy_end = np.where(sending, t, tx.busy_end)
            tx.free_at = np.where(sending, t, tx.free_at)
            slot = np.argmin(tx.queue_end, axis=1)
            rows = np.flatnonzero(sending)
            tx.queue_end[rows, slot[rows]] = t[rows]
        return Transfer(delivered, arrival, end, corrupt_try, corrupt_ber)


def _energy(radio: RadioState | None, tx_s: np.ndarray, rx_s: np.ndarray) -> None:
    if radio is not None:
        radio.tx_s += tx_s
        radio.rx_s += rx_s


def radio_energy_j(radio: RadioState, mac: MacSection) -> np.ndarray:
    """E = V (I_tx t_tx + I_rx t_rx) per realization [J]."""
    return mac.supply_v * (mac.tx_current_a * radio.tx_s + mac.rx_current_a * radio.rx_s)
