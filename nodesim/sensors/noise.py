"""Stochastic sensor error processes, vectorised over samples (and a leading batch axis).

All processes are sampled at a constant interval ``dt_s`` and drawn from a passed
:class:`numpy.random.Generator`; nothing here touches a global random state.

Conventions (IEEE Std 952-1997; thesis appendix V, eqs V.23, V.31-V.34).  ``S(f)`` is the two-sided rate
power spectral density evaluated at f >= 0, the form used in the spectral Allan variance
sigma^2(tau) = 4 int_0^inf S(f) sin^4(pi f tau) / (pi f tau)^2 df (V.23):

* white rate noise (angle random walk N): S = N^2, Allan variance N^2 / tau (V.31-V.32);  sampled at
  dt the per-sample standard deviation is N / sqrt(dt);
* first-order Gauss-Markov bias (sigma, T): b' = -b/T + w, stationary variance sigma^2, two-sided PSD
  2 sigma^2 T / (1 + (2 pi f T)^2) (thesis eqs 3.18-3.20), discretised exactly:
  b[k+1] = phi b[k] + sigma sqrt(1 - phi^2) w[k],  phi = exp(-dt/T);
* bias instability (flicker, coefficient B): S = B^2 / (2 pi f) (V.33), Allan floor 0.664 B (V.34).
  It is synthesised as a sum of Gauss-Markov processes with log-spaced correlation times T_i, each with
  variance sigma_i^2 = (B^2 / pi) dln(T).  Derivation: int 2 c T / (1 + (2 pi f T)^2) dln T = c / (2 f),
  which equals B^2 / (2 pi f) for c = B^2 / pi.  The spectrum is 1/f between about 1/(2 pi T_max) and
  1/(2 pi T_min) and flat (bounded variance) below, so the Allan floor holds for
  ~T_min << tau << ~T_max.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.signal import lfilter

FLICKER_PER_DECADE = 3
"""Gauss-Markov components per decade of correlation time in the flicker synthesis (ripple < ~3 %)."""


def white(rng: np.random.Generator, shape: tuple[int, ...], density: float, dt_s: float) -> np.ndarray:
    """White noise of two-sided PSD ``density**2`` sampled at ``dt_s``: sigma = density / sqrt(dt)."""
    return white_from_normals(rng.standard_normal(shape), density, dt_s)


def white_from_normals(w: np.ndarray, density: float, dt_s: float) -> np.ndarray:
    """:func:`white` from given standard normals ``w``, scaled in place (``w`` is returned)."""
    return np.multiply(density / math.sqrt(dt_s), w, out=w)


def gauss_markov(rng: np.random.Generator, shape: tuple[int, ...], sigma: float, tau_s: float, dt_s: float) -> np.ndarray:
    """Stationary first-order Gauss-Markov samples along the last axis (exact discretisation).

    The first sample is drawn from the stationary distribution N(0, sigma^2), the recursion runs in C
    (:func:`scipy.signal.lfilter` with the AR(1) denominator [1, -phi]).
    """
    if sigma == 0.0:
        return np.zeros(shape)
    return gauss_markov_from_normals(rng.standard_normal(shape), sigma, tau_s, dt_s)


def gauss_markov_from_normals(w: np.ndarray, sigma: float, tau_s: float, dt_s: float, axis: int = -1) -> np.ndarray:
    """:func:`gauss_markov` driven by given standard normals ``w`` (e.g. rows of (R, n), one realization's
    stream each), along ``axis`` (the last by default): x[0] = sigma w[0], x[k] = phi x[k-1] + sigma sqrt(1 - phi^2)
    w[k], phi = exp(-dt / tau)."""
    phi = math.exp(-dt_s / tau_s)
    drive = w * (sigma * math.sqrt(1.0 - phi * phi))
    first = [slice(None)] * w.ndim
    first[axis] = 0
    drive[tuple(first)] = sigma * w[tuple(first)]
    return lfilter([1.0], [1.0, -phi], drive, axis=axis)


def flicker_taus(tau_min_s: float, tau_max_s: float, per_decade: int = FLICKER_PER_DECADE) -> np.ndarray:
    """Log-spaced correlation times of the flicker synthesis, ``per_decade`` per decade, both ends included."""
    n = max(2, int(math.ceil(math.log10(tau_max_s / tau_min_s) * per_decade)) + 1)
    return np.geomspace(tau_min_s, tau_max_s, n)


def flicker(
    rng: np.random.Generator,
    shape: tuple[int, ...],
    b_coefficient: float,
    dt_s: float,
    tau_min_s: float,
    tau_max_s: float,
) -> np.ndarray:
    """Bias-instability (1/f) noise of IEEE coefficient ``b_coefficient`` along the last axis (see module doc)."""
    if b_coefficient == 0.0:
        return np.zeros(shape)
    taus = flicker_taus(tau_min_s, tau_max_s)
    dln = math.log(taus[1] / taus[0])
    # weight the end points by half a bin (trapezoid rule over ln T)
    weights = np.full(taus.size, dln)
    weights[[0, -1]] *= 0.5
    out = np.zeros(shape)
    for tau, wgt in zip(taus, weights):
        out += gauss_markov(rng, shape, b_coefficient * math.sqrt(wgt / math.pi), float(tau), dt_s)
    return out


def random_walk(rng: np.random.Generator, shape: tuple[int, ...], k_density: float, dt_s: float) -> np.ndarray:
    """Rate random walk of coefficient K (Allan variance K^2 tau / 3): cumulative sum of white increments."""
    if k_density == 0.0:
        return np.zeros(shape)
    return np.cumsum(k_density * math.sqrt(dt_s) * rng.standard_normal(shape), axis=-1)
