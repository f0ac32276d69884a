"""Wall resistivity of API 5L carbon-steel drill pipe versus temperature and carbon content.

The thesis (5.2.2, Table 5.1, Fig. 5.9) states that the resistivity depends strongly on the carbon content
(0.06-1.22 wt %) and rises with temperature, and shows the dependence only as a figure from its ref. [42].
This module therefore uses a documented handbook-anchored model (an assumption, not the thesis's curve):

    rho(T, C) = [rho_1020 + k_C (C - 0.20)] * g(T) / g(20 degC),     g(T) = 1 + a1 T + a2 T^2   (T in degC)

* Temperature shape g(T): the three ASM Metals Handbook values for annealed AISI 1020 (0.159, 0.219 and
  0.292 uOhm*m at 0, 100 and 200 degC) are fitted exactly: a1 = 3.36e-3 /K, a2 = 4.1e-6 /K^2.
  Range enforced: -20 to 400 degC (beyond 200 degC it is an extrapolation; the BHA may exceed 200 degC).
* rho_1020 = 0.159 uOhm*m * g(20)/g(0) = 0.170 uOhm*m at 20 degC for 0.20 wt % C.
* Carbon slope k_C = 0.27 uOhm*m per wt % C: from AISI 1010 (0.10 % C, 0.143 uOhm*m at 20 degC) and the
  1020 value above (Matthiessen's rule: carbon adds resistivity linearly at low content).  The rule saturates
  above ~0.4 % C (AISI 1080 ~ 0.18 uOhm*m), so carbon is restricted to 0.05-0.40 wt %, which covers every
  API 5L grade of thesis Table 5.1 (0.21-0.31 wt %).

Example: 0.26 wt % C (API 5L X60 / B ERW) gives 0.186 uOhm*m at 20 degC and 0.320 uOhm*m at 200 degC.
Ferromagnetism of the wall (mu_r at 5 GHz) is a separate parameter of the waveguide model (default 1).
"""

from __future__ import annotations

from channel._validate import check_range
from channel.errors import ChannelError

API5L_CARBON_WT_PCT = {
    "A25": 0.21,
    "A SMLS": 0.22,
    "B SMLS": 0.27,
    "A ERW": 0.21,
    "B ERW": 0.26,
    "X42 SMLS": 0.29,
    "X46 SMLS": 0.31,
    "X52 SMLS": 0.31,
    "X60 SMLS": 0.26,
    "X42 ERW": 0.28,
    "X46 ERW": 0.30,
    "X52 ERW": 0.30,
    "X60 ERW": 0.26,
}
"""Maximum carbon content [wt %] of API 5L grades, thesis Table 5.1."""

DEFAULT_CARBON_WT_PCT = 0.26
"""A typical API 5L grade (B ERW, X60): the 'typical carbon content' of thesis 5.2.5."""

CARBON_MIN_WT_PCT = 0.05
CARBON_MAX_WT_PCT = 0.40
T_MIN_C = -20.0
T_MAX_C = 400.0

_A1_PER_K = 3.36e-3
_A2_PER_K2 = 4.1e-6
_RHO_1020_0C_OHM_M = 0.159e-6
_K_C_OHM_M_PER_WT_PCT = 0.27e-6


def _g(t_c):
    return 1.0 + _A1_PER_K * t_c + _A2_PER_K2 * t_c**2


RHO_1020_20C_OHM_M = _RHO_1020_0C_OHM_M * _g(20.0) / _g(0.0)


def carbon_steel_resistivity_ohm_m(temperature_c=20.0, carbon_wt_pct=DEFAULT_CARBON_WT_PCT):
    """Resistivity [Ohm*m] of plain carbon steel (module docstring model), vectorised."""
    t = check_range("temperature_c", temperature_c, T_MIN_C, T_MAX_C, unit="degC")
    c = check_range("carbon_wt_pct", carbon_wt_pct, CARBON_MIN_WT_PCT, CARBON_MAX_WT_PCT, unit="wt %")
    rho20 = RHO_1020_20C_OHM_M + _K_C_OHM_M_PER_WT_PCT * (c - 0.20)
    return rho20 * _g(t) / _g(20.0)


def grade_carbon_wt_pct(grade: str) -> float:
    """Carbon content of an API 5L grade of thesis Table 5.1 (e.g. 'X60 SMLS')."""
    key = " ".join(grade.upper().replace("-", "").split())
    if key not in API5L_CARBON_WT_PCT:
        raise ChannelError(f"grade must be one of {sorted(API5L_CARBON_WT_PCT)} (got {grade!r})")
    return API5L_CARBON_WT_PCT[key]
