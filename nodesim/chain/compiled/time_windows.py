"""Phase 2 of a streamed run in windows of time: every node over the window's ticks, top down, then the next window,
so that what a run holds grows with the window (:func:`window_s`) and the chain's length, not with its duration
(issue 20: peak memory flat as the duration doubles).

Node by node (:func:`.engine.simulate_compiled`), each node's sensor readings and records span the run, and every
node reads the sensors' shared per-sample truth of the whole run.  Here, for each window [t0, t1) of
:func:`window_s` and each node n from the top, its ticks k0 <= k < k1 with t0 <= T_n[k] < t1 are run by the same
steps over a window of ticks, each carrying its state from the node's window before:

* its count sums (:class:`nodesim.sensors.chain_imu.NodeImuStream`: the streams' states, the Gauss-Markov bias) from
  a shared truth over the window's samples only (:class:`nodesim.sensors.sample_truth.SampleTruth`, continuing the
  last window's prefix sums: the same sums);
* its firmware (:func:`.filters.run_node_firmware`, compiled for the build's words in a large run:
  :mod:`.firmware_constants`, from the lanes where the last window left them) on phase 1's
  records of those ticks, with the estimate frames of the node above and two above as the words they carry (no
  bit errors in a run in windows: :func:`.frame_pass.receive_words`, no bytes made), which keep of their last
  window only the words a later tick takes (:meth:`_Node.trim`);
* its survey words (:func:`firmware_model.node_survey.fixed_surveys_window`), its outputs
  (:meth:`nodesim.chain.streaming.NodeStream.node_windows`: timeseries rows, the metrics' sums, survey rows).
The numbers are those of the node-by-node run, bit for bit, except the RMS errors and the mean update age, whose
window sums are added (:class:`nodesim.chain.metrics.NodeMetricSums`, ~1e-15 relative); the timeseries table's rows
come window by window (node, then time, inside a window).  A window starts once phase 1's records of its ticks are
final: with more than one thread, phase 1 runs on a thread of its own beside the windows (:mod:`.phase_one`; the
drilling day's second half of phase 1 beside its first window: 67.6 / 71.0 s against 72.1 / 74.4 s for phase 1
first, whole processes interleaved, 2026-12-06); meanwhile the main thread makes every node's carried state
(:class:`_Node`) on the core phase 1 leaves idle.  Covered: the
fixed-point 2-state firmware without ``mac.bit_errors`` (:func:`windowed`), the drilling day's; other runs go node by
node.
"""

from __future__ import annotations

import gc
import math
from concurrent.futures import ThreadPoolExecutor
from dataclasses import replace
from typing import Callable

import numpy as np
from numba import njit

from firmware_model import frames as fr
from firmware_model import node_firmware as nf
from firmware_model import six_state_fixed as six_state
from firmware_model.node_survey import MA_RING
from nodesim import threads
from nodesim.chain import scratch as spill
from nodesim.chain.compiled import events as ev
from nodesim.chain.compiled import firmware_constants, frame_pass, six_state_fixed_node
from nodesim.chain.compiled import tick_plan as tp
from nodesim.chain.compiled.phase_one import PhaseOne, ground_surveys
from nodesim.chain.compiled.references import asks, encoder_reads, encoder_words
from nodesim.chain.compiled.surveys import fixed_survey_words
from nodesim.chain.estimator import alignment_ticks, alignment_window_s
from nodesim.chain.records import NodeRun
from nodesim.chain.sensing import reference_error_rad
from nodesim.chain.six_state_firmware_lanes import firmware_lanes
from nodesim.errors import NodesimError
from nodesim.sensors.chain_imu import ChainImu, NodeImuStream
from nodesim.sensors.sample_truth import SampleTruth

WINDOW_S = 3600.0
"""The shortest window of simulated time phase 2 runs every node over before the next (module docstring): a run of up
to this long is one window; a longer one holds a window of each node's records at a time (~2.7 MB a node and hour
for the drilling day's one realization) and a shared truth of a window's samples (~7.5 MB an hour)."""

