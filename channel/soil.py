"""868 MHz through moist soil: Peplinski dielectric model, propagation constants, modified Friis path loss.

Sources
-------
* Thesis chapter 5.1, eqs 5.1-5.3 (Vuran & Akyildiz's modified Friis equation, the thesis's ref. [31]):
  ``L_p = 6.4 + 20 log10 d + 20 log10 beta + 8.69 alpha d``  [dB], d in m, beta in rad/m, alpha in Np/m.
  It is the free-space loss 20 log10(4 pi d / lambda0) plus 20 log10(lambda0 / lambda_soil) plus the
  attenuation 8.69 alpha d, i.e. exactly ``20 log10(2 beta d) + 8.686 alpha d``: the exact constant is
  20 log10 2 = 6.02 dB; the published 6.4 comes from rounding 20 log10(c / 2 pi) = 153.6 up to 154.  We keep
  6.4 as the default (the thesis's equation) and expose it as ``constant_db``; with 6.02 the model tends to
  the Friis free-space loss when alpha -> 0 and eps_r -> 1.
* Dielectric model (not printed in the thesis; it is the model of the cited Vuran & Akyildiz paper):
  Peplinski, Ulaby & Dobson (1995), the 0.3-1.3 GHz correction of Dobson et al. (1985)::

      eps'  = 1.15 [1 + (rho_b/rho_s)(eps_s^a - 1) + m_v^beta1 eps'_fw^a - m_v]^(1/a) - 0.68
      eps'' = [m_v^beta2 eps''_fw^a]^(1/a),      a = 0.65
      beta1 = 1.2748 - 0.519 S - 0.152 C,  beta2 = 1.33797 - 0.603 S - 0.166 C
      eps_s = (1.01 + 0.44 rho_s)^2 - 0.062,  sigma_eff = 0.0467 + 0.2204 rho_b - 0.4111 S + 0.6614 C  [S/m]
      eps'_fw  = eps_w_inf + (eps_w0 - eps_w_inf) / (1 + (2 pi f tau_w)^2)
      eps''_fw = 2 pi f tau_w (eps_w0 - eps_w_inf) / (1 + (2 pi f tau_w)^2)
                 + sigma_eff (rho_s - rho_b) / (2 pi eps0 f rho_s m_v)

  S and C are sand and clay mass fractions, m_v the volumetric water content, densities in g/cm^3.
  Free water: eps_w_inf = 4.9 and Stogryn's temperature fits (as given by Ulaby, Moore & Fung)
  eps_w0(T) = 88.045 - 0.4147 T + 6.295e-4 T^2 + 1.075e-5 T^3 and
  2 pi tau_w(T) = 1.1109e-10 - 3.824e-12 T + 6.938e-14 T^2 - 5.096e-16 T^3 s; at 20 degC they give
  Peplinski's constants 80.1 and 0.58e-10 s.  Validity: 0.3-1.3 GHz (enforced), 0-40 degC (enforced).
* alpha, beta of a lossy non-magnetic medium (standard plane-wave result):
  ``alpha, beta = omega sqrt(mu eps0 eps'/2 [sqrt(1 + (eps''/eps')^2) -/+ 1])``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from channel._validate import as_float_array, check_positive, check_range
from channel.constants import C0_M_S, EPS0_F_M, NP_TO_DB
from channel.errors import ChannelError

PEPLINSKI_F_MIN_HZ = 0.3e9
PEPLINSKI_F_MAX_HZ = 1.3e9
"""Frequency range of the Peplinski (1995) correction; outside it the model raises ChannelError."""

WATER_T_MIN_C = 0.0
WATER_T_MAX_C = 40.0
"""Temperature range of the free-water fits used here."""

THESIS_PATH_LOSS_CONSTANT_DB = 6.4
"""The constant of thesis eq 5.2 (Vuran & Akyildiz); the exact value is 20 log10(2) = 6.02 dB."""

EXACT_PATH_LOSS_CONSTANT_DB = float(20.0 * np.log10(2.0))

_A = 0.65
_EPS_W_INF = 4.9


@dataclass(frozen=True)
class Soil:
    """A soil sample: mass fractions, water content, densities and temperature (floats or broadcastable arrays).

    Defaults: the sandy loam of the Vuran & Akyildiz evaluations (sand 0.50, clay 0.15, bulk density 1.5,
    particle density 2.66 g/cm^3) at 20 degC and 20 % volumetric water content.
    """

    sand: float = 0.5
    clay: float = 0.15
    vwc: float = 0.2
    bulk_density_g_cm3: float = 1.5
    particle_density_g_cm3: float = 2.66
    temperature_c: float = 20.0

    def __post_init__(self) -> None:
        sand = check_range("sand", self.sand, 0.0, 1.0)
        clay = check_range("clay", self.clay, 0.0, 1.0)
        if np.any(sand + clay > 1.0 + 1e-12):
            raise ChannelError(f"sand + clay must be <= 1 (got {float(np.max(sand + clay)):g})")
        check_range("vwc", self.vwc, 0.0, 1.0, lo_open=True)
        rho_s = check_positive("particle_density_g_cm3", self.particle_density_g_cm3, "g/cm^3")
        rho_b = check_positive("bulk_density_g_cm3", self.bulk_density_g_cm3, "g/cm^3")
        if np.any(rho_b >= rho_s):
            raise ChannelError(
                f"bulk_density_g_cm3 must be < particle_density_g_cm3 (got {float(np.max(rho_b)):g} >= "
                f"{float(np.min(rho_s)):g})"
            )
        check_range("temperature_c", self.temperature_c, WATER_T_MIN_C, WATER_T_MAX_C, unit="degC")

    @property
    def porosity(self):
        """1 - rho_b / rho_s: the largest physically possible volumetric water content."""
        return 1.0 - np.asarray(self.bulk_density_g_cm3, float) / np.asarray(self.particle_density_g_cm3, float)

    @property
    def exceeds_porosity(self):
        """True where vwc > porosity (the thesis's 80 % VWC case: a slurry, not a soil)."""
        return np.asarray(self.vwc, float) > self.porosity


def water_permittivity(f_hz, temperature_c=20.0, eps_inf: float = _EPS_W_INF):
    """Debye free-water permittivity (eps', eps'') without the conductivity term; Stogryn's T fits."""
    f = check_positive("frequency_hz", f_hz, "Hz")
    t = check_range("temperature_c", temperature_c, WATER_T_MIN_C, WATER_T_MAX_C, unit="degC")
    eps_w0 = 88.045 - 0.4147 * t + 6.295e-4 * t**2 + 1.075e-5 * t**3
    two_pi_tau = 1.1109e-10 - 3.824e-12 * t + 6.938e-14 * t**2 - 5.096e-16 * t**3
    x = f * two_pi_tau
    denom = 1.0 + x**2
    return eps_inf + (eps_w0 - eps_inf) / denom, x * (eps_w0 - eps_inf) / denom


def effective_conductivity_s_m(soil: Soil):
    """Peplinski's sigma_eff [S/m] (0.3-1.3 GHz regression)."""
    return 0.0467 + 0.2204 * np.asarray(soil.bulk_density_g_cm3, float) - 0.4111 * np.asarray(soil.sand, float) \
        + 0.6614 * np.asarray(soil.clay, float)


def soil_permittivity(f_hz, soil: Soil):
    """Relative complex permittivity (eps', eps'') of moist soil, Peplinski et al. 1995 (module docstring)."""
    f = check_range("frequency_hz", f_hz, PEPLINSKI_F_MIN_HZ, PEPLINSKI_F_MAX_HZ, unit="Hz (Peplinski validity)")
    sand = np.asarray(soil.sand, float)
    clay = np.asarray(soil.clay, float)
    mv = np.asarray(soil.vwc, float)
    rho_b = np.asarray(soil.bulk_density_g_cm3, float)
    rho_s = np.asarray(soil.particle_density_g_cm3, float)
    sigma = effective_conductivity_s_m(soil)
    if np.any(sigma <= 0):
        raise ChannelError(
            "sand/clay/bulk_density give a non-positive Peplinski effective conductivity "
            f"(min {float(np.min(sigma)):.3g} S/m): outside the model's regression range; use more clay or less sand "
            "(sigma_eff = 0.0467 + 0.2204 rho_b - 0.4111 sand + 0.6614 clay must be > 0)"
        )
    beta1 = 1.2748 - 0.519 * sand - 0.152 * clay
    beta2 = 1.33797 - 0.603 * sand - 0.166 * clay
    eps_s = (1.01 + 0.44 * rho_s) ** 2 - 0.062
    efw1, efw2 = water_permittivity(f, soil.temperature_c)
    efw2 = efw2 + sigma * (rho_s - rho_b) / (2.0 * np.pi * EPS0_F_M * f * rho_s * mv)
    inner = 1.0 + (rho_b / rho_s) * (eps_s**_A - 1.0) + mv**beta1 * efw1**_A - mv
    eps_real = 1.15 * inner ** (1.0 / _A) - 0.68
    eps_imag = (mv**beta2 * efw2**_A) ** (1.0 / _A)
    return eps_real, eps_imag


def propagation_constants(f_hz, eps_real, eps_imag, mu_r=1.0):
    """Attenuation alpha [Np/m] and phase constant beta [rad/m] of a lossy medium (module docstring)."""
    f = check_positive("frequency_hz", f_hz, "Hz")
    e1 = check_positive("eps_real", eps_real)
    e2 = check_range("eps_imag", eps_imag, 0.0, None)
    mu = check_positive("mu_r", mu_r)
    k = 2.0 * np.pi * f / C0_M_S * np.sqrt(mu * e1 / 2.0)
    tan2 = np.square(e2 / e1)
    root = np.sqrt(1.0 + tan2)
    # root - 1 written as tan^2 / (root + 1): no cancellation for tiny loss tangents (alpha would round to 0)
    return k * np.sqrt(tan2 / (root + 1.0)), k * np.sqrt(root + 1.0)


def free_space_path_loss_db(distance_m, f_hz):
    """Friis free-space loss 20 log10(4 pi d f / c) [dB] between isotropic antennas."""
    d = check_positive("distance_m", distance_m, "m")
    f = check_positive("frequency_hz", f_hz, "Hz")
    return 20.0 * np.log10(4.0 * np.pi * d * f / C0_M_S)


def modified_friis_path_loss_db(distance_m, alpha_np_per_m, beta_rad_per_m,
                                constant_db: float = THESIS_PATH_LOSS_CONSTANT_DB):
    """Thesis eq 5.2: L_p = constant + 20 log10 d + 20 log10 beta + 8.686 alpha d  [dB]."""
    d = check_positive("distance_m", distance_m, "m")
    alpha = check_range("alpha_np_per_m", alpha_np_per_m, 0.0, None)
    beta = check_positive("beta_rad_per_m", beta_rad_per_m)
    return constant_db + 20.0 * np.log10(d) + 20.0 * np.log10(beta) + NP_TO_DB * alpha * d


@dataclass(frozen=True)
class SoilPathLoss:
    """Result of :func:`soil_path_loss` (arrays broadcast over the inputs)."""

    eps_real: np.ndarray
    eps_imag: np.ndarray
    alpha_np_per_m: np.ndarray
    beta_rad_per_m: np.ndarray
    path_loss_db: np.ndarray
    exceeds_porosity: np.ndarray


def soil_path_loss(f_hz, distance_m, soil: Soil, constant_db: float = THESIS_PATH_LOSS_CONSTANT_DB) -> SoilPathLoss:
    """Peplinski permittivity -> alpha, beta -> modified Friis path loss (thesis eqs 5.2-5.3), vectorised."""
    eps_real, eps_imag = soil_permittivity(f_hz, soil)
    alpha, beta = propagation_constants(f_hz, eps_real, eps_imag)
    loss = modified_friis_path_loss_db(distance_m, alpha, beta, constant_db)
    return SoilPathLoss(eps_real, eps_imag, alpha, beta, loss, np.broadcast_to(soil.exceeds_porosity, loss.shape))


def max_distance_m(max_path_loss_db, alpha_np_per_m, beta_rad_per_m,
                   constant_db: float = THESIS_PATH_LOSS_CONSTANT_DB):
    """Largest d with L_p(d) <= max_path_loss_db (L_p is increasing in d), in closed form.

    Solving constant + 20 log10(beta d) + 8.686 alpha d = L for d: with u = ln 10 / 20 and
    since 8.686 u = 1,
    ln(beta d) + alpha d = u (L - constant), hence d = W(alpha/beta * exp(u (L - constant))) / alpha (Lambert W,
    principal branch); d = exp(u (L - constant)) / beta when alpha = 0.
    """
    from scipy.special import lambertw  # here, not at module top: importing channel stays cheap

    loss = as_float_array("max_path_loss_db", max_path_loss_db)
    alpha = check_range("alpha_np_per_m", alpha_np_per_m, 0.0, None)
    beta = check_positive("beta_rad_per_m", beta_rad_per_m)
    log_bd = (loss - constant_db) * np.log(10.0) / 20.0
    lossless = np.exp(log_bd) / beta
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        arg = alpha / beta * np.exp(log_bd)
        lossy = np.real(lambertw(arg)) / alpha
        # tiny alpha d: W(x) = x - x^2 + 1.5 x^3 - ... keeps full precision where W(x)/alpha would not
        lossy = np.where(arg < 1e-4, lossless * (1.0 - arg + 1.5 * arg**2 - 8.0 / 3.0 * arg**3), lossy)
    # exp() overflows only for absurd budgets; there the attenuation term dominates: d ~ (log_bd - ln(beta d))/alpha
    big = ~np.isfinite(arg)
    if np.any(big):
        approx = log_bd / np.where(alpha > 0, alpha, 1.0)
        for _ in range(4):
            approx = (log_bd - np.log(beta * approx)) / np.where(alpha > 0, alpha, 1.0)
        lossy = np.where(big, approx, lossy)
    return np.where(alpha > 0, lossy, lossless)
