"""Monte Carlo uncertainty of the MSA-corrected final position and MSA parameters (HV Ch 4-5, SV 2.1).

Per replication m (HV 8.1 of the digest; vectorised over replications, in chunks):

1. draw dB ~ N(0, sigma_B^2) and dDip ~ N(0, sigma_dip^2) once (constant over the stations; HV scenarios
   2-4), and noise n ~ N(0, sigma_n^2) per axis per station;
2. B_m = s * B_c + b + n (HV 3.1) from the clean triads of the modelled survey and the *true* reference;
3. MSA against the erroneous reference B* = B + dB, dip* = dip + dDip from ``n_starts`` starts at
   truth + U(-0.25, 0.25) (HV Table 8), keeping the lowest L;
4. correct (HV 3.2), convert to a survey (HV 3.7-3.9), minimum curvature to the final position.

Statistics (HV Ch 4): unbiased sample standard deviation b_M per component; the reported spread is
k * b_M with k = 1.96 (HV, "95 % uncertainty deviation") or 3 (SV, "3*Stdev").  The relative standard
error of b_M from M normal replications is about 1/sqrt(2 (M - 1)) (8 % at M = 300).
"""

from __future__ import annotations

import sys
from dataclasses import dataclass

import numpy as np

from nodesim.errors import NodesimError
from nodesim.ground.magnetic_survey import FieldReference, apply_errors, correct, survey_from_readings, tool_readings
from nodesim.ground.msa import N_PARAMS, SolverOptions, solve_batch
from nodesim.ground.msa_surveys import Trajectory
from nodesim.ground.wellpath import displacements
from nodesim.units import DEG


@dataclass(frozen=True)
class MonteCarloConfig:
    """Noise and reference-error magnitudes (1 sigma), replications, starts and seed.

    HV scenario 1: noise 3.3 nT, no reference error; 2: + sigma_B 107 nT; 3: + sigma_dip 0.16 deg;
    4: as 3 with noise 0.3 nT (HV Table 8).  SV: noise 70 nT, sigma_B 107 nT, sigma_dip 0.16 deg."""

    noise_nt: float = 3.3
    sigma_b_nt: float = 0.0
    sigma_dip_deg: float = 0.0
    replications: int = 300
    n_starts: int = 1
    start_spread: float = 0.25
    seed: int = 0
    chunk: int = 100
    k_sigma: float = 1.96

    def __post_init__(self):
        for name in ("noise_nt", "sigma_b_nt", "sigma_dip_deg", "start_spread"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v >= 0.0):
                raise NodesimError(f"magnetic Monte Carlo: {name} = {v} must be finite and >= 0")
        if self.replications < 2:
            raise NodesimError(f"magnetic Monte Carlo: replications = {self.replications} must be >= 2")
        if self.n_starts < 1 or self.chunk < 1:
            raise NodesimError("magnetic Monte Carlo: n_starts and chunk must be >= 1")
        if not (np.isfinite(self.k_sigma) and self.k_sigma > 0.0):
            raise NodesimError(f"magnetic Monte Carlo: k_sigma = {self.k_sigma} must be > 0")


HV_SCENARIOS = {
    1: MonteCarloConfig(noise_nt=3.3),
    2: MonteCarloConfig(noise_nt=3.3, sigma_b_nt=107.0),
    3: MonteCarloConfig(noise_nt=3.3, sigma_b_nt=107.0, sigma_dip_deg=0.16),
    4: MonteCarloConfig(noise_nt=0.3, sigma_b_nt=107.0, sigma_dip_deg=0.16),
}
"""HV Table 8 scenarios (B = 51 uT, dip 72 deg; truth s = (1.1, 0.95, 1.25), b = (0.25, 0.295, -0.335) uT)."""


@dataclass(frozen=True, eq=False)
class MonteCarloResult:
    """Per-replication MSA parameters (M, 6), costs, convergence and corrected final positions (M, 3)."""

    config: MonteCarloConfig
    truth: np.ndarray
    modelled_final_nev_m: np.ndarray
    uncorrected_final_nev_m: np.ndarray
    theta: np.ndarray
    cost: np.ndarray
    converged: np.ndarray
    final_nev_m: np.ndarray

    @property
    def position_spread_m(self) -> np.ndarray:
        """k * sample std of the corrected final N, E, V [m]."""
        return self.config.k_sigma * np.std(self.final_nev_m, axis=0, ddof=1)

    @property
    def theta_spread(self) -> np.ndarray:
        """k * sample std of (b_x, b_y, b_z [uT], s_x, s_y, s_z)."""
        return self.config.k_sigma * np.std(self.theta, axis=0, ddof=1)

    @property
    def mean_position_error_m(self) -> np.ndarray:
        return np.mean(self.final_nev_m, axis=0) - self.modelled_final_nev_m

    @property
    def sampling_rel_error(self) -> float:
        """Relative standard error of a sample standard deviation, 1/sqrt(2 (M - 1))."""
        return 1.0 / np.sqrt(2.0 * (self.theta.shape[0] - 1))

    def as_dict(self) -> dict:
        return {
            "replications": int(self.theta.shape[0]),
            "k_sigma": self.config.k_sigma,
            "position_spread_m": self.position_spread_m.tolist(),
            "bias_spread_ut": self.theta_spread[:3].tolist(),
            "scale_spread": self.theta_spread[3:].tolist(),
            "mean_position_error_m": self.mean_position_error_m.tolist(),
            "uncorrected_final_nev_m": self.uncorrected_final_nev_m.tolist(),
            "converged_fraction": float(np.mean(self.converged)),
        }