MAX_WINDOWS = 2
"""A run is cut into at most this many windows (of its duration / MAX_WINDOWS where that is longer than
:data:`WINDOW_S`): each window costs every node a step of its own, and the steps do not come free.  Measured
(2026-12-06, whole ``nodesim run`` processes under ``/usr/bin/time``, 2 cores): the drilling day in one window 65.2 /
65.5 s and 1.10 GB peak (node by node: 62.4 / 64.9 / 67.2 s, 1.09 GB), in two 73.3 s and 0.80 GB (73.2 / 74.2 s,
0.76-0.79 GB with the sensors in the main thread), in four 73.3 / 78.2 / 78.4 / 82.8 s and 0.61-0.64 GB, in 24 (one
hour each) 157 s and 0.58 GB; later, the VM faster, one after the other: one window 59.5 / 60.0 s, two 60.7 s,
four 64.4 s, 24 99.0 s, with 21-23 k, 41 k, 88 k and 735 k voluntary context switches; its first 8 hours node by
node 23.4 s, in one window 21.5 / 22.2 s, in one-hour windows 32.1-36.1 s (with ``NODESIM_THREADS = 1``: 39.9 s in
one window against 43.3 s in one-hour windows).  A step costs ~0.5 ms of Python on one thread, but with the
sensor, output and writer threads the run's CPU time grows ~1-3 ms a step: the threads hand the GIL over ~35 more
times a step (the 8 hours in one-hour windows with the sensors and outputs in the main thread, only the writer
beside it: 28.8 s and 15 k voluntary switches, against 32.3 s and 231 k with the threads, 22.2 s in one window).  So a run up to two hours long is held flat in memory, and a longer one takes
windows of half its duration."""


def window_s(duration_s: float) -> float:
    """The window of a run of ``duration_s`` (:data:`WINDOW_S`, :data:`MAX_WINDOWS`)."""
    return max(WINDOW_S, duration_s / MAX_WINDOWS)


def windowed(scenario, on_node) -> bool:
    """Whether a streamed run goes window by window (module docstring): ``on_node`` takes windows
    (:class:`nodesim.chain.streaming.NodeStream`) and :func:`covers` the scenario."""
    return hasattr(on_node, "node_windows") and covers(scenario)


def covers(scenario) -> bool:
    """Whether phase 2 can run ``scenario`` in windows: the fixed-point 2-state firmware without ``mac.bit_errors``
    (the float filters and the 6-state firmware carry no state from window to window yet, nor do the bit errors'
    tables)."""
    return scenario.filter.implementation == "fixed" and scenario.filter.states == 2 and not scenario.mac.bit_errors


class _Span:
    """The samples a whole-run shared truth would cover (:func:`nodesim.chain.sensing.shared_truth`): a node whose
    samples fall outside reads a truth of its own (:class:`NodeImuStream`)."""

    def __init__(self, j_lo: int, j_hi: int):
        self.j_lo, self.j_hi = j_lo, j_hi

    def covers(self, a: int, b: int) -> bool:
        return self.j_lo <= a and b <= self.j_hi


