"""Link-budget what-ifs for one radio hop (``nodesim link soil|pipe``): parameters, evaluation, sweeps.

The physics is in :mod:`channel`; this module names the parameters (with defaults, units and help), evaluates
one medium over broadcast parameter arrays and parses ``--sweep KEY=START:STOP:N``.

Output keys (also the ``--json`` keys, documented in the README):
soil: ``eps_real``, ``eps_imag``, ``alpha_np_per_m``, ``beta_rad_per_m``, ``path_loss_db`` (thesis eq 5.2),
``free_space_loss_db``, ``rss_dbm``, ``margin_db``, ``max_distance_m`` (largest distance keeping
``target_margin_db``), ``exceeds_porosity``;
pipe: ``cutoff_hz`` (per mode: ``TE11``, ``TM01``, ``TE21``, ``TE01``, ...), ``propagating_modes``, ``mode``,
``resistivity_ohm_m``, ``attenuation_db_per_m`` (of ``mode``, default the dominant TE11; conductor + dielectric),
``loss_db`` (attenuation x length), ``rx_power_dbm``, ``margin_db``, ``max_length_m``;
both: ``noise_floor_dbm``, ``snr_db``, ``ber``, ``packet_error_rate`` (frame of ``frame_bits``, :mod:`channel.per`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from channel import budget, per, soil, steel, waveguide
from channel.errors import ChannelError
from nodesim.errors import NodesimError


DATA_FRAME_BITS = 272.0
"""The chain's data frame on air: ``mac.preamble_bits`` (56) + the 27-byte estimate frame (firmware_model.frames);
a literal so the CLI parser imports no numba or pydantic (tests/nodesim/chain/test_mac.py checks it equals
``MacSection().data_frame_bits``)."""


@dataclass(frozen=True)
class Param:
    key: str
    default: float
    help: str


_BUDGET = (
    Param("tx_gain_dbi", 0.0, "transmit antenna gain [dBi]"),
    Param("rx_gain_dbi", 0.0, "receive antenna gain [dBi]"),
    Param("other_losses_db", 0.0, "other fixed losses: cables, coupling, mismatch [dB]"),
    Param("target_margin_db", 10.0, "margin to keep when answering 'how far apart' [dB]"),
    Param("frame_bits", DATA_FRAME_BITS, "frame length on air for the packet error rate [bits] "
          "(default: the chain's data frame, mac.preamble_bits + the estimate frame)"),
    Param("bit_rate_bps", per.Radio.bit_rate_bps, "bit rate [bit/s] (assumption)"),
    Param("bandwidth_hz", per.Radio.bandwidth_hz, "receiver noise bandwidth [Hz] (assumption)"),
    Param("noise_figure_db", per.Radio.noise_figure_db, "receiver noise figure [dB] (assumption)"),
    Param("modulation_index", per.Radio.modulation_index, "FSK modulation index h (1: orthogonal tones)"),
)

SOIL_PARAMS = (
    Param("frequency_hz", 868e6, "carrier frequency [Hz] (Peplinski model: 0.3e9-1.3e9)"),
    Param("distance_m", 0.3, "distance between the two transceivers [m]"),
    Param("sand", 0.5, "sand mass fraction [0-1]"),
    Param("clay", 0.15, "clay mass fraction [0-1], sand + clay <= 1"),
    Param("vwc", 0.2, "volumetric water content (0-1]"),
    Param("bulk_density_g_cm3", 1.5, "soil bulk density [g/cm^3]"),
    Param("particle_density_g_cm3", 2.66, "soil particle (specific) density [g/cm^3]"),
    Param("temperature_c", 20.0, "soil temperature [degC] (0-40); for the pipe, the wall temperature (-20 to 400)"),
    Param("tx_power_dbm", budget.SOIL_868_BUDGET.tx_power_dbm, "transmit power [dBm] (CC1101/AMB8420: 2)"),
    Param("sensitivity_dbm", budget.SOIL_868_BUDGET.sensitivity_dbm, "receiver sensitivity [dBm] (CC1101: -110)"),
    *_BUDGET,
    Param("path_loss_constant_db", soil.THESIS_PATH_LOSS_CONSTANT_DB,
          "constant of thesis eq 5.2 [dB] (6.4 as published; 6.02 exact)"),
)

PIPE_PARAMS = (
    Param("frequency_hz", 5e9, "carrier frequency [Hz]"),
    Param("radius_m", 0.03, "inner radius of the drill pipe [m]"),
    Param("length_m", 3.0, "pipe length between the two transceivers [m]"),
    Param("carbon_wt_pct", steel.DEFAULT_CARBON_WT_PCT, "carbon content of the steel [wt %] (0.05-0.40)"),
    Param("temperature_c", 20.0, "wall temperature [degC] (-20 to 400)"),
    Param("mu_r_wall", 1.0, "relative permeability of the wall at the carrier frequency"),
    Param("eps_r", 1.0, "relative permittivity of a 'fluid' filling"),
    Param("loss_tangent", 0.0, "loss tangent of a 'fluid' filling"),
    Param("tx_power_dbm", budget.PIPE_5G_BUDGET.tx_power_dbm, "transmit power [dBm] (thesis: 10)"),
    Param("sensitivity_dbm", budget.PIPE_5G_BUDGET.sensitivity_dbm, "receiver sensitivity [dBm] (thesis: -100)"),
    *_BUDGET,
)

PARAMS = {"soil": SOIL_PARAMS, "pipe": PIPE_PARAMS}
FILLINGS = ("air", "water", "fluid")
CUTOFF_MODES = 6
"""How many modes (lowest cutoff first) ``cutoff_hz`` lists."""


def resolve_key(medium: str, key: str) -> str:
    """The parameter key named by ``key`` (exact, or without its unit suffix: 'distance' -> 'distance_m')."""
    keys = [p.key for p in PARAMS[medium]]
    k = key.strip().replace("-", "_")
    if k in keys:
        return k
    matches = [p for p in keys if p.split("_")[0] == k or p.rsplit("_", 1)[0] == k]
    if len(matches) == 1:
        return matches[0]
    raise NodesimError(f"--sweep key {key!r} is not a numeric parameter of 'link {medium}'; allowed: {', '.join(keys)}")


def parse_sweep(medium: str, text: str) -> tuple[str, np.ndarray]:
    """'vwc=0.01:0.8:20' -> ('vwc', linspace(0.01, 0.8, 20))."""
    if "=" not in text:
        raise NodesimError(f"--sweep must look like KEY=START:STOP:N (got {text!r})")
    key, rng = text.split("=", 1)
    parts = rng.split(":")
    try:
        if len(parts) != 3:
            raise ValueError
        start, stop, n = float(parts[0]), float(parts[1]), int(parts[2])
    except ValueError as err:
        raise NodesimError(f"--sweep range must be START:STOP:N with numbers and an integer N (got {rng!r})") from err
    if not 2 <= n <= 100_000:
        raise NodesimError(f"--sweep N must be in [2, 100000] (got {n})")
    return resolve_key(medium, key), np.linspace(start, stop, n)


def _budget(p: dict) -> budget.LinkBudget:
    return budget.LinkBudget(p["tx_power_dbm"], p["sensitivity_dbm"], p["tx_gain_dbi"], p["rx_gain_dbi"],
                             p["other_losses_db"])


def _quality(p: dict, rx_power_dbm, modulation: str) -> dict:
    radio = per.Radio(p["bit_rate_bps"], p["bandwidth_hz"], p["noise_figure_db"], modulation, p["modulation_index"])
    return per.link_quality(rx_power_dbm, p["frame_bits"], radio)


def evaluate_soil(p: dict, modulation: str = "fsk_noncoherent") -> dict:
    """Every soil output for parameter values (floats or one broadcast array)."""
    s = soil.Soil(p["sand"], p["clay"], p["vwc"], p["bulk_density_g_cm3"], p["particle_density_g_cm3"],
                  p["temperature_c"])
    r = soil.soil_path_loss(p["frequency_hz"], p["distance_m"], s, p["path_loss_constant_db"])
    b = _budget(p)
    allowed = b.allowed_path_loss_db(p["target_margin_db"])
    rss = b.received_power_dbm(r.path_loss_db)
    return {
        "eps_real": r.eps_real,
        "eps_imag": r.eps_imag,
        "alpha_np_per_m": r.alpha_np_per_m,
        "beta_rad_per_m": r.beta_rad_per_m,
        "path_loss_db": r.path_loss_db,
        "free_space_loss_db": soil.free_space_path_loss_db(p["distance_m"], p["frequency_hz"]),
        "rss_dbm": rss,
        "margin_db": b.margin_db(r.path_loss_db),
        "max_distance_m": soil.max_distance_m(allowed, r.alpha_np_per_m, r.beta_rad_per_m, p["path_loss_constant_db"]),
        "exceeds_porosity": r.exceeds_porosity,
        **_quality(p, rss, modulation),
    }


def filling_for(name: str, p: dict) -> waveguide.Filling:
    if name == "air":
        return waveguide.AIR
    if name == "water":
        try:
            return waveguide.water_filling(p["frequency_hz"], p["temperature_c"])
        except ChannelError as err:
            raise NodesimError(f"--filling water takes the water temperature from temperature_c: {err}") from err
    if name == "fluid":
        return waveguide.Filling("fluid", p["eps_r"], p["loss_tangent"], 1.0)
    raise NodesimError(f"--filling must be one of {', '.join(FILLINGS)} (got {name!r})")


def evaluate_pipe(p: dict, filling: str = "air", mode: str = "TE11", resistivity_ohm_m: float | None = None,
                  sweeping: bool = False, modulation: str = "fsk_noncoherent") -> dict:
    """Every pipe output; a single point below the mode's cutoff is a ChannelError, a sweep gives inf there."""
    fill = filling_for(filling, p)
    md = waveguide.Mode.parse(mode)
    if not sweeping:
        waveguide.require_propagation(p["frequency_hz"], p["radius_m"], fill, md)
    rho = (np.asarray(resistivity_ohm_m, float) if resistivity_ohm_m is not None
           else steel.carbon_steel_resistivity_ohm_m(p["temperature_c"], p["carbon_wt_pct"]))
    att = waveguide.attenuation_db_per_m(md, p["frequency_hz"], p["radius_m"], rho, p["mu_r_wall"], fill)
    b = _budget(p)
    length = np.asarray(p["length_m"], float)
    if np.any(length < 0):
        raise NodesimError(f"length_m must be >= 0 (got {float(np.min(length)):g})")
    with np.errstate(invalid="ignore"):
        loss = att * length
        allowed = b.allowed_path_loss_db(p["target_margin_db"])
        max_len = np.where(allowed > 0, allowed / att, 0.0)
    radius = np.atleast_1d(p["radius_m"])
    single_radius = radius.size == 1
    cutoffs = {m.name: waveguide.cutoff_frequency_hz(m, p["radius_m"], fill.eps_r, fill.mu_r)
               for m in waveguide.modes_by_cutoff()[:CUTOFF_MODES]}
    # one list of modes only for one point: a swept frequency, radius or water temperature (the filling's
    # permittivity) changes which modes propagate, point by point
    one_point = single_radius and np.ndim(p["frequency_hz"]) == 0 and np.ndim(fill.eps_r) == 0
    prop = ([m.name for m in waveguide.propagating_modes(p["frequency_hz"], float(radius[0]), fill)]
            if one_point else None)
    return {
        "cutoff_hz": cutoffs,
        "propagating_modes": prop,
        "mode": md.name,
        "filling": fill.name,
        "resistivity_ohm_m": rho,
        "attenuation_db_per_m": att,
        "loss_db": loss,
        "rx_power_dbm": b.received_power_dbm(loss),
        "margin_db": b.margin_db(loss),
        "max_length_m": max_len,
        **_quality(p, b.received_power_dbm(loss), modulation),
    }


def evaluate(medium: str, values: dict, sweep: tuple[str, np.ndarray] | None = None, **options) -> dict:
    """Evaluate ``medium`` at ``values`` (one entry per parameter), optionally sweeping one key.

    ``options``: ``modulation`` for both media; ``filling``, ``mode``, ``resistivity_ohm_m`` for the pipe."""
    p = dict(values)
    if sweep is not None:
        p[sweep[0]] = sweep[1]
    if medium == "soil":
        out = evaluate_soil(p, **options)
    else:
        out = evaluate_pipe(p, sweeping=sweep is not None, **options)
    numeric = (np.ndarray, np.generic, float, int)
    if sweep is not None:
        n = sweep[1].size
        out = {k: (np.broadcast_to(np.asarray(v), (n,)) if isinstance(v, numeric) else v) for k, v in out.items()}
        out["sweep"] = {"key": sweep[0], "values": sweep[1]}
    else:
        out = {k: (np.asarray(v).item() if isinstance(v, numeric) else v) for k, v in out.items()}
        if "cutoff_hz" in out:
            out["cutoff_hz"] = {k: float(v) for k, v in out["cutoff_hz"].items()}
    out["inputs"] = {k: v for k, v in values.items()}
    return out
