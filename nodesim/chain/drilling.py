"""A minimal drilling process: tube insertions, drilling with rotation, survey stops (thesis 2.7, 4.1).

Stand-in for the drilling kinematics of the sensor/kinematics issue (a wellpath given as stations, true
inclination/azimuth/toolface per node); this version drills a straight hole at the scenario's inclination
and azimuth and keeps the string rigid (every node shares the string's yaw, no torsion).

Programme for tube j = 0 .. N-1 (node id N - j; the bit node N goes in first, node 1 last), each
``insertion_s + L / ROP + survey_stop_s`` long, starting at t_j = j x that:
  1. insertion [t_j, t_j + insertion_s): the string is in the slips (no rotation).  The new tube's node is
     powered and averages its gyro for its initial bias; every node below holds its state (thesis 2.7:
     "saves psi during the insertion transition and resumes from it afterwards").
  2. drilling L metres at ROP while the string rotates at ``drill_rate_deg_s``.  The new node starts its
     filter with an encoder yaw (the new top tube is updated by the encoder first) and forwards it down.
  3. survey stop of ``survey_stop_s`` (static): after ``survey_settle_s`` (the 32-point moving average has
     settled) the bottom node's survey of station j+1 (MD = (j+1) L) is taken and sent up to the ground.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from nodesim.chain.motion import ChainMotion, NodeTimeline, SurveyStop
from nodesim.kinematics import LabRotationProfile, RotationPhase
from nodesim.scenario import Scenario
from nodesim.units import DEG


@dataclass(frozen=True)
class PhaseRotation:
    """String rotation made of constant-rate phases (static between them); yaw is the integral from 0.

    The rate/yaw/mean-rate integrals are those of :class:`LabRotationProfile`, which depend only on
    ``phases``; they are reused, not rewritten."""

    phases: tuple[RotationPhase, ...]

    rate_rad_s = LabRotationProfile.rate_rad_s
    yaw_rad = LabRotationProfile.yaw_rad
    mean_rate_rad_s = LabRotationProfile.mean_rate_rad_s

    @property
    def rotation_end_s(self) -> float:
        return self.phases[-1].end_s if self.phases else 0.0


@dataclass(frozen=True)
class DrillingProgramme:
    tubes: int
    tube_length_m: float
    rate_of_penetration_m_s: float
    drill_rate_rad_s: float
    insertion_s: float
    survey_stop_s: float
    survey_settle_s: float

    @property
    def drill_s(self) -> float:
        return self.tube_length_m / self.rate_of_penetration_m_s

    @property
    def per_tube_s(self) -> float:
        return self.insertion_s + self.drill_s + self.survey_stop_s

    def tube_start_s(self, j: int) -> float:
        return j * self.per_tube_s

    def rotation(self) -> PhaseRotation:
        phases = []
        for j in range(self.tubes):
            a = self.tube_start_s(j) + self.insertion_s
            phases.append(RotationPhase(f"drill_tube_{j + 1}", a, a + self.drill_s, self.drill_rate_rad_s))
        return PhaseRotation(tuple(phases))

    def timelines(self) -> tuple[NodeTimeline, ...]:
        out = {}
        n = self.tubes
        for j in range(n):
            node_id = n - j
            t0 = self.tube_start_s(j)
            holds = tuple((self.tube_start_s(m), self.tube_start_s(m) + self.insertion_s) for m in range(j + 1, n))
            top_until = self.tube_start_s(j + 1) if j + 1 < n else math.inf
            out[node_id] = NodeTimeline(node_id, t0, t0 + self.insertion_s, holds, top_until)
        return tuple(out[i] for i in range(1, n + 1))

    def stops(self) -> tuple[SurveyStop, ...]:
        out = []
        for j in range(self.tubes):
            start = self.tube_start_s(j) + self.insertion_s + self.drill_s
            out.append(
                SurveyStop(j + 1, (j + 1) * self.tube_length_m, self.tubes, start, start + self.survey_settle_s,
                           start + self.survey_stop_s)
            )
        return tuple(out)


def drilling_motion(scenario: Scenario) -> ChainMotion:
    m = scenario.motion
    prog = DrillingProgramme(
        tubes=scenario.chain.nodes,
        tube_length_m=m.tube_length_m,
        rate_of_penetration_m_s=m.rate_of_penetration_m_s,
        drill_rate_rad_s=m.drill_rate_deg_s * DEG,
        insertion_s=m.insertion_s,
        survey_stop_s=m.survey_stop_s,
        survey_settle_s=m.survey_settle_s,
    )
    stops = prog.stops()
    lo, hi = scenario.metrics.window_start_s, scenario.metrics.window_end_s
    windows = tuple((max(s.t_survey_s, lo), min(s.end_s, hi)) for s in stops if s.t_survey_s < hi and s.end_s > lo)
    return ChainMotion(prog.rotation(), m.inclination_deg * DEG, m.azimuth_deg * DEG, prog.timelines(), stops, windows)
