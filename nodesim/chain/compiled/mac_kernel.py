"""Compiled stop-and-wait ARQ of one frame in one realization: :meth:`nodesim.chain.mac.Link.transfer` per lane.

The same rules and the same floating-point operations as the batched numpy MAC (:mod:`nodesim.chain.mac`, whose
docstring states the model): queue tail drop, start at max(t_ready, the radio's free time), per attempt the data
draw against PER_data(t), a dead receiver, outages, the Gilbert-Elliott burst state, half duplex against the
receiver's last exchange, the ACK draw against PER_ack(t), the attempt's duration and the duty-cycle off time,
energy per radio.  Realizations are independent there (every state is per realization), so resolving a frame lane
by lane gives the same numbers as resolving all lanes at once.

Arrays, realization-major so that one realization's state stays together in the cache (L links, G time
steps, R realizations, radios = nodes + the surface station):
``chan``  = (per_data (R, L, G), per_ack (R, L, G), rows (L,), step_s (L,), airtime_s (L,), ack_airtime_s (L,),
            burst (L, 5): has, p_good_to_bad, p_bad_to_good, loss_good, loss_bad, outages (L, O, 2), n_outages (L,))
``draws`` = (R, L, 4) uint64: each lane's PCG64 state (:mod:`nodesim.rng.pcg64`), advanced as the lane draws its
            uniforms, in the order :class:`nodesim.chain.links.LossDraws` hands them out
``radio`` = (busy_start, busy_end, free_at (R, radios), queue_end (R, radios, Q), tx_s, rx_s (R, radios))
``stats`` = (frames, delivered, attempts, dropped (R, L) int64, latency_sum_s (R, L), bad (R, L) bool)
``mac``   = (enabled, max_retries, queue_length, turnaround_s, ack_timeout_s, duty_cycle) as float64
``bits``  = (on, ber (R, L, G), per_preamble (R, L, G), keys (R, L) uint64, has_bytes (L,) bool, the all-zero
            frame, its layout and type, crc_rejected (R, L), undetected (R, L), then the receivers' records
            err_try, err_ber (R, N, K)): ``mac.bit_errors`` (:mod:`nodesim.chain.bit_errors`); ``scratch`` = (frame
            (bytes,) uint8, values (fields,) int64) work rows of this range of realizations
Each attempt takes its draws from the lane's stream as it needs them: the data draw, the ACK draw (MAC on), the burst
state and burst loss draws (a Gilbert-Elliott link), ``per_attempt`` of them, whether it uses them all or not (the
numpy MAC takes them in blocks of that size).  Drawing them here instead of from a buffer filled beforehand keeps
~20 bytes a node-tick out of memory in a long run.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from nodesim.chain.bit_errors import frame_try
from nodesim.rng.pcg64 import uniform


@njit(cache=True)
def time_row(chan, link: int, t: float) -> int:
    """Row of ``link``'s per-time tables (PER, margin) that holds time ``t``."""
    rows, step = chan[2][link], chan[3][link]
    if rows == 1:
        return 0
    g = int(t / step)
    return min(max(g, 0), rows - 1)


@njit(cache=True)
def _in_outage(chan, link: int, t: float) -> bool:
    out = chan[7]
    for i in range(chan[8][link]):
        if t >= out[link, i, 0] and t < out[link, i, 1]:
            return True
    return False