class _Node:
    """What node index ``n`` carries from window to window (module docstring)."""

    def __init__(self, net, n: int, plan, imu: ChainImu, span: _Span | None, stream, node_ticks: int):
        s, node = net.scenario, net.nodes[n]
        t, R = node.t_s, net.R
        self.n, self.node = n, node
        self.k_end = int(np.searchsorted(t, node.dead_at_s, side="left"))
        starts = np.flatnonzero(np.asarray(plan[n, :t.size]) == tp.START)
        self.n_static = int(starts[0]) if starts.size else -1
        self.accel_sigma = imu.accel_density_m_s2_per_sqrt_hz / np.sqrt(net.dt_s)  # as node_signals gives it
        self.imu = NodeImuStream(imu, net.motion, net._streams, n, t, net.dt_s, R, span)
        self.fw = firmware_lanes(s, R)
        self.six = six_state_fixed_node.build(self.fw)
        self.run_firmware = firmware_constants.runner(self.fw.params, self.fw.fparams, node_ticks, self.six[0])
        self.work6 = six_state.new_work()
        self.asks = 0  # encoder requests in the windows before
        self.points = s.filter.moving_average_points
        self.survey_states = np.zeros((R, MA_RING + 4 * self.points), np.int64)
        self.first = int(np.searchsorted(t, node.timeline.present_from_s))
        self.align = alignment_ticks(alignment_window_s(s), t[self.first:])
        self.reference_error = reference_error_rad(s, net._streams, n)
        self.clipped = np.zeros(R, np.int64)
        self.sent: list[tuple[int, tuple[np.ndarray, np.ndarray], np.ndarray]] = []  # (first tick, its frames'
        # words (yaw, P_yy (R, k) each), their tick times) the nodes below may take
        self.stream = stream

    def words_from(self, j_min: int) -> tuple[np.ndarray, np.ndarray]:
        """The yaw and P_yy words (R, k) of this node's ticks from ``j_min`` on (of those it keeps), contiguous."""
        parts = [(a, w) for a, w, _ in self.sent if a + w[0].shape[1] > j_min]
        if not parts or parts[0][0] > j_min:
            raise NodesimError(f"node {self.node.node_id}: its estimate frame of tick {j_min} was taken after the "
                               "window it was kept for (nodesim.chain.compiled.time_windows)")
        if len(parts) == 1:  # (a view with one realization)
            a, w = parts[0]
            return np.ascontiguousarray(w[0][:, j_min - a:]), np.ascontiguousarray(w[1][:, j_min - a:])
        return tuple(np.concatenate([w[i][:, max(j_min - a, 0):] for a, w in parts], axis=1) for i in (0, 1))

    def trim(self, t_s: float) -> None:
        """Keep the words of the ticks from ``t_s`` on (a copy: the window's whole arrays are freed)."""
        kept = []
        for a, w, t in self.sent:
            i = int(np.searchsorted(t, t_s, side="left"))
            if i < t.size:
                kept.append((a + i, (w[0][:, i:].copy(), w[1][:, i:].copy()), t[i:].copy()))
        self.sent = kept


@njit(cache=True, nogil=True)
def _first_taken(src_offset, src_tick, s, k_first, k_end) -> int:
    """The lowest sender tick of the references from ``s`` nodes up taken at ticks k_first .. k_end - 1 (-1: none)."""
    best = -1
    for r in range(src_offset.shape[0]):
        for k in range(k_first, k_end):
            if src_offset[r, k] == s and (best < 0 or src_tick[r, k] < best):
                best = src_tick[r, k]
    return best


