"""The compiled chain engine: the SimPy engine's model and numbers, without a Python call per event.

:func:`simulate_compiled` takes a built :class:`nodesim.chain.network.Network` (clocks, sensor signals, hop
channels, links with their draw streams, faults: the same objects the SimPy engine runs on) and

1. resolves every tick, frame and packet in SimPy's event order in one compiled loop
   (:mod:`.events`, :mod:`.mac_kernel`): which reference each node takes at each tick in each realization;
2. runs each node's filter over its ticks, top node first (:mod:`.filters` with :mod:`.float_kernel` or
   :mod:`.fixed_kernel`), since estimates only flow down;
3. fills the nodes', links' and radios' records, so :meth:`Network.result` builds the same :class:`ChainRun`.

Bit-identical to the SimPy engine (tests/nodesim/test_chain_compiled.py compares every record).  Covered:
lab motion (every node present from t = 0, node 1 on top), every schedule, simple and channel links, the MAC,
node failures, outages, bursts, clock steps and the fallback, float and fixed filters (default fixed-point
policy).  Drilling runs (tube insertions, holds, survey stops and surveys going up) stay on the SimPy engine.
Uniform draws are buffered per link and realization from the link's own stream; a lane that runs out makes
phase 1 start again with a longer buffer (same stream, same numbers).
"""

from __future__ import annotations

import math
from typing import Callable

import numpy as np

from nodesim.chain.compiled import events as ev
from nodesim.chain.compiled import filters
from nodesim.chain.mac import LinkStats
from nodesim.errors import NodesimError
from nodesim.scenario import Scenario

INBOX_SLOTS = 8


def unsupported(scenario: Scenario) -> str | None:
    """Why the compiled engine cannot run ``scenario`` (None when it can)."""
    if scenario.motion.kind != "lab":
        return "motion.kind = 'drilling' (tube insertions and survey stops) needs simulation.engine = 'event'"
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
    """Every link phase 1 may use: down links 0..N-1 (hop h), skip links N + i (node i's fallback)."""

    def __init__(self, net):
        N, R = net.n_nodes, net.R
        self.links = list(net.down_links) + [
            net.skip_link(i + 1) if node.fallback.enabled else None for i, node in enumerate(net.nodes)]
        live = [x for x in self.links if x is not None]
        G = max(x.channel.per_data_table.shape[0] for x in live)
        O = max([len(x.outages) for x in live] + [1])
        L = len(self.links)
        per_data, per_ack, margin = np.zeros((L, G, R)), np.zeros((L, G, R)), np.zeros((L, G, R))
        rows, step = np.ones(L, dtype=np.int64), np.ones(L)
        air, ack_air = np.zeros(L), np.zeros(L)
        burst, outages, n_out = np.zeros((L, 5)), np.zeros((L, O, 2)), np.zeros(L, dtype=np.int64)
        for i, x in enumerate(self.links):
            if x is None:
                continue
            ch = x.channel
            g = ch.per_data_table.shape[0]
            per_data[i, :g], per_ack[i, :g] = ch.per_data_table, ch.per_ack_table
            margin[i, :ch.margin_db.shape[0]] = ch.margin_db
            rows[i], step[i], air[i], ack_air[i] = g, ch.step_s, ch.airtime_s, ch.ack_airtime_s
            if x.burst is not None:
                b = x.burst
                burst[i] = (1.0, b.p_good_to_bad, b.p_bad_to_good, b.loss_good, b.loss_bad)
            for j, (a, z) in enumerate(x.outages):
                outages[i, j] = (a, z)
            n_out[i] = len(x.outages)
        self.chan = (per_data, per_ack, rows, step, air, ack_air, burst, outages, n_out)
        self.margin = margin
        self.buffers = [[np.zeros(0) for _ in range(R)] for _ in range(L)]
        m = net.scenario.mac
        attempts = 1 + m.max_retries if m.enabled else 1
        for h in range(N):  # what a hop is expected to use, with headroom (more is drawn on demand)
            x = self.links[h]
            per_attempt = (2 if m.enabled else 1) + (2 if x.burst is not None else 0)
            sender = net.nodes[max(h - 1, 0)]
            frames = sender.sig.t_s.size * (2 if h == 0 else 1)
            p_ok = float(np.mean((1.0 - x.channel.per_data_table) * (1.0 - x.channel.per_ack_table)))
            mean_attempts = min(attempts, 1.2 / max(p_ok, 1.0 / attempts) + 0.05)
            n = int(math.ceil(frames * per_attempt * mean_attempts)) + 64
            for r in range(R):
                self.buffers[h][r] = x.draws.generators[r].random(n)

    def more(self, link: int, r: int) -> None:
        """Twice the buffered draws of one lane (the continuation of its stream)."""
        old = self.buffers[link][r]
        gen = self.links[link].draws.generators[r]
        self.buffers[link][r] = np.concatenate([old, gen.random(max(256, old.size))])

    def draws(self) -> tuple:
        L, R = len(self.links), len(self.buffers[0])
        sizes = np.array([[b.size for b in row] for row in self.buffers], dtype=np.int64).reshape(L, R)
        start = np.zeros(L * R, dtype=np.int64)
        start[1:] = np.cumsum(sizes.ravel())[:-1]
        flat = np.concatenate([b for row in self.buffers for b in row]) if sizes.sum() else np.zeros(1)
        return flat, start.reshape(L, R), sizes, np.zeros((L, R), dtype=np.int64)

    def store(self, stats: tuple) -> None:
        frames, delivered, attempts, dropped, latency, _ = stats
        for i, x in enumerate(self.links):
            if x is None:
                continue
            x.stats = LinkStats(frames.shape[1])
            x.stats.frames, x.stats.delivered = frames[i].copy(), delivered[i].copy()
            x.stats.attempts, x.stats.dropped = attempts[i].copy(), dropped[i].copy()
            x.stats.latency_sum_s = latency[i].copy()


