"""Per-hop channels of the chain: mean path loss from the channel models, shadowing, PER per transmission.

Hop h (0-based) feeds node h + 1: hop 0 runs from the surface to the top node, hop h >= 1 from node h to node
h + 1.  ``radio.model = "simple"``: every attempt is lost with ``chain.link_loss_probability`` and takes
``chain.link_delay_s``.  ``radio.model = "channel"``: the medium of the hop gives the mean path loss
(:mod:`channel` through :mod:`nodesim.chain.link_whatif`, nothing re-derived):

* soil (868 MHz between tube ends): Peplinski permittivity -> alpha, beta -> thesis eq 5.2 over ``distance_m``;
  a ``vwc_profile`` makes it a function of time, evaluated every ``radio.profile_step_s``;
* pipe (5 GHz along a tube): TE11 attenuation of an air-filled carbon-steel tube (thesis 5.2) x ``length_m``;
* cable (to the surface): a fixed ``loss_db``.

Then P_r = P_t - L_p - X_(h,r) (thesis eq 5.1, 0 dBi antennas) with X_(h,r) ~ N(0, sigma^2) log-normal
shadowing drawn once per hop and realization (a static borehole: the shadowing is a property of the hop, both
directions share it), and PER = 1 - (1 - BER(SNR))^bits (:mod:`channel.per`) for data and ACK frames,
tabulated per (time step, realization) so a transmission costs a table look-up.  The skip hop of the ad-hoc
fallback (node h to node h + 2) spans hops h + 1 and h + 2: the same medium over the summed distance or
length (mixed media: the summed losses), with its own shadowing draw.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from channel import budget, per
from nodesim.chain import link_whatif
from nodesim.rng.streams import RunStreams
from nodesim.scenario.schema import Scenario


@dataclass(frozen=True)
class HopGeometry:
    kind: str
    distance_m: float  # soil distance, pipe length (0 for a cable)
    loss_db: float  # cable loss
    vwc: float | None  # soil water content override


def hop_geometry(scenario: Scenario, h: int) -> HopGeometry:
    """Medium and size of hop ``h`` (0-based) from the defaults and the ``[[radio.hop]]`` overrides."""
    r = scenario.radio
    kind = r.top_kind if h == 0 else r.kind
    o = next((x for x in r.hop if x.hop == h + 1), None)
    if o is not None and o.kind is not None:
        kind = o.kind
    dist = {"soil": r.soil.distance_m, "pipe": r.pipe.length_m, "cable": 0.0}[kind]
    if o is not None and kind == "soil" and o.distance_m is not None:
        dist = o.distance_m
    if o is not None and kind == "pipe" and o.length_m is not None:
        dist = o.length_m
    loss = o.loss_db if o is not None and o.loss_db is not None else r.cable.loss_db
    return HopGeometry(kind, dist, loss, o.vwc if o is not None else None)


def _vwc(scenario: Scenario, geo: HopGeometry, t_s: np.ndarray) -> np.ndarray:
    s = scenario.radio.soil
    if geo.vwc is not None:
        return np.full(t_s.shape, geo.vwc)
    if s.vwc_profile:
        rows = np.asarray(s.vwc_profile, dtype=float)
        return np.interp(t_s, rows[:, 0], rows[:, 1])
    return np.full(t_s.shape, s.vwc)


def mean_path_loss_db(scenario: Scenario, geo: HopGeometry, t_s: np.ndarray) -> np.ndarray:
    """Mean path loss of a hop at times ``t_s`` (thesis eq 5.2 for soil, alpha x length for the pipe)."""
    r = scenario.radio
    if geo.kind == "cable":
        return np.full(t_s.shape, geo.loss_db)
    if geo.kind == "soil":
        p = {x.key: x.default for x in link_whatif.SOIL_PARAMS}
        p.update({k: getattr(r.soil, k) for k in ("frequency_hz", "sand", "clay", "bulk_density_g_cm3",
                                                  "particle_density_g_cm3", "temperature_c")})
        p.update(distance_m=geo.distance_m, vwc=_vwc(scenario, geo, t_s))
        return np.broadcast_to(link_whatif.evaluate_soil(p)["path_loss_db"], t_s.shape).astype(float)
    p = {x.key: x.default for x in link_whatif.PIPE_PARAMS}
    p.update({k: getattr(r.pipe, k) for k in ("frequency_hz", "radius_m", "carbon_wt_pct", "temperature_c")})
    p["length_m"] = geo.distance_m
    return np.full(t_s.shape, float(link_whatif.evaluate_pipe(p)["loss_db"]))


def link_budget(scenario: Scenario, kind: str) -> budget.LinkBudget:
    sec = getattr(scenario.radio, kind)
    return budget.LinkBudget(sec.tx_power_dbm, sec.sensitivity_dbm)


@dataclass
class HopChannel:
    """Per-attempt loss probabilities of one hop: ``per_data(t)`` and ``per_ack(t)``, shape (R,).

    ``margin_db`` (G, R): P_r - sensitivity per time step and realization (shadowing included);
    ``mean_margin_db``: without shadowing, at t = 0.  ``airtime_s``/``ack_airtime_s``: frame durations."""

    name: str
    kind: str
    step_s: float
    per_data_table: np.ndarray  # (G, R)
    per_ack_table: np.ndarray  # (G, R)
    margin_db: np.ndarray  # (G, R)
    mean_path_loss_db: float
    mean_margin_db: float
    airtime_s: float
    ack_airtime_s: float
    ber_table: np.ndarray | None = None  # (G, R) bit error rate (None: the simple link has none)
    per_preamble_table: np.ndarray | None = None  # (G, R) 1 - (1 - BER)^preamble_bits

    def _at(self, table: np.ndarray, t_s) -> np.ndarray:
        if table.shape[0] == 1:
            return table[0]
        g = self._row(t_s)
        return table[g, np.arange(g.shape[0])]

    def ber(self, t_s: np.ndarray) -> np.ndarray:
        return self._at(self.ber_table, t_s)

    def per_preamble(self, t_s: np.ndarray) -> np.ndarray:
        return self._at(self.per_preamble_table, t_s)

    def _row(self, t_s) -> np.ndarray:
        g = np.clip((np.asarray(t_s) / self.step_s).astype(np.int64), 0, self.per_data_table.shape[0] - 1)
        return g

    def for_frame(self, frame_bits: int, bit_rate_bps: float) -> "HopChannel":
        """The same hop for data frames of ``frame_bits`` bits (preamble included): PER 1 - (1 - BER)^bits and
        airtime bits / bit rate (the survey frames of the up links); the simple link is the same whatever the
        length (its fixed delay and loss)."""
        if self.ber_table is None:
            return self
        return replace(self, per_data_table=np.asarray(per.per_from_ber(self.ber_table, frame_bits), dtype=float),
                       airtime_s=frame_bits / bit_rate_bps)

    def per_data(self, t_s: np.ndarray) -> np.ndarray:
        return self._at(self.per_data_table, t_s)

    def per_ack(self, t_s: np.ndarray) -> np.ndarray:
        return self._at(self.per_ack_table, t_s)


def simple_channel(scenario: Scenario, name: str, R: int) -> HopChannel:
    """The fixed-delay link of ``[chain]``: loss ``link_loss_probability`` per attempt, ``link_delay_s`` long."""
    c = scenario.chain
    p = np.full((1, R), c.link_loss_probability)
    return HopChannel(name, "simple", scenario.simulation.duration_s + 1.0, p, np.zeros((1, R)),
                      np.full((1, R), np.inf), 0.0, np.inf, c.link_delay_s, c.link_delay_s)


def _channels(scenario: Scenario, specs: list[tuple[str, str, np.ndarray, np.ndarray]]) -> list[HopChannel]:
    """One HopChannel per (name, kind, mean path loss (G,), shadowing (R,)); the PER tables of all channels of a
    medium are evaluated in one vectorised call (element by element the same numbers as one call per hop)."""
    r, m = scenario.radio, scenario.mac
    radio = per.Radio(r.bit_rate_bps, r.bandwidth_hz, r.noise_figure_db)
    out: list[HopChannel | None] = [None] * len(specs)
    for kind in dict.fromkeys(spec[1] for spec in specs):
        idx = [i for i, spec in enumerate(specs) if spec[1] == kind]
        b = link_budget(scenario, kind)
        path_loss = np.stack([specs[i][2] for i in idx])  # (hops, G)
        loss = path_loss[:, :, None] + np.stack([specs[i][3] for i in idx])[:, None, :]
        rx = b.received_power_dbm(loss)  # (hops, G, R)
        quality = per.link_quality(rx, m.data_frame_bits, radio)
        ber = np.asarray(quality["ber"], dtype=float)  # the PERs below are 1 - (1 - ber)^bits of this BER
        per_data = np.asarray(quality["packet_error_rate"], dtype=float)
        per_ack = np.asarray(per.per_from_ber(ber, m.ack_bits), dtype=float)
        per_pre = (np.asarray(per.per_from_ber(ber, m.preamble_bits), dtype=float) if m.preamble_bits
                   else np.zeros_like(ber))
        margin = np.asarray(b.margin_db(loss), dtype=float)
        for j, i in enumerate(idx):
            out[i] = HopChannel(
                name=specs[i][0], kind=kind, step_s=r.profile_step_s,
                per_data_table=per_data[j], per_ack_table=per_ack[j], margin_db=margin[j],
                mean_path_loss_db=float(path_loss[j, 0]), mean_margin_db=float(b.margin_db(path_loss[j, 0])),
                airtime_s=m.data_frame_bits / r.bit_rate_bps, ack_airtime_s=m.ack_bits / r.bit_rate_bps,
                ber_table=ber[j], per_preamble_table=per_pre[j],
            )
    return out


def _time_grid(scenario: Scenario) -> np.ndarray:
    if not scenario.radio.soil.vwc_profile:
        return np.zeros(1)
    step = scenario.radio.profile_step_s
    return np.arange(int(scenario.simulation.duration_s // step) + 1) * step


def hop_channels(scenario: Scenario, streams: RunStreams, R: int) -> tuple[list[HopChannel], list[HopChannel | None]]:
    """(hop channels, skip-hop channels) for hops 0..N-1.  Skip channel h (h >= 1) runs from node h to node h + 2
    (None where there is no node h + 2, for hop 0, or with the simple model)."""
    n = scenario.chain.nodes
    if scenario.radio.model == "simple":
        return [simple_channel(scenario, f"hop{h + 1}", R) for h in range(n)], [None] * n
    grid = _time_grid(scenario)
    sigma = scenario.radio.shadowing_sigma_db
    if sigma > 0.0:
        gens = [streams.radio_batch(R, h) for h in range(n)]
        shadow = np.array([[g.standard_normal() for g in row] for row in gens]) * sigma
        skip_shadow = np.array([[g.standard_normal() for g in row] for row in gens]) * sigma
    else:  # no shadowing: zero draws (what sigma x N(0, 1) gives) without building the hops' generators
        shadow = skip_shadow = np.zeros((n, R))
    geos = [hop_geometry(scenario, h) for h in range(n)]
    known: dict[HopGeometry, np.ndarray] = {}

    def loss_of(geo: HopGeometry) -> np.ndarray:  # identical hops (a uniform chain) are evaluated once
        if geo not in known:
            known[geo] = mean_path_loss_db(scenario, geo, grid)
        return known[geo]

    specs = [(f"hop{h + 1}", geos[h].kind, loss_of(geos[h]), shadow[h]) for h in range(n)]
    for h in range(1, n - 1):
        a, b = geos[h], geos[h + 1]
        if a.kind == b.kind and a.kind != "cable":
            loss = loss_of(HopGeometry(a.kind, a.distance_m + b.distance_m, 0.0, a.vwc if a.vwc == b.vwc else None))
        else:
            loss = specs[h][2] + specs[h + 1][2]
        specs.append((f"skip{h}-{h + 2}", a.kind, loss, skip_shadow[h]))
    channels = _channels(scenario, specs)
    skips: list[HopChannel | None] = [None] * n
    skips[1:n - 1] = channels[n:]
    return channels[:n], skips