@njit(cache=True, inline="always")  # into phase 1's loop (events module docstring)
def transfer(link: int, r: int, t_ready: float, tx: int, rx: int, rx_dead_at_s: float, chan, draws, radio,
             stats, mac, bits, scratch):
    """Send one frame at ``t_ready`` on ``link`` in realization ``r``: (delivered, arrival_s, end_s, the delivered
    try's number where its bit errors passed the CRC (else -1), that try's BER)."""
    per_data, per_ack = chan[0], chan[1]
    airtime, ack_airtime = chan[4][link], chan[5][link]
    burst = chan[6]
    has_burst = burst[link, 0] > 0.0
    has_outages = chan[8][link] > 0
    hi, lo, inc_hi, inc_lo = draws[r, link, 0], draws[r, link, 1], draws[r, link, 2], draws[r, link, 3]
    busy_start, busy_end, free_at, queue_end, tx_s, rx_s = radio
    frames, delivered_n, attempts_n, dropped, latency_sum, bad = stats
    enabled = mac[0] > 0.0
    frames[r, link] += 1
    sending = True
    if enabled:
        held = 0
        for q in range(queue_end.shape[2]):
            if queue_end[r, tx, q] > t_ready:
                held += 1
        if held >= int(mac[2]):
            dropped[r, link] += 1
            sending = False
        start = max(t_ready, free_at[r, tx])
    else:
        start = t_ready
    attempts = 1 + int(mac[1]) if enabled else 1
    per_attempt = (2 if enabled else 1) + (2 if has_burst else 0)
    t = start
    done = False
    arrival = np.nan
    n_att = 0
    heard = 0
    wait_sum = 0.0
    alive_always = rx_dead_at_s == np.inf
    errs = bits[0] and bits[4][link]
    c_try, c_ber = -1, 0.0
    if sending:
        for _ in range(attempts):
            if done:
                break
            n_att += 1
            u0, hi, lo = uniform(hi, lo, inc_hi, inc_lo)
            u1 = u_state = u_loss = 0.0
            if enabled:
                u1, hi, lo = uniform(hi, lo, inc_hi, inc_lo)
            if has_burst:
                u_state, hi, lo = uniform(hi, lo, inc_hi, inc_lo)
                u_loss, hi, lo = uniform(hi, lo, inc_hi, inc_lo)
            g = time_row(chan, link, t)
            ok = u0 >= (bits[2][r, link, g] if errs else per_data[r, link, g])
            if not alive_always:
                alive = t < rx_dead_at_s
                ok = ok and alive
                if alive:
                    heard += 1
            if has_outages and _in_outage(chan, link, t):
                ok = False
            if has_burst:
                if bad[r, link]:
                    flip = u_state < burst[link, 2]
                else:
                    flip = u_state < burst[link, 1]
                bad[r, link] = bad[r, link] ^ flip
                if u_loss < (burst[link, 4] if bad[r, link] else burst[link, 3]):
                    ok = False
            if enabled and t < busy_end[r, rx] and t + airtime > busy_start[r, rx]:
                ok = False
            if errs and ok:  # the receiver decodes the frame with the try's bit errors
                try_no, ber = attempts_n[r, link] + n_att - 1, bits[1][r, link, g]
                flips, accepted = frame_try(bits[3][r, link], try_no, ber, bits[5], scratch[0], bits[6], bits[7],
                                            scratch[1])
                if not accepted:
                    bits[8][r, link] += 1
                    ok = False
                elif flips > 0:
                    bits[9][r, link] += 1
                    if math.isnan(arrival):
                        c_try, c_ber = try_no, ber
            if ok and math.isnan(arrival):
                arrival = t + airtime
            if not enabled:
                done = True
                t = t + airtime
                break
            acked = ok and u1 >= per_ack[r, link, g]
            if has_outages and _in_outage(chan, link, t):
                acked = False
            wait = (mac[3] + ack_airtime) if acked else mac[4]
            wait_sum += wait
            done = done or acked
            t = max(t + airtime + wait, t + airtime / mac[5])
    draws[r, link, 0], draws[r, link, 1] = hi, lo
    attempts_n[r, link] += n_att
    if enabled:
        if alive_always:
            heard = n_att
        tx_s[r, tx] += n_att * airtime
        rx_s[r, tx] += wait_sum
        tx_s[r, rx] += (ack_airtime if done else 0.0)
        rx_s[r, rx] += heard * airtime
    got = not math.isnan(arrival)
    if got:
        delivered_n[r, link] += 1
        latency_sum[r, link] += arrival - t_ready
    end = t if sending else np.nan
    if enabled and sending:
        busy_start[r, tx] = start
        busy_end[r, tx] = t
        free_at[r, tx] = t
        slot = 0
        for q in range(1, queue_end.shape[2]):
            if queue_end[r, tx, q] < queue_end[r, tx, slot]:
                slot = q
        queue_end[r, tx, slot] = t
    return got, arrival, end, c_try, c_ber