def _resolve(net, links: _Links):
    """Phase 1 (:mod:`.events`), started again with more draws or inbox slots until it completes."""
    N, R = net.n_nodes, net.R
    c, m = net.scenario.chain, net.scenario.mac
    K = np.array([n.sig.t_s.size for n in net.nodes], dtype=np.int64)
    Kmax = int(K.max())
    T = np.full((N, Kmax), np.inf)
    for i, node in enumerate(net.nodes):
        T[i, :K[i]] = node.sig.t_s
    dead_at = np.array([n.dead_at_s for n in net.nodes], dtype=float)
    filter_start = np.array([n.timeline.filter_start_s for n in net.nodes], dtype=float)
    scheduled = np.zeros(Kmax, dtype=bool)
    scheduled[:K[0]] = net.nodes[0].scheduled
    fb = net.scenario.faults
    fallback = (np.array([n.fallback.enabled for n in net.nodes]), np.arange(N, 2 * N, dtype=np.int64),
                fb.fallback_after_failures, fb.fallback_min_margin_db)
    nodes_cfg = (c.processing_s, c.max_update_age_s, net.forward_every_tick)
    mac = np.array([float(m.enabled), m.max_retries, m.queue_length, m.turnaround_s, m.ack_timeout_s, m.duty_cycle])
    slots = INBOX_SLOTS
    while True:
        L = len(links.links)
        radios = N + 1
        radio = (np.full((radios, R), -np.inf), np.full((radios, R), -np.inf), np.full((radios, R), -np.inf),
                 np.full((radios, R, m.queue_length), -np.inf), np.zeros((radios, R)), np.zeros((radios, R)))
        stats = (np.zeros((L, R), np.int64), np.zeros((L, R), np.int64), np.zeros((L, R), np.int64),
                 np.zeros((L, R), np.int64), np.zeros((L, R)), np.zeros((L, R), dtype=bool))
        inbox = (np.zeros((N, R, slots), np.int64), np.zeros((N, R, slots), np.int64),
                 np.zeros((N, R, slots), np.int64), np.zeros((N, R, slots)), np.zeros((N, R), np.int64))
        out = (np.zeros((N, Kmax), dtype=bool), np.zeros((N, Kmax, R), dtype=bool), np.full((N, Kmax, R), np.nan),
               np.full((N, Kmax, R), -1, np.int64), np.full((N, Kmax, R), -1, np.int64), np.full((Kmax, R), np.nan),
               np.zeros((N, R), np.int64), np.zeros((N, R), np.int64), np.zeros(1, np.int64))
        need = np.zeros(2, np.int64)
        status = ev.run_events(T, K, dead_at, filter_start, scheduled, nodes_cfg, fallback, links.chan, links.margin,
                               links.draws(), radio, stats, mac, inbox, np.full((N, R), -1, np.int64),
                               np.zeros((N, R), np.int64), out, need)
        if status == ev.DONE:
            return T, out, radio, stats
        if status == ev.NEED_DRAWS:
            links.more(int(need[0]), int(need[1]))
        else:
            slots *= 2