def run_windows(net, phase1: PhaseOne, plan, K: np.ndarray, stream, senders: list,
                progress: Callable[[float], None] | None) -> tuple[list, tuple]:
    """Phase 2 window by window (module docstring), each window once ``phase1`` has made its records final (phase 1
    may still be running: :mod:`.phase_one`); ``stream`` the run's :class:`NodeStream`, ``senders`` the surveys
    phase 1 sends (:func:`.phase_one.ground_surveys`).  Returns (the ground surveys, each with its frame, the nodes'
    summaries in node order)."""
    N, R = net.n_nodes, net.R
    s = net.scenario
    nodes: list[_Node | None] = [None] * N  # every one made by prepare(), before the first step
    total, done, steps_done = float(K.sum()), 0, 0
    keep_s = s.chain.max_update_age_s + 1.0  # a frame older than this at a window's end is never taken after it
    outputs, sensors = _Outputs(), _Sensors(net)
    surveys = list(net.ground)  # each set to its frame as it is made; grows window by window

    def prepare() -> None:  # every node's carried state, while phase 1 makes the first window's records final
        for i, n in enumerate(sorted(range(N), key=lambda j: net.nodes[j].t_s[0])):  # the first window's nodes first
            t = net.nodes[n].t_s
            nodes[n] = _Node(net, n, plan, sensors.imu, sensors.span, stream.node_windows(net.nodes[n].node_id, t, R),
                             net.node_ticks * R)
            if i % spill.DROP_EVERY_ROWS == spill.DROP_EVERY_ROWS - 1:
                spill.drop(net.scratch)  # the tick plan's rows read (and the tick table's pages): ~1 GB at once else

    frozen_before = gc.get_freeze_count()  # a caller's own frozen objects stay frozen after the run
    gc.freeze()  # the objects made before (modules, the network) left out of the collections: below
    try:
        steps = _steps(net, K, sensors, phase1, senders, surveys, prepare)
        ahead: list = []  # the next steps, their sensors under way on the worker
        while True:
            while len(ahead) <= SENSORS_AHEAD:
                step = next(steps, None)
                if step is None:
                    break
                t1, n, k0, k1, _ = step
                ahead.append((step, sensors.submit(nodes[n], k0, k1)))
            if not ahead:
                break
            (t1, n, k0, k1, out), sensed = ahead.pop(0)
            run, survey_from, mine = _window(net, nodes, n, k0, k1, sensed(), out, plan)
            outputs.submit(_outputs_of, net, nodes[n], run, survey_from, k0, mine, surveys)
            if n >= 2:  # its receivers (n - 1, n) have run this window
                nodes[n - 2].trim(t1 - keep_s)
            if not ahead or ahead[0][0][0] != t1:  # the window's last step: the last two nodes' receivers are done
                for x in nodes[max(n - 1, 0):n + 1]:
                    x.trim(t1 - keep_s)
            done += k1 - k0
            steps_done += 1
            if steps_done % DROP_EVERY_STEPS == 0:
                spill.drop(net.scratch)  # the whole-run tables' pages read so far (when they are on disk)
            if progress is not None:
                progress(0.5 + 0.5 * done / total)
        outputs.close()
    finally:
        outputs.shutdown()
        sensors.shutdown()
        if not frozen_before:
            gc.unfreeze()  # collectable again, as before the run
    out = phase1.result()[1]
    summaries = []
    for n in range(N):
        x = nodes[n]
        summaries.append(x.stream.finish(out.stale[:, n].copy(), out.duplicate[:, n].copy(), x.fw.overflow_counts,
                                         x.clipped, getattr(x.fw, "singular_ticks", None)))
    return surveys, tuple(summaries)


DROP_EVERY_STEPS = 8
"""The whole-run tables' pages leave memory every this many (node, window) steps (:func:`nodesim.chain.scratch.drop`,
as :data:`.engine.DROP_EVERY_NODES`)."""

SENSORS_AHEAD = 3
"""Phase 2 in windows has the sensor readings of this many (node, window) steps made ahead on worker threads while
it runs the firmware of the one before (as :data:`.engine.ATTACH_AHEAD` node by node)."""

SENSOR_THREADS = 1
"""Worker threads making the sensor readings (a node's windows in order: each is asked for after the one before was
taken).  Two: the drilling day in four windows 83.6 / 84.6 s against 73.3-82.8 s with one (2026-12-06)."""


def window_edges(duration_s: float) -> list[float]:
    """The windows' edges in simulated time: 0, W, 2 W, ..., inf (:func:`window_s`)."""
    W = window_s(duration_s)
    edges = [i * W for i in range(max(1, math.ceil(duration_s / W)) + 1)]
    edges[-1] = math.inf
    return edges


