"""5 GHz inside the drill pipe: the steel tube as a circular waveguide (thesis 5.2, eqs 5.4-5.8).

Cutoff (eqs 5.4-5.5), with X'_mn the n-th zero of J'_m (TE) and X_mn the n-th zero of J_m (TM), computed by
``scipy.special.jnp_zeros`` / ``jn_zeros`` (the thesis tabulates them in Tables 5.2-5.3)::

    f_c = X / (2 pi a sqrt(mu eps)),   mu = mu0 mu_r,  eps = eps0 eps_r of the filling

Conductor attenuation (eqs 5.6-5.8, the standard Pozar / Balanis forms), eta the filling's wave impedance::

    alpha_TE,mn = R_s / (a eta sqrt(1 - (f_c/f)^2)) * [(f_c/f)^2 + m^2 / (X'_mn^2 - m^2)]    Np/m
    alpha_TM,mn = R_s / (a eta sqrt(1 - (f_c/f)^2))                                         Np/m
    R_s = sqrt(pi f mu0 mu_r,wall rho)

Dielectric loss of a filling with loss tangent tan_d (Pozar eq 3.29):
``alpha_d = k^2 tan_d / (2 beta)``, k = 2 pi f sqrt(mu_r eps_r) / c, beta = sqrt(k^2 - k_c^2).

Cross-checked against scikit-rf's ``CircularWaveguide`` (tests/channel/test_waveguide.py): cutoffs and
conductor attenuation agree to 1e-6 for air filling; skrf divides by the free-space eta0 even for a filled
guide and puts the filling's mu (not the wall's) into R_s, so with a dielectric filling ours = skrf * sqrt(eps_r).

At or below a mode's cutoff the mode does not propagate: the vectorised functions return ``inf`` there and
the link functions raise ChannelError saying which cutoff the frequency is below.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from channel._validate import check_positive, check_range
from channel.constants import C0_M_S, ETA0_OHM, MU0_H_M, NP_TO_DB
from channel.errors import ChannelError
from channel.soil import water_permittivity


@dataclass(frozen=True, order=True)
class Mode:
    """A circular-waveguide mode: kind 'TE' or 'TM', azimuthal index m >= 0, radial index n >= 1."""

    kind: str
    m: int
    n: int

    def __post_init__(self) -> None:
        if self.kind not in ("TE", "TM"):
            raise ChannelError(f"mode kind must be 'TE' or 'TM' (got {self.kind!r})")
        if self.m < 0 or self.n < 1:
            raise ChannelError(f"mode indices must have m >= 0 and n >= 1 (got m={self.m}, n={self.n})")

    @property
    def name(self) -> str:
        return f"{self.kind}{self.m}{self.n}" if self.m < 10 and self.n < 10 else f"{self.kind}{self.m},{self.n}"

    @property
    def bessel_zero(self) -> float:
        """X'_mn (TE) or X_mn (TM)."""
        return _zero(self.kind, self.m, self.n)

    @classmethod
    def parse(cls, text: str) -> "Mode":
        """'TE11', 'tm01', 'TE1,2' -> Mode."""
        t = text.strip().upper()
        kind, rest = t[:2], t[2:]
        try:
            m, n = (int(v) for v in rest.split(",")) if "," in rest else (int(rest[0]), int(rest[1:]))
        except (ValueError, IndexError) as err:
            raise ChannelError(f"mode must look like TE11 or TM01 (got {text!r})") from err
        return cls(kind, m, n)


@lru_cache(maxsize=None)
def _zero(kind: str, m: int, n: int) -> float:
    from scipy.special import jn_zeros, jnp_zeros  # here, not at module top: importing channel stays cheap

    return float((jnp_zeros if kind == "TE" else jn_zeros)(m, n)[-1])


TE11 = Mode("TE", 1, 1)
TM01 = Mode("TM", 0, 1)
TE21 = Mode("TE", 2, 1)
TE01 = Mode("TE", 0, 1)


@dataclass(frozen=True)
class Filling:
    """What fills the bore: relative permittivity, loss tangent, relative permeability."""

    name: str = "air"
    eps_r: float = 1.0
    loss_tangent: float = 0.0
    mu_r: float = 1.0

    def __post_init__(self) -> None:
        check_range("eps_r", self.eps_r, 1.0, None)
        check_range("loss_tangent", self.loss_tangent, 0.0, None)
        check_positive("mu_r", self.mu_r)


AIR = Filling("air", 1.0, 0.0, 1.0)


def water_filling(f_hz, temperature_c=20.0) -> Filling:
    """Fresh water at ``f_hz`` from the Debye model shared with the soil module (no ionic conductivity).

    Arrays are allowed (one filling per frequency of a sweep)."""
    e1, e2 = water_permittivity(f_hz, temperature_c)
    return Filling("water", e1, e2 / e1, 1.0)


def modes_by_cutoff(m_max: int = 6, n_max: int = 3) -> list[Mode]:
    """Every TE and TM mode with m <= m_max and n <= n_max, sorted by cutoff (TE11, TM01, TE21, TE01/TM11, ...)."""
    modes = [Mode(k, m, n) for k in ("TE", "TM") for m in range(m_max + 1) for n in range(1, n_max + 1)]
    return sorted(modes, key=lambda md: (md.bessel_zero, md.kind, md.m, md.n))


