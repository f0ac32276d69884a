"""The drilling process as the chain sees it: :class:`nodesim.motion.drilling.DrillingProcess` (tube insertions
along a wellpath, true attitude of every node) turned into node timelines and survey stops (thesis 2.7, 4.1).

Chain time t = process time + ``initial_static_s``: the string first rests so that the nodes in the hole
(the ``initial_tubes`` = M tubes 0 .. M - 1, default only the bit's tube 0) can average their gyros for their
initial bias.  Then, per tube k = M - 1 .. N - 1 (process phases): drill one tube length while rotating, a
survey stop, then the insertion of tube k + 1 at the top (string in the slips).  Mapping: process node k
(0 = bit) is chain node id N - k (1 = top of the final chain).
  - nodes N .. N - M + 1 (the initial tubes): present from 0, static window [0, initial_static_s), filters
    started at initial_static_s as after an insertion; node N - M + 1 is the top (encoder-aided) node until
    the first insertion starts, the others are never the top node;
  - node N - k (k >= M): present from the start of its tube's insertion; the insertion is its static
    window (the new node averages its gyro), and its filter starts from an encoder yaw when the insertion
    ends (thesis 2.7: the new top tube gets an encoder update first);
  - every node already in the string holds its state during later insertions (thesis 2.7: "saves psi
    during the insertion transition and resumes from it afterwards");
  - survey stop of tube k: station k + 1 (the first is station M); the bottom node's survey is taken
    ``survey_settle_s`` after the stop starts (the 32-point moving average has settled) and sent up; its MD
    is the bottom node's MD.  With ``motion.survey_nodes = "all"`` every node present at the stop takes its
    survey at that time too (one :class:`SurveyStop` per node, each with its own MD); the metric windows
    are one per station either way.
Mounting yaws are set so that every node's yaw equals the string angle theta at its insertion (a rigid,
aligned string: in a straight hole all nodes share the encoder's angle; a curved hole adds the geometric
twist of :mod:`nodesim.motion.drilling`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from nodesim.motion.timelines import ChainMotion, NodeAttitude, NodeTimeline, SurveyStop
from nodesim.motion.drilling import DrillingProcess, Wellpath
from nodesim.motion.rotation import RateProfile
from nodesim.scenario.schema import Scenario
from nodesim.units import DEG


@dataclass(frozen=True)
class ShiftedSpin:
    """The string spin of the process, on chain time (t_chain = t_process + lead_s)."""

    profile: RateProfile
    lead_s: float
    rotation_end_s: float

    def yaw_rad(self, t_s) -> np.ndarray:
        return self.profile.angle_rad(np.asarray(t_s, dtype=float) - self.lead_s)

    def rate_rad_s(self, t_s) -> np.ndarray:
        return self.profile.rate_rad_s(np.asarray(t_s, dtype=float) - self.lead_s)

    def mean_rate_rad_s(self, t0_s, t1_s) -> np.ndarray:
        t0, t1 = np.asarray(t0_s, dtype=float), np.asarray(t1_s, dtype=float)
        return (self.yaw_rad(t1) - self.yaw_rad(t0)) / (t1 - t0)


def drilling_process(scenario: Scenario) -> DrillingProcess:
    """The scenario's drilling process (kinematics issue model), mounts aligned to the string angle."""
    m = scenario.motion
    n = scenario.chain.nodes
    rows = m.wellpath or [[0.0, m.inclination_deg, m.azimuth_deg], [n * m.tube_length_m + 1.0, m.inclination_deg,
                                                                    m.azimuth_deg]]
    proc = DrillingProcess(
        Wellpath.from_degrees(rows),
        tube_length_m=m.tube_length_m,
        rop_m_s=m.rate_of_penetration_m_s,
        drilling_rate_rad_s=m.drill_rate_deg_s * DEG,
        ramp_s=m.ramp_s,
        survey_stop_s=m.survey_stop_s,
        insertion_s=m.insertion_s,
        node_offset_m=m.node_offset_m,
        n_tubes=n,
        initial_tubes=m.initial_tubes,
    )
    mounts = proc.rate_profile().angle_rad(proc.insertion_times_s())
    return replace(proc, mount_yaw_rad=tuple(float(x) for x in mounts))


