"""Radio channel figures of thesis chapter 5: waveguide cutoffs and losses, the 110 dB pipe budget, soil RSS.

Steel: the handbook-anchored resistivity model of :mod:`channel.steel` at 20 degC and 0.26 wt % C (a typical
API 5L grade, thesis Table 5.1), mu_r,wall = 1, air filling, r = 3 cm, 5 GHz.
Soil: 868 MHz, 0.3 m, P_t = 2 dBm, 0 dBi antennas (thesis 5.1.2); composition not given by the thesis, so the
default sandy loam (sand 0.50, clay 0.15, 1.5 g/cm^3) is used for the direct comparison and for the
1 % -> 80 % span.

The soil RSS gap: the published equations give RSS about 28 dB (1 % VWC) to 44 dB (80 %) above the thesis's
figures for the default soil.  Unit errors in d, f, beta or alpha would make the gap grow steeply with water
content (tested and ruled out in tests/channel/test_soil_gap.py); only a VWC-independent offset can fit both
endpoints, and an offset leaves the 1 % -> 80 % span unchanged, so the span alone picks the soil.  The
published span is 40.6 dB (-54.5 -> -95.1 dBm); no soil of the sand/clay grid of Figs 5.2-5.4 reaches it, and
the closest, pure clay (39.9 dB), is the one soil of both hypothesis rows (chosen once, by the span, never by
a row's level).  The offset is not fitted either: 30 dB is exactly 10 log10(1000), the dBm/dBW step, i.e. the
thesis's RSS would be P_r computed in dBW (P_t = 2 dBm entered as 1.58 mW -> -28 dBW) and labelled dBm.  This
is a hypothesis (the thesis code is not available; the thesis states neither the soil nor the unit): the
direct checks stay failed, and the hypothesis rows are of kind ``hypothesis``.  80 % VWC exceeds the porosity
1 - rho_b / rho_s of every soil here (0.436 at 1.5 / 2.66 g/cm^3): the rows at 80 % say so.

Every row is a ``reproduction`` (our model, run independently, against the published figure) except the two
soil hypothesis rows.
"""

from __future__ import annotations

import numpy as np

from channel import soil, steel, waveguide
from channel.budget import PIPE_5G_BUDGET, SOIL_868_BUDGET
from nodesim.validation import Check, within_abs, within_factor, within_rel

RADIUS_M = 0.03
F_PIPE_HZ = 5e9
F_SOIL_HZ = 868e6
D_SOIL_M = 0.3
DBW_OFFSET_DB = 30.0
"""10 log10(1 W / 1 mW): the offset of the dBW-labelled-as-dBm hypothesis."""


def _rho() -> float:
    return float(steel.carbon_steel_resistivity_ohm_m(20.0, steel.DEFAULT_CARBON_WT_PCT))


def pipe_cutoffs() -> list[Check]:
    src = "thesis Table 5.4 (cut-off frequencies at radius 3 cm), eqs 5.4-5.5"
    out = []
    for mode, pub in ((waveguide.TE11, 2.928e9), (waveguide.TM01, 3.828e9), (waveguide.TE21, 4.858e9)):
        ours = float(waveguide.cutoff_frequency_hz(mode, RADIUS_M))
        note = "thesis mixes c = 3e8 (TM01) and 2.998e8" if mode == waveguide.TM01 else ""
        out.append(within_rel(f"pipe: {mode.name} cutoff, r = 3 cm [Hz]", src, ours, pub, 0.005, note))
    return out


ORDER_FACTOR = 2.0
"""The thesis gives the pipe figures as "of the order of"; read as within a factor of two, the project's
convention for approximately stated figures (the lab figures of the chain issue use the same factor)."""


def pipe_attenuation() -> list[Check]:
    rho = _rho()
    src = "thesis 5.2.5 / Fig. 5.11 (5 GHz, r = 3 cm, typical carbon content, room temperature), eqs 5.6-5.8"
    te = float(waveguide.attenuation_db_per_m(waveguide.TE11, F_PIPE_HZ, RADIUS_M, rho))
    tm = float(waveguide.attenuation_db_per_m(waveguide.TM01, F_PIPE_HZ, RADIUS_M, rho))
    ratio_note = (
        f"rho = {rho:.4g} Ohm*m (0.26 wt % C, 20 degC, handbook-anchored model); TM01/TE11 = {tm / te:.3f} is fixed "
        f"by geometry, the thesis's 0.082/0.034 = 2.41 cannot come from one resistivity"
    )
    return [
        within_factor("pipe: TE11 attenuation at 5 GHz [dB/m]", src, te, 0.034, ORDER_FACTOR,
                      ratio_note + "; 0.034 dB/m would need rho = 1.12e-7 Ohm*m"),
        within_factor("pipe: TM01 attenuation at 5 GHz [dB/m]", src, tm, 0.082, ORDER_FACTOR,
                      ratio_note + "; 0.082 dB/m would need rho = 2.39e-7 Ohm*m"),
    ]


def pipe_budget_length() -> list[Check]:
    att = float(waveguide.attenuation_db_per_m(waveguide.TE11, F_PIPE_HZ, RADIUS_M, _rho()))
    budget_db = PIPE_5G_BUDGET.max_path_loss_db
    return [within_factor(
        "pipe: length for a 110 dB budget, TE11 [m]",
        "thesis 5.2.5 / Fig. 5.12 (10 dBm in, -100 dBm sensitivity)",
        budget_db / att, 3666.0, ORDER_FACTOR,
        "3666 m implies 0.0300 dB/m, i.e. rho = 0.87e-7 Ohm*m; ours uses the TE11 attenuation of the check above",
    )]


