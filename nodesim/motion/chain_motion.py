"""A scenario's motion as the chain sees it (``motion.kind``): the lab string or a drilling process.

  - ``lab``: the thesis lab string (thesis 4.2.2-4.2.3, :class:`nodesim.motion.rotation.LabRotationProfile`);
    every node is present from t = 0, estimates its initial bias over the static window and shares the
    string's yaw, inclination and azimuth (a rigid string, no torsion).  Node 1 is the top node.
  - ``drilling``: :func:`nodesim.motion.drilling_timelines.drilling_motion`.
"""

from __future__ import annotations

import math
import weakref

import numpy as np

from nodesim.motion.drilling_timelines import drilling_motion
from nodesim.motion.rotation import LabRotationProfile
from nodesim.motion.timelines import ChainMotion, NodeAttitude, NodeTimeline
from nodesim.scenario.schema import Scenario
from nodesim.units import DEG


def lab_profile(scenario: Scenario) -> LabRotationProfile:
    m = scenario.motion
    return LabRotationProfile(
        inclination_rad=m.inclination_deg * DEG,
        azimuth_rad=m.azimuth_deg * DEG,
        stationary_s=m.stationary_s,
        slow_rate_rad_s=m.slow_rate_deg_s * DEG,
        slow_turns=m.slow_turns,
        pause_s=m.pause_s,
        fast_rate_rad_s=m.fast_rate_deg_s * DEG,
        fast_turns=m.fast_turns,
    )


_LAST_MOTION: list = [None]  # (weakref to the scenario, its ChainMotion) of the latest build_motion


def build_motion(scenario: Scenario) -> ChainMotion:
    """The motion of ``scenario`` (lab or drilling), built once per scenario object: a run asks for it four times
    (the memory estimate, its disk needs, the outputs, the network), and a drilling day's takes ~0.2 s to build,
    before any core but one has work.  Both are frozen (a Scenario cannot change, a ChainMotion neither), so the
    latest one is kept, as :func:`nodesim.chain.sensing.shared_truth` keeps its truth."""
    last = _LAST_MOTION[0]
    if last is not None and last[0]() is scenario:
        return last[1]
    motion = _build_motion(scenario)
    _LAST_MOTION[0] = (weakref.ref(scenario), motion)
    return motion


def _build_motion(scenario: Scenario) -> ChainMotion:
    if scenario.motion.kind == "drilling":
        return drilling_motion(scenario)
    profile = lab_profile(scenario)
    n = scenario.chain.nodes
    timelines = tuple(
        NodeTimeline(i + 1, 0.0, scenario.motion.stationary_s, (), math.inf if i == 0 else 0.0) for i in range(n)
    )
    window = ((scenario.metrics.window_start_s, scenario.metrics.window_end_s),)

    def shared(t_s: np.ndarray) -> NodeAttitude:
        return NodeAttitude(profile.yaw_rad(t_s), np.full(t_s.shape, profile.inclination_rad),
                            np.full(t_s.shape, profile.azimuth_rad))

    return ChainMotion(profile, lambda _, t_s: shared(t_s), timelines, (), window, profile.rotation_end_s, shared)