def final_positions(md_m, inc_rad, azi_rad) -> np.ndarray:
    """Minimum-curvature final N, E, V relative to the first station, batched: inc/azi (..., n) -> (..., 3)."""
    return np.sum(displacements(md_m, inc_rad, azi_rad, "minimum_curvature"), axis=-2)


def _progress(total: int, enabled: bool | None):
    """A tqdm bar over replications on stderr when stderr is a terminal (or ``enabled`` is True), else None;
    stdout stays for results (``--json``)."""
    show = sys.stderr.isatty() if enabled is None else enabled
    if not show:
        return None
    from tqdm import tqdm

    return tqdm(total=total, unit="rep", desc="magnetic Monte Carlo", file=sys.stderr)


def run_monte_carlo(
    traj: Trajectory,
    reference: FieldReference,
    truth,
    config: MonteCarloConfig = MonteCarloConfig(),
    progress: bool | None = None,
    options: SolverOptions = SolverOptions(),
) -> MonteCarloResult:
    """Monte Carlo of MSA + MCM on one modelled survey (vectorised over each chunk of replications).

    Results depend only on (inputs, seed): all random numbers are drawn before the chunked solve."""
    truth = np.asarray(truth, dtype=float)
    if truth.shape != (N_PARAMS,) or np.any(truth[3:] <= 0):
        raise NodesimError("magnetic Monte Carlo: truth must be (b_x, b_y, b_z, s_x, s_y, s_z) with s > 0")
    g, b_clean = tool_readings(traj.toolface_deg, traj.inc_deg, traj.azi_deg, reference)
    u = g / np.linalg.norm(g, axis=-1, keepdims=True)
    md = traj.md_m
    modelled = final_positions(md, traj.inc_deg * DEG, traj.azi_deg * DEG)
    clean_m = apply_errors(b_clean, truth)
    raw = survey_from_readings(g, clean_m)
    uncorrected = final_positions(md, raw.inc_rad, raw.azi_rad)
    rng = np.random.default_rng(config.seed)
    m_total, k = config.replications, config.n_starts
    # every random number is drawn up front, so the result does not depend on the chunk size
    noise_all = rng.standard_normal((m_total,) + b_clean.shape) * (config.noise_nt * 1e-3)
    b_star_all = reference.b_total_ut + rng.standard_normal(m_total) * (config.sigma_b_nt * 1e-3)
    dip_star_all = (reference.dip_deg + rng.standard_normal(m_total) * config.sigma_dip_deg) * DEG
    starts_all = truth + rng.uniform(-config.start_spread, config.start_spread, size=(m_total, k, N_PARAMS))
    starts_all[..., 3:] = np.maximum(starts_all[..., 3:], 0.05)
    thetas, costs, convs, finals = [], [], [], []
    bar = _progress(m_total, progress)
    done = 0
    while done < m_total:
        m = min(config.chunk, m_total - done)
        sl = slice(done, done + m)
        noise, b_star, dip_star, starts = noise_all[sl], b_star_all[sl], dip_star_all[sl], starts_all[sl]
        b_m = clean_m + noise
        theta, cost, _, conv = solve_batch(
            starts.reshape(m * k, N_PARAMS),
            u,
            np.repeat(b_m, k, axis=0),
            np.repeat(b_star * np.cos(dip_star), k),
            np.repeat(b_star * np.sin(dip_star), k),
            options,
        )
        best = np.argmin(cost.reshape(m, k), axis=1)
        pick = np.arange(m) * k + best
        theta, cost, conv = theta[pick], cost[pick], conv[pick]
        corr = survey_from_readings(g, correct(b_m, theta), check=False)
        finals.append(final_positions(md, corr.inc_rad, corr.azi_rad))
        thetas.append(theta)
        costs.append(cost)
        convs.append(conv)
        done += m
        if bar is not None:
            bar.update(m)
    if bar is not None:
        bar.close()
    return MonteCarloResult(
        config,
        truth,
        modelled,
        uncorrected,
        np.concatenate(thetas),
        np.concatenate(costs),
        np.concatenate(convs),
        np.concatenate(finals),
    )


def run_monte_carlo_loop(traj, reference, truth, config: MonteCarloConfig = MonteCarloConfig()) -> MonteCarloResult:
    """The same Monte Carlo one replication at a time (chunk = 1): the per-replication baseline of the benchmark."""
    cfg = MonteCarloConfig(**{**config.__dict__, "chunk": 1})
    return run_monte_carlo(traj, reference, truth, cfg, progress=False)