def _steps(net, K: np.ndarray, sensors: "_Sensors", phase1: PhaseOne, senders: list, surveys: list,
           prepare: Callable[[], None]):
    """(window end, node index, k0, k1, phase 1's records) of every (window, node) step with ticks (``K`` each node's
    ticks), in run order;
    each window's shared truth is queued on the sensors' worker before its first step, and its steps come once
    phase 1's records of the window are final (with the surveys sent in it added to ``net.ground`` and
    ``surveys``); ``prepare()`` is called once, after the first window's truth is queued and before that wait."""
    edges = window_edges(net.scenario.simulation.duration_s)
    T, clock = net.tick_table, net.tick_clock()
    for t0, t1 in zip(edges[:-1], edges[1:]):
        b = np.zeros((len(net.nodes), 2), np.int64)
        times = np.zeros((len(net.nodes), 2))
        _window_bounds(T, clock, K, t0, t1, net.dt_s, b, times)
        spill.drop(net.scratch)  # the tick table's pages the bisections read (none where the clocks are affine)
        bounds = [(int(k0), int(k1), float(a), float(z)) for (k0, k1), (a, z) in zip(b, times)]
        sensors.next_window(bounds)
        if prepare is not None:
            prepare()
            prepare = None
        out, arrivals = phase1.wait(t1)
        ground_surveys(net, senders, arrivals, t1)
        surveys.extend(net.ground[len(surveys):])
        for n, (k0, k1, _, _) in enumerate(bounds):
            if k0 < k1:
                yield t1, n, k0, k1, out


@njit(cache=True, nogil=True)
def _window_bounds(T, clock, K, t0, t1, dt_s, bounds, times) -> None:
    """Per node n: ``bounds[n]`` = (k0, k1), its ticks with t0 <= T_n[k] < t1 (bisections); ``times[n]`` = (the time
    after which tick k0 reads samples: T_n[k0 - 1], or T_n[0] - dt at its first tick; T_n[k1 - 1]) where it has
    some.  The times from the clock where it is affine (:func:`.events.tick_time`: the table's doubles, without
    mapping its pages)."""
    for n in range(K.size):
        for i, t in enumerate((t0, t1)):
            lo, hi = 0, K[n]
            while lo < hi:
                mid = (lo + hi) // 2
                if ev.tick_time(T, clock, n, mid) < t:
                    lo = mid + 1
                else:
                    hi = mid
            bounds[n, i] = lo
        k0, k1 = bounds[n, 0], bounds[n, 1]
        if k0 < k1:
            times[n, 0] = ev.tick_time(T, clock, n, k0 - 1) if k0 > 0 else ev.tick_time(T, clock, n, 0) - dt_s
            times[n, 1] = ev.tick_time(T, clock, n, k1 - 1)


class _Sensors:
    """The window steps' sensor readings (count sums and true attitude) made on :data:`SENSOR_THREADS` worker threads
    (in the calling thread with ``NODESIM_THREADS = 1``), each window's shared truth before its steps'."""

    def __init__(self, net):
        self.net = net
        s = net.scenario
        self.imu = ChainImu.from_scenario(s)
        rate = self.imu.sample_rate_hz
        self.span = None
        if net.motion.shared_attitude is not None:
            self.span = _Span(math.floor(-net.dt_s * rate) + 1, math.floor(s.simulation.duration_s * rate) + 1)
        many = threads.thread_count() > 1
        self.pool = ThreadPoolExecutor(SENSOR_THREADS, thread_name_prefix="nodesim-sensors") if many else None
        self.truth = self._later(lambda: None)

    def _later(self, work: Callable):
        if self.pool is None:
            value = work()
            return lambda: value
        return self.pool.submit(work).result

    def next_window(self, bounds: list) -> None:
        last = self.truth
        self.truth = self._later(lambda: _window_truth(self.net, self.imu, self.span, last(), bounds))

    def submit(self, x: _Node, k0: int, k1: int) -> Callable:
        """The readings of node ``x``'s ticks k0 .. k1 - 1, asked for now: a function that returns them (count sums,
        true attitude, the ticks' times: :func:`.events.tick_times`, a new array, not a view of the tick table,
        whose pages leave memory)."""
        net, truth = self.net, self.truth

        def read() -> tuple:
            t = ev.tick_times(net.tick_table, net.tick_clock(), x.n, k0, k1)
            return x.imu.counts(k0, k1, truth()), net.motion.attitude(x.n, t), t
        return self._later(read)

    def shutdown(self) -> None:
        if self.pool is not None:
            self.pool.shutdown(wait=True, cancel_futures=True)


