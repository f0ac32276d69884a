"""The chain's view of the true motion: the string's spin, each node's attitude, and when each node exists,
holds and surveys (data types; :mod:`nodesim.motion.chain_motion` builds them from a scenario).

Two kinds (``motion.kind``):
  - ``lab``: the thesis lab string (thesis 4.2.2-4.2.3, :class:`nodesim.motion.rotation.LabRotationProfile`);
    every node is present from t = 0, estimates its initial bias over the static window and shares the
    string's yaw, inclination and azimuth (a rigid string, no torsion).  Node 1 is the top node.
  - ``drilling``: :func:`nodesim.motion.drilling_timelines.drilling_motion` around the drilling process of
    :mod:`nodesim.motion.drilling`; node N (at the bit) is in place first and node 1 is inserted last.

Both give a :class:`ChainMotion`: the string spin (angle theta(t), what the encoder reads; its rate is what
every z gyro sees), each node's true yaw/inclination/azimuth at its tick times, one :class:`NodeTimeline`
per node and the survey stops.
"""

from __future__ import annotations

from bisect import bisect_right
from dataclasses import dataclass
from functools import cached_property
from typing import Callable, Protocol

import numpy as np

from nodesim.errors import NodesimError


class Rotation(Protocol):
    rotation_end_s: float

    def yaw_rad(self, t_s) -> np.ndarray: ...

    def rate_rad_s(self, t_s) -> np.ndarray: ...

    def mean_rate_rad_s(self, t0_s, t1_s) -> np.ndarray: ...


@dataclass(frozen=True)
class NodeTimeline:
    """When node ``node_id`` exists, estimates its initial bias, holds its state and is the top node."""

    node_id: int
    present_from_s: float  # powered in its tube
    filter_start_s: float  # end of its static bias window: the filter starts with an encoder yaw
    holds: tuple[tuple[float, float], ...]  # [start, end): tube insertions above it, state saved and resumed
    top_until_s: float  # it is the top node (encoder-aided) from present_from_s until this time

    def __post_init__(self):
        for i, (a, b) in enumerate(self.holds):
            if not a < b or (i and a < self.holds[i - 1][1]):
                raise NodesimError(f"node {self.node_id}: holds[{i}] = ({a}, {b}) must be a non-empty interval after "
                                   f"the previous one (holds are in time order and do not overlap)")

    @cached_property
    def _hold_starts(self) -> list[float]:
        return [a for a, _ in self.holds]

    def holding(self, t_s: float) -> bool:
        """t_s inside one of the holds [a, b): the last hold starting at or before t_s (bisection, O(log holds))."""
        i = bisect_right(self._hold_starts, t_s) - 1
        return i >= 0 and t_s < self.holds[i][1]

    def is_top(self, t_s: float) -> bool:
        return self.present_from_s <= t_s < self.top_until_s


@dataclass(frozen=True)
class SurveyStop:
    """A survey at a survey station: node ``node_id`` (the bottom node, or with ``motion.survey_nodes = "all"``
    each node present at the stop) takes its survey at ``t_survey_s``, at MD ``md_m``, and sends it up."""

    station: int
    md_m: float
    node_id: int
    start_s: float
    t_survey_s: float
    end_s: float


@dataclass(frozen=True)
class NodeAttitude:
    """True attitude of one node at its tick times (K,): yaw (unwrapped), inclination, azimuth (rad)."""

    yaw_rad: np.ndarray
    inclination_rad: np.ndarray
    azimuth_rad: np.ndarray


@dataclass(frozen=True)
class ChainMotion:
    rotation: Rotation  # the string spin: yaw_rad = theta(t) read by the encoder, rates seen by the z gyros
    attitude: Callable[[int, np.ndarray], NodeAttitude]  # (node index, tick times) -> truth
    timelines: tuple[NodeTimeline, ...]  # index i = node id i + 1
    stops: tuple[SurveyStop, ...]
    metric_windows: tuple[tuple[float, float], ...]  # where RMS errors are measured
    rotation_end_s: float  # end of the last rotation (bias convergence is timed from here)
    # the attitude every node has at chain time t wherever its sensors sample (from its first sample on), when all
    # nodes share one: the lab's rigid string, a drilling string in a straight hole (drilling_timelines); None
    # when the nodes differ.  The sensors then compute the per-sample truth once per run, not once per node.
    shared_attitude: Callable[[np.ndarray], NodeAttitude] | None = None

    def top_node_id(self, t_s: float) -> int:
        """The top node of the string at ``t_s``: the smallest id already in its tube (where surveys go up to)."""
        return min(tl.node_id for tl in self.timelines if tl.present_from_s <= t_s)
