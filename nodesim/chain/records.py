"""The records a chain run leaves: per node (:class:`NodeRun`, every per-tick array), per survey as the ground
station got it (:class:`GroundSurvey`), and the run (:class:`ChainRun`), with what each node leaves when its
per-tick records are streamed out and dropped (:class:`NodeSummary`).  Data types only: both engines
(:mod:`nodesim.chain.network`, :mod:`nodesim.chain.compiled`) fill them, metrics and tables read them."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from nodesim.chain.mac import Link
from nodesim.chain.radio import HopChannel
from nodesim.chain.packets import SurveyPacket
from nodesim.motion.timelines import ChainMotion


@dataclass(frozen=True)
class NodeRun:
    """Per-tick records of one node (realization axis first; NaN where the node does not exist yet)."""

    node_id: int
    t_s: np.ndarray  # (K,)
    running: np.ndarray  # (K,) filter running and not holding
    update_mask: np.ndarray  # (R, K)
    update_age_s: np.ndarray  # (R, K) age of the reference at use, NaN without update
    true_yaw_rad: np.ndarray  # (K,)
    true_inclination_rad: np.ndarray  # (K,)
    true_azimuth_rad: np.ndarray  # (K,)
    yaw_est_rad: np.ndarray
    yaw_var_rad2: np.ndarray
    true_bias_rad_s: np.ndarray
    bias_est_rad_s: np.ndarray
    inclination_rad: np.ndarray  # moving-averaged, as the firmware reports it
    azimuth_rad: np.ndarray
    stale_packets: np.ndarray  # (R,)
    duplicate_packets: np.ndarray  # (R,)
    filter_start_s: float
    accel_sigma_m_s2: float
    firmware_overflows: dict  # fixed-point saturation/overflow events per site (empty for the float filter)
    # what the firmware read and the references it used (for replay logs, nodesim.replay.chain_log)
    gyro_counts: np.ndarray | None = None  # (R, K, 3) int64 per-tick sums of the int16 samples
    accel_counts: np.ndarray | None = None  # (R, K, 3) int64
    samples: np.ndarray | None = None  # (K,) int64 samples per tick
    ref_yaw_rad: np.ndarray | None = None  # (R, K) NaN where no update
    ref_var_rad2: np.ndarray | None = None
    present_from_s: float = 0.0
    adc_clipped_samples: np.ndarray | None = None  # (R,) gyro + accelerometer axis readings clipped at full scale
    estimate_frames: np.ndarray | None = None  # (R, K, 27) uint8 the estimate frames it sent (fixed firmware), 0 = none
    # (R, 2) rad: static error of the lab's measured truth (along, across the tilt; metrics.reference_accuracy_pct,
    # nodesim.chain.sensing.reference_error_rad); None: the metrics compare with the exact geometry
    reference_error_rad: np.ndarray | None = None
    # (R,) int64: the 6-state filter's ticks inside its singularity margin (filter.states = 6); None: 2-state filter
    singular_ticks: np.ndarray | None = None
    # the sensor readings (nodesim.chain.sensing.NodeSignals) behind gyro_rad_s and specific_force
    readings: object | None = None

    def ticks(self, k0: int, k1: int) -> "NodeRun":
        """The records of ticks ``k0`` .. ``k1 - 1`` (views; without the sensor readings object): a window of the
        node's ticks, as :class:`nodesim.chain.metrics.NodeMetricSums` takes them."""
        cut = {name: getattr(self, name) for name in TICK_FIELDS + REALIZATION_TICK_FIELDS}
        cut = {name: x[k0:k1] if name in TICK_FIELDS else x[:, k0:k1] for name, x in cut.items() if x is not None}
        return replace(self, **cut, readings=None)

    @property
    def gyro_rad_s(self) -> np.ndarray | None:
        """(R, K) tick-averaged z gyro [rad/s] (converted from the counts when first read)."""
        return None if self.readings is None else self.readings.gyro_rad_s

    @property
    def specific_force(self) -> np.ndarray | None:
        """(R, K, 3) tick-averaged specific force [m/s^2], sensor frame (converted when first read)."""
        return None if self.readings is None else self.readings.specific_force


TICK_FIELDS = ("t_s", "running", "true_yaw_rad", "true_inclination_rad", "true_azimuth_rad", "samples")
""":class:`NodeRun`'s (K,) records."""
REALIZATION_TICK_FIELDS = ("update_mask", "update_age_s", "yaw_est_rad", "yaw_var_rad2", "true_bias_rad_s",
                           "bias_est_rad_s", "inclination_rad", "azimuth_rad", "gyro_counts", "accel_counts",
                           "ref_yaw_rad", "ref_var_rad2", "estimate_frames")
""":class:`NodeRun`'s (R, K, ...) records (None where a run has none)."""


@dataclass(frozen=True)
class GroundSurvey:
    """A survey as the ground station received it."""

    packet: SurveyPacket
    arrival_s: np.ndarray  # (R,) NaN where it did not arrive
    # the fixed firmware's survey frame as the ground station received it (R, 25) uint8 (None: float filter)
    frame: np.ndarray | None = None


@dataclass(frozen=True)
class NodeSummary:
    """What a node leaves when its per-tick records were streamed out and dropped (a streamed run,
    :mod:`nodesim.chain.streaming`): its metric arrays (R,) (:func:`nodesim.chain.metrics.node_metrics`), its
    survey-table rows (:func:`nodesim.chain.run_tables.node_survey_rows`) and the counters a :class:`NodeRun` has
    under the same names."""

    node_id: int
    metrics: dict[str, np.ndarray]
    survey_rows: dict[str, np.ndarray]
    stale_packets: np.ndarray  # (R,)
    duplicate_packets: np.ndarray  # (R,)
    firmware_overflows: dict
    adc_clipped_samples: np.ndarray | None = None  # (R,)
    singular_ticks: np.ndarray | None = None  # (R,) filter.states = 6


@dataclass(frozen=True)
class ChainRun:
    nodes: tuple[NodeRun, ...]  # empty in a streamed run (``summaries`` instead)
    motion: ChainMotion
    surveys: tuple[GroundSurvey, ...]
    rotation_end_s: float
    lost_packets: np.ndarray  # (R,) over all links
    simpy_events: int
    moving_average_points: int
    hops: tuple[HopChannel, ...] = ()
    down_links: tuple[Link, ...] = ()  # index h: hop h (0 = surface to the top node)
    up_links: tuple[Link, ...] = ()
    skip_links: tuple[Link, ...] = ()  # fallback links that carried frames
    radio_energy_j: np.ndarray | None = None  # (N, R) per node
    engine: str = "event"  # which engine ran it: "event" (SimPy) or "compiled" (same numbers)
    summaries: tuple[NodeSummary, ...] = ()  # a streamed run's nodes (``nodes`` empty); () otherwise

    @property
    def node_count(self) -> int:
        return len(self.nodes) or len(self.summaries)

    @property
    def node_results(self) -> tuple:
        """The nodes' records, or in a streamed run their summaries: both have ``node_id``, ``stale_packets``,
        ``duplicate_packets``, ``firmware_overflows``, ``adc_clipped_samples`` and ``singular_ticks``."""
        return self.nodes or self.summaries