def _window_truth(net, imu, span: _Span | None, last: SampleTruth | None, bounds: list) -> SampleTruth | None:
    """The shared truth of the samples the nodes' ticks of this window read (``bounds``: each node's (k0, k1, the time
    after which its tick k0 reads samples, the time of its tick k1 - 1)),
    continuing ``last`` (its prefix sums at this window's first sample); None where the nodes have no shared attitude."""
    if span is None:
        return None
    rate = imu.sample_rate_hz
    lo, hi = span.j_hi, span.j_lo
    for k0, k1, before, last_t in bounds:
        if k0 < k1:
            lo = min(lo, math.floor(before * rate) + 1)
            hi = max(hi, math.floor(last_t * rate) + 1)
    lo, hi = max(lo, span.j_lo), min(hi, span.j_hi)
    if last is None:
        lo = span.j_lo  # the run's first window: the truth starts where the whole run's does
    else:
        lo = max(min(lo, last.j_hi), last.j_lo)
    if hi <= lo:
        return last
    start = None if last is None else last.sums_at(lo)
    return SampleTruth(imu, net.motion, lo, hi, shared=True, keep_readings=imu.sampling != "tick_sum",
                       start_sums=start)


def _window(net, nodes: list, n: int, k0: int, k1: int, sensed: tuple, out: ev.Records, plan) -> tuple:
    """Node index ``n``'s ticks k0 .. k1 - 1: sensors, firmware, frames and survey words; (its records of the window
    as a :class:`NodeRun` without the survey, (its yaw words, count sums) the survey is made from, the indices in
    ``net.ground`` of the surveys it sent at those ticks)."""
    x = nodes[n]
    node, R = net.nodes[n], net.R
    c, att, t = sensed  # (count sums, true attitude, times) of the window's ticks (:meth:`_Sensors.submit`)
    W = k1 - k0
    codes = np.array(plan[n, k0:k1])
    x.clipped += c.gyro_clipped_samples + c.accel_clipped_samples
    running = ev.running_ticks(codes, t, node.dead_at_s)
    applied, offset, src_tick = out.applied[:, n, k0:k1], out.src_offset[:, n, k0:k1], out.src_tick[:, n, k0:k1]
    above = [net.nodes[i] if i >= 0 else node for i in (n - 1, n - 2)]
    age = np.empty((R, W))
    ev.forwarded_ages(t, offset, src_tick, above[0].t_s, above[1].t_s, age)
    ask, rows = asks(n, codes, out, x.asks)
    if ask.size:
        age[:, ask] = out.ask_age[:, rows]
    yaw, var, bias = np.full((R, W), np.nan), np.full((R, W), np.nan), np.full((R, W), np.nan)
    ref_yaw, ref_var = np.full((R, W), np.nan), np.full((R, W), np.nan)
    yaw_raw, var_raw = np.zeros((R, W), np.int64), np.zeros((R, W), np.int64)
    sends = n < net.n_nodes - 1  # the bottom node sends no estimate
    at_tick = np.flatnonzero((codes == tp.STATIC) | (codes == tp.START))
    static = codes[at_tick] == tp.STATIC
    enc_yaw = net.encoder.read_many(t[at_tick])[0] if at_tick.size else None
    if static.any():
        yaw[:, at_tick[static]] = enc_yaw[static]
    k_end = min(max(x.k_end - k0, 0), W)
    if x.n_static >= 0 and k_end > 0:
        _firmware(net, out, x, n, k0, k_end, t, codes, c, applied, offset, src_tick, above, at_tick, enc_yaw,
                  (yaw, var, bias, ref_yaw, ref_var, yaw_raw, var_raw), sends, running, nodes)
    x.asks += ask.size
    if sends:
        x.sent.append((k0, (yaw_raw, var_raw), t))
    run = NodeRun(
        node_id=node.node_id, t_s=t, running=running, update_mask=applied, update_age_s=age,
        true_yaw_rad=att.yaw_rad, true_inclination_rad=att.inclination_rad, true_azimuth_rad=att.azimuth_rad,
        yaw_est_rad=yaw, yaw_var_rad2=var, true_bias_rad_s=c.true_bias_rad_s, bias_est_rad_s=bias,
        inclination_rad=None, azimuth_rad=None, stale_packets=out.stale[:, n], duplicate_packets=out.duplicate[:, n],
        filter_start_s=node.timeline.filter_start_s, accel_sigma_m_s2=x.accel_sigma, firmware_overflows={},
        gyro_counts=c.gyro_counts, accel_counts=c.accel_counts, samples=c.samples, ref_yaw_rad=ref_yaw,
        ref_var_rad2=ref_var, present_from_s=node.timeline.present_from_s, estimate_frames=None,
        reference_error_rad=x.reference_error)
    mine = [i for i in net.surveys_of(n) if k0 <= net.ground[i].packet.tick < k1]
    return run, (yaw_raw, c), mine