def _kernels(scenario: Scenario):
    if scenario.filter.implementation == "fixed":
        from nodesim.chain.compiled import fixed_kernel as k
    else:
        from nodesim.chain.compiled import float_kernel as k
    return k, (k.predict, k.update, k.yaw_rad, k.bias_rad_s, k.yaw_variance_rad2)


def _run_node(net, n: int, T, out) -> None:
    """Phase 2 for node index ``n`` (module docstring); writes the node's records."""
    from nodesim.chain.estimator import new_filter

    node, sig = net.nodes[n], net.nodes[n].sig
    running, applied, age, src_node, src_tick, enc_t_read, stale, dup, _ = out
    t, R = sig.t_s, net.R
    K = t.size
    k_end = int(np.searchsorted(t, node.dead_at_s, side="left"))
    n_static = int(np.searchsorted(t[:k_end], node.timeline.filter_start_s, side="left"))
    node.running[:] = running[n, :K]
    node.applied[:] = applied[n, :K].T
    node.age[:] = age[n, :K].T
    node.stale, node.duplicate = stale[n].copy(), dup[n].copy()
    if n_static:
        node.yaw[:, :n_static] = net.encoder.read_many(t[:n_static])[0]
    if n_static >= k_end:
        return
    bias0 = filters.sequential_sum(sig.gyro_rad_s, n_static) / n_static if n_static else 0.0
    node.kf = new_filter(net.scenario, R, net.encoder.read(t[n_static])[0], bias0)
    node._record(n_static)
    module, kernels = _kernels(net.scenario)
    state, params = module.lane_states(node.kf), module.kernel_params(node.kf)
    counts = np.zeros(len(getattr(module, "SITES", (None,))), dtype=np.int64)
    enc_ref = np.zeros((K, R))
    if n == 0:
        t_read = np.where(np.isnan(enc_t_read[:K]), t[:, None], enc_t_read[:K])
        yaw_enc, rate_enc = net.encoder.read_many(t_read)
        enc_ref = yaw_enc - rate_enc * (t_read - t[:, None])
    src = src_node[n, :K]
    offset = np.where(src >= 0, n - src, -1)
    above = [net.nodes[i] if i >= 0 else node for i in (n - 1, n - 2)]
    c = net.scenario.chain
    filters.run_node(kernels, state, params, counts, sig.gyro_rad_s, t, n_static + 1, k_end, n == 0,
                     node.scheduled, enc_ref, net.encoder.variance_rad2, applied[n, :K], offset, src_tick[n, :K],
                     tuple(a.sig.t_s for a in above), tuple(a.yaw for a in above), tuple(a.var for a in above),
                     net.dt_s, net.extrapolate_rate, sig.gyro_white_sigma_rad_s, net.offset_sigma_rad**2,
                     node.yaw, node.var, node.bias, node.ref_yaw, node.ref_var)
    if hasattr(module, "counts_dict"):
        for site, count in module.counts_dict(counts).items():
            node.kf.ctx.counter.record(site, count)


def simulate_compiled(net, progress: Callable[[float], None] | None = None):
    """Run the built network ``net`` on the compiled engine (module docstring) and return its ChainRun."""
    links = _Links(net)
    T, out, radio, stats = _resolve(net, links)
    net.events = int(out[-1][0])
    links.store(stats)
    for i, node in enumerate(net.nodes):
        node.radio.tx_s, node.radio.rx_s = radio[4][i].copy(), radio[5][i].copy()
    net.surface.tx_s, net.surface.rx_s = radio[4][-1].copy(), radio[5][-1].copy()
    for n in range(net.n_nodes):
        _run_node(net, n, T, out)
        if progress is not None:
            progress((n + 1) / net.n_nodes)
    return net.result()