HYPOTHESIS_SOIL = {"sand": 0.0, "clay": 1.0}
"""The one soil of both dBW-hypothesis rows: the sand/clay grid soil whose 1 % -> 80 % RSS span is closest to the
published 40.6 dB (checked in tests/channel/test_soil_gap.py); default bulk and particle densities."""

PUBLISHED_RSS_DBM = {0.01: -54.5, 0.8: -95.1}
"""Thesis 5.1.2: RSS "from about -54.5 dBm with 1 % VWC to about -95.1 dBm with 80 % VWC" (868 MHz, 0.3 m)."""


def _soil_rss(vwc, sand=0.5, clay=0.15):
    s = soil.Soil(sand=sand, clay=clay, vwc=vwc)
    loss = soil.soil_path_loss(F_SOIL_HZ, D_SOIL_M, s).path_loss_db
    return SOIL_868_BUDGET.received_power_dbm(loss)


def _composition_grid():
    """Sand and clay fractions 0, 0.1, ..., 1 with sand + clay <= 1 inside the Peplinski regression (sigma_eff > 0)."""
    sand, clay = np.meshgrid(np.round(np.arange(0, 1.01, 0.1), 10), np.round(np.arange(0, 1.01, 0.1), 10))
    sand, clay = sand.ravel(), clay.ravel()
    keep = sand + clay <= 1.0 + 1e-9
    sand, clay = sand[keep], clay[keep]
    sigma = soil.effective_conductivity_s_m(soil.Soil(sand=sand, clay=clay))
    return sand[sigma > 0], clay[sigma > 0]


def porosity_note(vwc: float, sand: float, clay: float) -> str:
    """The row note's porosity flag: non-empty when ``vwc`` exceeds the soil's porosity 1 - rho_b / rho_s."""
    s = soil.Soil(sand=sand, clay=clay, vwc=vwc)
    if not bool(s.exceeds_porosity):
        return ""
    return (f"{vwc * 100:g} % VWC exceeds this soil's porosity {float(s.porosity):.3f} (1 - {s.bulk_density_g_cm3:g} / "
            f"{s.particle_density_g_cm3:g} g/cm^3): more water than pore space, a slurry rather than a soil")


def _join(*parts: str) -> str:
    return "; ".join(p for p in parts if p)


def soil_rss() -> list[Check]:
    src = "thesis 5.1.2 (RSS about -54.5 dBm at 1 % and -95.1 dBm at 80 % VWC, 868 MHz, 0.3 m), eqs 5.1-5.3"
    (lo_vwc, lo_pub), (hi_vwc, hi_pub) = PUBLISHED_RSS_DBM.items()
    lo, hi = (float(v) for v in _soil_rss(np.array([lo_vwc, hi_vwc])))
    span_pub = lo_pub - hi_pub
    checks = [
        within_abs("soil: RSS at 1 % VWC, sandy loam [dBm]", src, lo, lo_pub, 3.0,
                   f"measured gap {lo - lo_pub:.1f} dB above the thesis: see the dBW hypothesis rows"),
        within_abs("soil: RSS at 80 % VWC, sandy loam [dBm]", src, hi, hi_pub, 3.0,
                   _join(f"measured gap {hi - hi_pub:.1f} dB above the thesis", porosity_note(hi_vwc, 0.5, 0.15))),
    ]
    sand, clay = _composition_grid()
    grid_spans = _soil_rss(lo_vwc, sand, clay) - _soil_rss(hi_vwc, sand, clay)
    k = int(np.argmax(grid_spans))
    checks.append(within_abs(
        "soil: RSS span 1 % -> 80 % VWC, sandy loam [dB]", src, lo - hi, span_pub, 3.0,
        _join(f"offset-free (a constant offset cancels in a span); the largest span over the sand/clay grid is "
              f"{grid_spans[k]:.1f} dB (sand {sand[k]:g}, clay {clay[k]:g}), so no soil of Figs 5.2-5.4 gives the "
              "published span", porosity_note(hi_vwc, 0.5, 0.15)),
    ))
    h_sand, h_clay = HYPOTHESIS_SOIL["sand"], HYPOTHESIS_SOIL["clay"]
    h_lo, h_hi = (float(v) for v in _soil_rss(np.array([lo_vwc, hi_vwc]), h_sand, h_clay))
    fitted = ((h_lo - lo_pub) + (h_hi - hi_pub)) / 2.0
    assumes = (f"hypothesis, assumes both: (1) one soil for both rows, sand {h_sand:g} / clay {h_clay:g} (the grid soil "
               f"whose span, {h_lo - h_hi:.1f} dB, is closest to the published {span_pub:.1f} dB; the thesis states no "
               f"composition), (2) a constant {DBW_OFFSET_DB:g} dB offset, the thesis's RSS being dBW labelled dBm "
               f"(not fitted: the constant that would fit this soil best is {fitted:.1f} dB)")
    checks += [
        within_abs(f"soil: RSS at 1 % VWC, clay (sand {h_sand:g}, clay {h_clay:g}), dBW hypothesis [dBm]", src,
                   h_lo - DBW_OFFSET_DB, lo_pub, 2.0, assumes, kind="hypothesis"),
        within_abs(f"soil: RSS at 80 % VWC, clay (sand {h_sand:g}, clay {h_clay:g}), dBW hypothesis [dBm]", src,
                   h_hi - DBW_OFFSET_DB, hi_pub, 2.0, _join(assumes, porosity_note(hi_vwc, h_sand, h_clay)),
                   kind="hypothesis"),
    ]
    return checks


CHECKS = [pipe_cutoffs, pipe_attenuation, pipe_budget_length, soil_rss]