def _firmware(net, out: ev.Records, x: _Node, n: int, k0: int, k_end: int, t, codes, c, applied, offset, src_tick, above,
              at_tick, enc_yaw, records: tuple, sends: bool, running, nodes: list) -> None:
    """The fixed firmware over the window's ticks 0 .. k_end - 1 (:func:`.engine._run_node_firmware` for a window),
    its frames as words: a run in windows has no ``mac.bit_errors`` (:func:`covers`), so every frame arrives as it
    was sent, and the receivers take the words it carries (:func:`.frame_pass.receive_words`), the sender checks that
    they fit it (:func:`.frame_pass.send_frames` into no frame ticks), and no bytes are made (sending the bytes was
    ~2-3 % of the day's CPU samples)."""
    yaw, var, bias, ref_yaw, ref_var, yaw_raw, var_raw = records
    node, fw, R = net.nodes[n], x.fw, net.R
    W = t.size
    yaw_enc, enc_rate, back_us = encoder_words(fw.config, R, t, at_tick, enc_yaw,
                                               encoder_reads(net, n, t, codes, out, x.asks))
    rate_raw, bias_raw = np.zeros((R, W), np.int64), np.zeros((R, W), np.int64)
    rx = np.zeros((R, W), np.int64), np.zeros((R, W), np.int64)
    k_first = min(max(x.n_static + 1 - k0, 0), W)  # the first tick that may take a reference or send a frame
    up_yaw, up_var, up_first = [], [], np.zeros(2, np.int64)
    for s in (1, 2):
        j = _first_taken(offset, src_tick, s, k_first, k_end) if n - s >= 0 else -1
        y, v = (nodes[n - s].words_from(j) if j >= 0 else (np.zeros((R, 1), np.int64), np.zeros((R, 1), np.int64)))
        up_first[s - 1] = max(j, 0)
        up_yaw.append(y)
        up_var.append(v)
    up_yaw, up_var = tuple(up_yaw), tuple(up_var)
    inp, res = np.zeros((R, len(fw.INPUTS)), np.int64), np.zeros((R, len(nf.OUTPUTS)), np.int64)
    words = np.zeros((R, len(fr.FIELDS[fr.ESTIMATE])), np.int64)

    def run(r0: int, r1: int) -> np.ndarray:
        counts = np.zeros(len(fw.SITES), dtype=np.int64)
        if n > 0:
            frame_pass.receive_words(offset, src_tick, k_first, k_end, up_yaw, up_var, up_first, *rx, r0, r1)
        x.run_firmware(fw.states, fw.params, fw.fparams, counts, c.gyro_counts, c.accel_counts, c.samples,
                       t, codes, k_end, k0 == 0, applied, yaw_enc, enc_rate, back_us, offset, src_tick,
                       tuple(a.t_s for a in above), *rx, inp, res, yaw_raw, var_raw, rate_raw, bias_raw,
                       yaw, var, bias, ref_yaw, ref_var, r0, r1, *x.six, x.work6)
        return counts

    fw.counts += sum(threads.map_chunks(run, R))
    if sends:
        no_bytes = np.zeros((R, 0, fr.ESTIMATE_BYTES), np.uint8)
        status = min(threads.map_chunks(lambda r0, r1: frame_pass.send_frames(
            node.node_id, node.first_tick, net.forward_every_tick, running, k_first, k_end, k0, applied, t, yaw_raw,
            var_raw, rate_raw, bias_raw, no_bytes, words, r0, r1), R))
        frame_pass.check_sent(status, node.node_id)