def cutoff_frequency_hz(mode: Mode, radius_m, eps_r=1.0, mu_r=1.0):
    """Thesis eqs 5.4-5.5: f_c = X / (2 pi a sqrt(mu eps)), vectorised over radius and filling."""
    a = check_positive("radius_m", radius_m, "m")
    er = check_range("eps_r", eps_r, 1.0, None)
    mr = check_positive("mu_r", mu_r)
    return mode.bessel_zero * C0_M_S / (2.0 * np.pi * a * np.sqrt(er * mr))


def propagating_modes(f_hz: float, radius_m: float, filling: Filling = AIR, m_max: int = 12, n_max: int = 6):
    """Modes with f_c < f, lowest cutoff first; empty when f is below the TE11 cutoff."""
    f = float(check_positive("frequency_hz", f_hz, "Hz"))
    out = [md for md in modes_by_cutoff(m_max, n_max)
           if cutoff_frequency_hz(md, radius_m, filling.eps_r, filling.mu_r) < f]
    return out


def surface_resistance_ohm(f_hz, resistivity_ohm_m, mu_r_wall=1.0):
    """Thesis eq 5.8: R_s = sqrt(pi f mu0 mu_r rho) [Ohm]."""
    f = check_positive("frequency_hz", f_hz, "Hz")
    rho = check_positive("resistivity_ohm_m", resistivity_ohm_m, "Ohm*m")
    mu = check_positive("mu_r_wall", mu_r_wall)
    return np.sqrt(np.pi * f * MU0_H_M * mu * rho)


def conductor_attenuation_np_per_m(mode: Mode, f_hz, radius_m, resistivity_ohm_m, mu_r_wall=1.0,
                                   filling: Filling = AIR):
    """Thesis eqs 5.6-5.7 [Np/m]; ``inf`` where f <= f_c (the mode is cut off)."""
    f = check_positive("frequency_hz", f_hz, "Hz")
    a = check_positive("radius_m", radius_m, "m")
    rs = surface_resistance_ohm(f, resistivity_ohm_m, mu_r_wall)
    fc = cutoff_frequency_hz(mode, a, filling.eps_r, filling.mu_r)
    eta = ETA0_OHM * np.sqrt(filling.mu_r / filling.eps_r)
    ratio2 = (fc / f) ** 2
    with np.errstate(divide="ignore", invalid="ignore"):
        base = rs / (a * eta * np.sqrt(1.0 - ratio2))
    if mode.kind == "TE":
        x = mode.bessel_zero
        base = base * (ratio2 + mode.m**2 / (x**2 - mode.m**2))
    return np.where(ratio2 < 1.0, base, np.inf)


def dielectric_attenuation_np_per_m(mode: Mode, f_hz, radius_m, filling: Filling = AIR):
    """Pozar eq 3.29: alpha_d = k^2 tan_d / (2 beta) [Np/m]; ``inf`` where the mode is cut off."""
    f = check_positive("frequency_hz", f_hz, "Hz")
    a = check_positive("radius_m", radius_m, "m")
    k = 2.0 * np.pi * f * np.sqrt(filling.eps_r * filling.mu_r) / C0_M_S
    kc = mode.bessel_zero / a
    beta2 = k**2 - kc**2
    with np.errstate(divide="ignore", invalid="ignore"):
        alpha = k**2 * filling.loss_tangent / (2.0 * np.sqrt(beta2))
    return np.where(beta2 > 0, alpha, np.inf)


def attenuation_db_per_m(mode: Mode, f_hz, radius_m, resistivity_ohm_m, mu_r_wall=1.0, filling: Filling = AIR):
    """Conductor + dielectric attenuation of ``mode`` in dB/m (``inf`` below cutoff)."""
    total = conductor_attenuation_np_per_m(mode, f_hz, radius_m, resistivity_ohm_m, mu_r_wall, filling) \
        + dielectric_attenuation_np_per_m(mode, f_hz, radius_m, filling)
    return NP_TO_DB * total


def require_propagation(f_hz: float, radius_m: float, filling: Filling = AIR, mode: Mode = TE11) -> None:
    """Raise ChannelError when ``mode`` (default the dominant TE11) does not propagate at ``f_hz``."""
    fc = float(cutoff_frequency_hz(mode, radius_m, filling.eps_r, filling.mu_r))
    if not float(f_hz) > fc:
        what = "no mode propagates" if mode == TE11 else f"{mode.name} does not propagate"
        raise ChannelError(
            f"frequency_hz {float(f_hz):.4g} Hz is at or below the {mode.name} cutoff {fc:.4g} Hz of a "
            f"{float(radius_m) * 100:g} cm radius {filling.name}-filled pipe: {what}; raise frequency_hz above "
            f"{fc:.4g} Hz or radius_m above {float(radius_m) * fc / float(f_hz):.4g} m"
        )
