"""Scenario sections of the radio links, the MAC and the faults (``[radio]``, ``[mac]``, ``[faults]``).

Every field has a validated default.  ``radio.model = "simple"`` (the default) keeps the fixed-delay links of
``[chain]``; ``"channel"`` puts a channel model under every hop: hop h feeds node h (hop 1 = surface to the
top node, by ``radio.top_kind``; the others by ``radio.kind`` unless a ``[[radio.hop]]`` override names them).
Media: ``soil`` (868 MHz between tube ends, Peplinski + thesis eq 5.2), ``pipe`` (5 GHz waveguide along a
tube, thesis 5.2), ``cable`` (a fixed loss to the surface).
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field, model_validator

from firmware_model.frames import ESTIMATE_BYTES
from nodesim.scenario.section_base import _Section
from nodesim.errors import NodesimError

Kind = Literal["soil", "pipe", "cable"]


class SoilHopSection(_Section):
    """Soil hop defaults (thesis 5.1.2: AMB8420/CC1101, 2 dBm, -110 dBm)."""

    frequency_hz: float = Field(868e6, ge=0.3e9, le=1.3e9, description="carrier (Peplinski model range)")
    distance_m: float = Field(0.3, gt=0.0, le=100.0, description="distance between the tube-end transceivers")
    sand: float = Field(0.5, ge=0.0, le=1.0)
    clay: float = Field(0.15, ge=0.0, le=1.0)
    vwc: float = Field(0.2, gt=0.0, le=1.0, description="volumetric water content")
    vwc_profile: list[list[float]] = Field(
        default_factory=list, description="[t_s, vwc] rows, linear in time (overrides vwc; held at the ends)")
    bulk_density_g_cm3: float = Field(1.5, gt=0.0, le=3.0)
    particle_density_g_cm3: float = Field(2.66, gt=0.0, le=4.0)
    temperature_c: float = Field(20.0, ge=0.0, le=40.0)
    tx_power_dbm: float = Field(2.0, ge=-40.0, le=40.0)
    sensitivity_dbm: float = Field(-110.0, ge=-150.0, le=0.0)

    @model_validator(mode="after")
    def _profile(self) -> "SoilHopSection":
        if self.sand + self.clay > 1.0:
            raise ValueError(f"sand + clay must be <= 1 (got {self.sand} + {self.clay})")
        for i, row in enumerate(self.vwc_profile):
            if len(row) != 2 or not 0.0 < row[1] <= 1.0 or row[0] < 0.0:
                raise ValueError(f"vwc_profile[{i}] = {row}: rows are [t_s >= 0, vwc in (0, 1]]")
            if i and row[0] <= self.vwc_profile[i - 1][0]:
                raise ValueError(f"vwc_profile[{i}] = {row}: t_s must increase")
        return self


class PipeHopSection(_Section):
    """Pipe hop defaults (thesis 5.2.5: 5 GHz, 10 dBm, -100 dBm; TE11 in an air-filled carbon-steel tube)."""

    frequency_hz: float = Field(5e9, gt=0.0, le=100e9)
    radius_m: float = Field(0.03, gt=0.0, le=1.0)
    length_m: float = Field(3.0, gt=0.0, le=1000.0, description="waveguide length between the transceivers")
    carbon_wt_pct: float = Field(0.2, ge=0.05, le=0.4)
    temperature_c: float = Field(20.0, ge=-20.0, le=400.0)
    tx_power_dbm: float = Field(10.0, ge=-40.0, le=40.0)
    sensitivity_dbm: float = Field(-100.0, ge=-150.0, le=0.0)


class CableHopSection(_Section):
    """Cable to the surface: a fixed loss (an assumption; the thesis gives no figure)."""

    loss_db: float = Field(20.0, ge=0.0, le=300.0)
    tx_power_dbm: float = Field(2.0, ge=-40.0, le=40.0)
    sensitivity_dbm: float = Field(-110.0, ge=-150.0, le=0.0)


class HopOverride(_Section):
    """One hop that differs from the defaults (hop h feeds node h; 1 = surface to the top node)."""

    hop: int = Field(..., ge=1, description="1-based hop index")
    kind: Kind | None = None
    distance_m: float | None = Field(None, gt=0.0, le=100.0, description="soil distance")
    length_m: float | None = Field(None, gt=0.0, le=1000.0, description="pipe length")
    loss_db: float | None = Field(None, ge=0.0, le=300.0, description="cable loss")
    vwc: float | None = Field(None, gt=0.0, le=1.0, description="soil water content (constant)")


class RadioSection(_Section):
    model: Literal["simple", "channel"] = "simple"
    kind: Kind = Field("soil", description="medium of the hops between nodes")
    top_kind: Kind = Field("cable", description="medium of hop 1 (surface to the top node)")
    shadowing_sigma_db: float = Field(4.0, ge=0.0, le=30.0, description="log-normal shadowing per hop and "
                                      "realization (Castalia default 4 dB)")
    bit_rate_bps: float = Field(38_400.0, gt=0.0, le=1e9)
    bandwidth_hz: float = Field(100e3, gt=0.0, le=1e10)
    noise_figure_db: float = Field(8.0, ge=0.0, le=40.0)
    profile_step_s: float = Field(10.0, gt=0.0, le=3600.0, description="time step of a vwc_profile evaluation")
    soil: SoilHopSection = SoilHopSection()
    pipe: PipeHopSection = PipeHopSection()
    cable: CableHopSection = CableHopSection()
    hop: list[HopOverride] = Field(default_factory=list)


MAX_FRAME_BYTES = 255


class MacSection(_Section):
    """Stop-and-wait ARQ MAC (``enabled = false``: one attempt per frame, no ACK, no queue).

    A data frame on air is ``preamble_bits + 8 * ESTIMATE_BYTES`` bits (:attr:`data_frame_bits`, the estimate
    frame of :mod:`firmware_model.frames`, 27 bytes incl. its CRC); it sets the airtime and the packet error rate.
    ``preamble_bits`` default 56: the CC1101 packet format (datasheet SWRS061 sec. 15.2), 4-byte preamble (the
    NUM_PREAMBLE reset value) + 16-bit sync word + 1 length byte, the radio's CRC off (the frame has its own).
    """

    enabled: bool = False
    preamble_bits: int = Field(56, ge=0, le=100_000, description="preamble + sync word + PHY header bits before "
                               "the frame (CC1101: 32 + 16 + 8)")
    ack_bits: int = Field(64, ge=8, le=100_000)
    bit_errors: bool = Field(False, description="draw each try's bit errors from the hop's BER and decode the frame "
                             "(CRC failure: dropped, retried; undetected: accepted, counted); needs radio.model = "
                             "'channel' and filter.implementation = 'fixed'")
    max_retries: int = Field(3, ge=0, le=20)
    ack_timeout_s: float = Field(0.01, gt=0.0, le=10.0)
    turnaround_s: float = Field(0.0002, ge=0.0, le=1.0, description="RX/TX switch time")
    duty_cycle: float = Field(1.0, gt=0.0, le=1.0, description="868 MHz limit, e.g. 0.01 (1 %); 1 = none")
    queue_length: int = Field(4, ge=1, le=10_000, description="frames a radio holds (incl. the one on air)")
    drop_policy: Literal["tail_drop"] = Field("tail_drop", description="a frame arriving at a full queue is dropped")
    tx_current_a: float = Field(0.0168, ge=0.0, le=2.0, description="CC1101 datasheet TX at 0 dBm, 868 MHz")
    rx_current_a: float = Field(0.0164, ge=0.0, le=2.0, description="CC1101 datasheet RX, 38.4 kbit/s")
    supply_v: float = Field(3.0, gt=0.0, le=48.0)

    @model_validator(mode="before")
    @classmethod
    def _no_frame_bits(cls, data):
        if isinstance(data, dict) and "frame_bits" in data:
            raise ValueError(
                f"mac.frame_bits is gone: the data frame length is the estimate frame's ({ESTIMATE_BYTES} bytes, "
                f"firmware_model/frames.py) plus mac.preamble_bits (default 56): remove mac.frame_bits and set "
                f"mac.preamble_bits (frame_bits = {data['frame_bits']!r} would be preamble_bits = frame_bits - "
                f"{8 * ESTIMATE_BYTES})")
        return data

    @property
    def data_frame_bits(self) -> int:
        """Bits on air per data frame: preamble_bits + 8 * ESTIMATE_BYTES."""
        return self.frame_bits(ESTIMATE_BYTES)

    def frame_bits(self, n_bytes: int) -> int:
        """Bits on air of a frame of ``n_bytes`` bytes: preamble_bits + 8 * n_bytes.  The CC1101's length byte
        limits a frame to MAX_FRAME_BYTES (datasheet SWRS061 sec. 15.2, variable packet length mode)."""
        if not 1 <= n_bytes <= MAX_FRAME_BYTES:
            raise NodesimError(f"a frame of {n_bytes} bytes does not fit the MAC's frame (allowed: 1..{MAX_FRAME_BYTES} "
                               f"bytes, the radio's length byte)")
        return self.preamble_bits + 8 * n_bytes


class NodeFailure(_Section):
    node: int = Field(..., ge=1)
    at_s: float = Field(..., ge=0.0)


class LinkOutage(_Section):
    hop: int = Field(..., ge=1, description="1 = surface to the top node")
    start_s: float = Field(..., ge=0.0)
    end_s: float = Field(..., gt=0.0)

    @model_validator(mode="after")
    def _ordered(self) -> "LinkOutage":
        if self.end_s <= self.start_s:
            raise ValueError(f"end_s ({self.end_s}) must be greater than start_s ({self.start_s})")
        return self


class BurstLoss(_Section):
    """Gilbert-Elliott burst loss on a hop (:class:`channel.budget.GilbertElliott`), on top of its PER."""

    hop: int = Field(..., ge=1)
    p_good_to_bad: float = Field(0.05, ge=0.0, le=1.0)
    p_bad_to_good: float = Field(0.2, gt=0.0, le=1.0)
    loss_good: float = Field(0.0, ge=0.0, le=1.0)
    loss_bad: float = Field(1.0, ge=0.0, le=1.0)


class ClockStep(_Section):
    node: int = Field(..., ge=1)
    at_s: float = Field(..., ge=0.0)
    step_s: float = Field(..., ge=-10.0, le=10.0, description="tick times from at_s on move by this")


class FaultsSection(_Section):
    node_failure: list[NodeFailure] = Field(default_factory=list)
    link_outage: list[LinkOutage] = Field(default_factory=list)
    burst: list[BurstLoss] = Field(default_factory=list)
    clock_step: list[ClockStep] = Field(default_factory=list)
    fallback: bool = Field(True, description="a node whose neighbour below is lost tries the next-but-one node")
    fallback_after_failures: int = Field(2, ge=1, le=1000, description="failed frames in a row before trying")
    fallback_min_margin_db: float = Field(3.0, ge=-50.0, le=100.0, description="mean margin the skip hop needs")


def check_indices(nodes: int, radio: RadioSection, faults: FaultsSection) -> None:
    """Hop and node indices inside the chain (hops 1..nodes, nodes 1..nodes); raises ValueError naming the key."""
    for name, items, attr in (("radio.hop", radio.hop, "hop"), ("faults.link_outage", faults.link_outage, "hop"),
                              ("faults.burst", faults.burst, "hop"), ("faults.node_failure", faults.node_failure,
                                                                      "node"),
                              ("faults.clock_step", faults.clock_step, "node")):
        for i, item in enumerate(items):
            v = getattr(item, attr)
            if v > nodes:
                raise ValueError(f"{name}[{i}].{attr} = {v}: allowed 1..{nodes} (chain.nodes)")