def _survey_words(x: _Node, k0: int, c, yaw_raw: np.ndarray) -> tuple:
    """(inclination (R, W), azimuth (R, W), (first, I words, A words)) of the window: the fixed firmware's moving
    averaged survey (:func:`nodesim.chain.compiled.surveys.fixed_survey_words`) from the node's first tick on,
    carried in ``x.survey_states``."""
    R, W = yaw_raw.shape
    inc, azi = np.empty((R, W)), np.empty((R, W))
    a = min(max(x.first - k0, 0), W)
    inc[:, :a] = azi[:, :a] = np.nan
    inc_raw, azi_raw = np.zeros((R, 0), np.int64), np.zeros((R, 0), np.int64)
    if a < W:
        inc_raw, azi_raw = fixed_survey_words(x.fw.config, c.accel_counts, yaw_raw, c.samples, a, k0 + a - x.first,
                                              x.align, x.points, x.survey_states, inc, azi)
    return inc, azi, (a, inc_raw, azi_raw)


def _outputs_of(net, x: _Node, run: NodeRun, survey_from: tuple, k0: int, mine: list, surveys: list) -> None:
    """A window's outputs: its survey words (:func:`_survey_words`), its surveys' frames as the ground station got them
    (set in ``surveys``, :meth:`Network.survey_frame`) and the node's ``add`` (the survey packets' ticks counted from
    the window's first)."""
    inc, azi, survey_raw = _survey_words(x, k0, survey_from[1], survey_from[0])
    run = replace(run, inclination_rad=inc, azimuth_rad=azi)
    got = []
    for i in mine:
        surveys[i] = g = net.survey_frame(i, run, k0, survey_raw)
        got.append(replace(g, packet=replace(g.packet, tick=g.packet.tick - k0)))
    x.stream.add(run, k0, got)


class _Outputs:
    """The window steps' outputs (:meth:`NodeWindows.add`) on one worker thread, in order, at most :data:`BACKLOG`
    waiting (with one thread, in the calling thread)."""

    BACKLOG = 4

    def __init__(self):
        self.pool = ThreadPoolExecutor(1, thread_name_prefix="nodesim-outputs") if threads.thread_count() > 1 else None
        self.pending: list = []

    def submit(self, step: Callable, *args) -> None:
        if self.pool is None:
            step(*args)
            return
        self.pending.append(self.pool.submit(step, *args))
        while len(self.pending) > self.BACKLOG or (self.pending and self.pending[0].done()):
            self.pending.pop(0).result()

    def close(self) -> None:
        while self.pending:
            self.pending.pop(0).result()

    def shutdown(self) -> None:
        if self.pool is not None:
            self.pool.shutdown(wait=True)