def drilling_motion(scenario: Scenario) -> ChainMotion:
    """The chain's view of the scenario's drilling process (module doc): timelines, attitudes, survey stops."""
    m = scenario.motion
    n = scenario.chain.nodes
    lead = m.initial_static_s
    proc = drilling_process(scenario)
    first = proc.initial_tubes  # process nodes 0 .. first - 1 are in the hole at t = 0
    phases = proc.phases()
    insertions = [p for p in phases if p.name == "insertion"]  # tube k = first .. n-1
    surveys = [p for p in phases if p.name == "survey"]
    drills = [p for p in phases if p.name == "drill"]
    ins_start = [0.0] * first + [lead + p.start_s for p in insertions]  # by process node k
    ins_end = [lead] * first + [lead + p.end_s for p in insertions]
    timelines = {}
    for k in range(n):
        holds = tuple((ins_start[j], ins_end[j]) for j in range(max(k + 1, first), n))
        if k < first - 1:
            top_until = 0.0  # an initial tube below the top one: never the top node
        else:
            top_until = ins_start[k + 1] if k + 1 < n else math.inf
        timelines[n - k] = NodeTimeline(n - k, ins_start[k], ins_end[k], holds, top_until)
    t_in = proc.insertion_times_s()

    def attitude(index: int, t_s: np.ndarray) -> NodeAttitude:
        """Node ``index``'s truth at chain times ``t_s``, O(K) (DrillingProcess.node_attitude); at rest before
        insertion."""
        k = n - 1 - index
        return NodeAttitude(*proc.node_attitude(k, np.maximum(np.asarray(t_s, dtype=float) - lead, t_in[k])))

    stops, bottom_stops = [], []
    for p in surveys:
        t_survey = lead + p.start_s + m.survey_settle_s
        if m.survey_nodes == "all":  # every node present at the stop, the bottom one first
            ks = np.flatnonzero(t_in <= t_survey - lead)
        else:
            ks = np.zeros(1, dtype=int)
        mds = proc.node_md_m(ks, proc.bit_md_m(t_survey - lead))
        here = [SurveyStop(p.tube + 1, float(md), n - int(k), lead + p.start_s, t_survey, lead + p.end_s)
                for k, md in zip(ks, mds)]
        stops += here
        bottom_stops.append(here[0])
    lo, hi = scenario.metrics.window_start_s, scenario.metrics.window_end_s
    windows = tuple((max(s.t_survey_s, lo), min(s.end_s, hi)) for s in bottom_stops
                    if s.t_survey_s < hi and s.end_s > lo)  # one per station
    spin = ShiftedSpin(proc.rate_profile(), lead, lead + drills[-1].end_s)
    present = np.array([timelines[n - k].present_from_s for k in range(n)])
    margin_s = 2.0 / scenario.chain.firmware_rate_hz
    shared = straight_hole_attitude(proc, spin, present - margin_s, lead + t_in)
    return ChainMotion(spin, attitude, tuple(timelines[i] for i in range(1, n + 1)), tuple(stops), windows,
                       spin.rotation_end_s, shared)


def straight_hole_attitude(proc: DrillingProcess, spin: ShiftedSpin, first_sample_s: np.ndarray,
                           inserted_s: np.ndarray):
    """The attitude every node shares in a straight hole, or None (:attr:`ChainMotion.shared_attitude`).

    With every wellpath station at one inclination I and azimuth A the twist Gamma is zero and a node's yaw is
    psi_k0 + theta(t) - theta(t_k) = theta(t) (its mount is the string angle at its insertion t_k), so every node
    reads (theta(t), I, A) from its insertion on.  Before t_k a node's truth is held at t_k; that equals theta(t) on
    its samples as long as the string does not turn between its first sample (``first_sample_s``, per process node
    k) and its insertion (``inserted_s``): checked here against the spin's rate segments.  Any turn there, or a
    curved path, gives None (each node its own truth)."""
    wp = proc.wellpath
    if np.any(wp.inclination_rad != wp.inclination_rad[0]) or np.any(wp.azimuth_rad != wp.azimuth_rad[0]):
        return None
    segments = spin.profile.segments
    if segments:
        starts = np.array([g.start_s for g in segments]) + spin.lead_s
        ends = np.array([g.end_s for g in segments]) + spin.lead_s
        i = np.searchsorted(ends, first_sample_s, side="right")  # the first segment ending after the first sample
        inside = i < ends.size
        if np.any(starts[np.minimum(i, ends.size - 1)][inside] < inserted_s[inside]):
            return None
    inc, azi = float(wp.inclination_rad[0]), float(wp.azimuth_rad[0])

    def shared(t_s: np.ndarray) -> NodeAttitude:
        t = np.asarray(t_s, dtype=float)
        return NodeAttitude(spin.yaw_rad(t), np.full(t.shape, inc), np.full(t.shape, azi))

    return shared
