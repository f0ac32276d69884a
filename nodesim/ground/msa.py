"""Multi-Station Analysis (MSA): per-axis magnetometer scale and bias from many survey stations.

Parameters theta = (b_x, b_y, b_z, s_x, s_y, s_z) (bias in uT, scale dimensionless, HV eq 3.1), the same at
every station.  With u_i = G_i/|G_i| and the corrected field c_i = (B_m,i - b)/s (HV 3.2), the residuals
of station i against the reference (B_hr, B_vr) are (HV 3.4-3.5, digest 6.1)::

    Bv_i = c_i . u_i          Bh_i = sqrt(|c_i|^2 - Bv_i^2)
    r_i  = (Bh_i - B_hr, Bv_i - B_vr)          L(theta) = sum_i |r_i|^2

Analytic Jacobian (digest 6.2, derived; checked against finite differences in the tests)::

    dc_ij/db_j = -1/s_j     dc_ij/ds_j = -c_ij/s_j
    dBv_i/dtheta = u_ij dc_ij/dtheta      dBh_i/dtheta = (c_ij - Bv_i u_ij) dc_ij/dtheta / Bh_i

The minimiser is found by Levenberg-Marquardt on the 2N residuals, vectorised over a batch (Monte Carlo
replications x starts): HV ran Excel GRG, the digest's re-implementation (section 14) used LM.  Several
starts are run and the lowest L kept (digest 6.4: about 10 % of single starts on HV Survey 3 end in a
spurious local minimum).  The condition number is that of J^T J (the Gauss-Newton Hessian of L / 2, HV
Ch 6) at the solution, with bias in uT; the theta is reported *unobservable* when J^T J is numerically
rank deficient (fewer than 6 independent directions), e.g. every station at the same toolface and attitude.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nodesim.errors import NodesimError
from nodesim.ground.magnetic_survey import FieldReference, check_triads, correct, survey_from_readings
from nodesim.ground.survey import make_survey
from nodesim.ground.wellpath import Wellpath, wellpath
from nodesim.units import DEG

N_PARAMS = 6
MIN_STATIONS = 3  # 2 residuals per station, 6 unknowns
TRUTH_FREE_CENTRE = np.array([0.0, 0.0, 0.0, 1.0, 1.0, 1.0])
UNOBSERVABLE_RCOND = 1e-10
"""J^T J with lambda_min / lambda_max below this (cond > 1e10) has no usable 6-parameter solution."""
ILL_CONDITIONED = 1e6
"""cond(J^T J) (bias in uT) above which the result is flagged ill-conditioned: HV Surveys 3 (2.4e6) and 7
(1.4e7), which HV's solver could not resolve, against 5e3-3.5e5 for Surveys 1, 2, 4, 5, 6."""


@dataclass(frozen=True)
class SolverOptions:
    """Levenberg-Marquardt settings: stop when the step is below ``xtol`` (relative) or L stalls (``ftol``)."""

    max_iter: int = 200
    xtol: float = 1e-13
    ftol: float = 1e-15
    lambda0: float = 1e-3


@dataclass(frozen=True, eq=False)
class MsaResult:
    """MSA outcome: theta (b_x, b_y, b_z [uT], s_x, s_y, s_z), cost L [uT^2] and diagnostics.

    ``status`` is ``"ok"``, ``"ill_conditioned"`` (cond > ``ILL_CONDITIONED``: trust with care),
    ``"unobservable"`` (J^T J rank deficient: theta is not determined by the data) or ``"not_converged"``.  ``start_costs`` lists the final L of every start (the lowest is kept)."""

    theta: np.ndarray
    cost: float
    iterations: int
    converged: bool
    condition_number: float
    gradient_norm: float
    status: str
    start_costs: np.ndarray

    @property
    def bias_ut(self) -> np.ndarray:
        return self.theta[:3]

    @property
    def scale(self) -> np.ndarray:
        return self.theta[3:]

    def as_dict(self) -> dict:
        return {
            "bias_ut": self.bias_ut.tolist(),
            "scale": self.scale.tolist(),
            "cost_ut2": self.cost,
            "iterations": self.iterations,
            "converged": self.converged,
            "condition_number": self.condition_number,
            "gradient_norm": self.gradient_norm,
            "status": self.status,
            "start_costs": self.start_costs.tolist(),
        }


def residuals_jacobian(theta, u, b_m, bh_ref, bv_ref) -> tuple[np.ndarray, np.ndarray]:
    """Residuals (B, 2N) ordered (Bh_1..Bh_N, Bv_1..Bv_N) and their Jacobian (B, 2N, 6).

    theta (B, 6); u, b_m (B, N, 3) or (N, 3); bh_ref, bv_ref scalars or (B,)."""
    theta = np.asarray(theta, dtype=float)
    c = correct(b_m, theta)  # (B, N, 3)
    s = theta[:, None, 3:]
    bv = np.sum(c * u, axis=-1)
    bh = np.sqrt(np.maximum(np.sum(c * c, axis=-1) - bv * bv, 1e-300))
    bh_ref = np.asarray(bh_ref, dtype=float).reshape(-1, 1)
    bv_ref = np.asarray(bv_ref, dtype=float).reshape(-1, 1)
    r = np.concatenate([bh - bh_ref, bv - bv_ref], axis=-1)
    dc_db = np.broadcast_to(-1.0 / s, c.shape)
    dc_ds = -c / s
    uu = np.broadcast_to(u, c.shape)
    hv = (c - bv[..., None] * uu) / bh[..., None]
    jac = np.concatenate(
        [
            np.concatenate([hv * dc_db, hv * dc_ds], axis=-1),
            np.concatenate([uu * dc_db, uu * dc_ds], axis=-1),
        ],
        axis=-2,
    )
    return r, jac


def _cost(theta, u, b_m, bh_ref, bv_ref) -> np.ndarray:
    if np.any(theta[:, 3:] <= 0.0):
        bad = np.any(theta[:, 3:] <= 0.0, axis=1)
        safe = np.where(bad[:, None], TRUTH_FREE_CENTRE, theta)
        r, _ = residuals_jacobian(safe, u, b_m, bh_ref, bv_ref)
        return np.where(bad, np.inf, np.sum(r * r, axis=-1))
    r, _ = residuals_jacobian(theta, u, b_m, bh_ref, bv_ref)
    return np.sum(r * r, axis=-1)


def solve_batch(theta0, u, b_m, bh_ref, bv_ref, options: SolverOptions = SolverOptions()):
    """Levenberg-Marquardt for a batch of independent MSA problems (vectorised over the batch axis).

    theta0 (B, 6); u, b_m (B, N, 3) or shared (N, 3); bh_ref, bv_ref (B,) or scalars.
    Returns theta (B, 6), cost L (B,), iterations (B,), converged (B,) bool."""
    theta = np.array(theta0, dtype=float, copy=True)
    nb = theta.shape[0]
    u = np.asarray(u, dtype=float)
    b_m = np.asarray(b_m, dtype=float)
    bh_ref = np.broadcast_to(np.asarray(bh_ref, dtype=float), (nb,))
    bv_ref = np.broadcast_to(np.asarray(bv_ref, dtype=float), (nb,))
    batched = b_m.ndim == 3

    def sub(idx):
        return (u[idx] if u.ndim == 3 else u), (b_m[idx] if batched else b_m), bh_ref[idx], bv_ref[idx]

    cost = _cost(theta, u, b_m, bh_ref, bv_ref)
    lam = np.full(nb, options.lambda0)
    iters = np.zeros(nb, dtype=int)
    converged = np.zeros(nb, dtype=bool)
    active = np.isfinite(cost)
    eye = np.eye(N_PARAMS)
    for _ in range(options.max_iter):
        idx = np.flatnonzero(active)
        if idx.size == 0:
            break
        ui, bi, hi, vi = sub(idx)
        r, jac = residuals_jacobian(theta[idx], ui, bi, hi, vi)
        a = np.einsum("bri,brj->bij", jac, jac)
        grad = np.einsum("bri,br->bi", jac, r)
        diag = np.einsum("bii->bi", a)
        damped = a + (lam[idx, None] * diag + 1e-30)[:, :, None] * eye
        step = -np.linalg.solve(damped, grad[..., None])[..., 0]
        trial = theta[idx] + step
        new_cost = _cost(trial, ui, bi, hi, vi)
        better = new_cost < cost[idx]
        small_step = np.linalg.norm(step, axis=1) <= options.xtol * (1.0 + np.linalg.norm(theta[idx], axis=1))
        stall = better & (cost[idx] - new_cost <= options.ftol * np.maximum(cost[idx], 1e-300))
        acc = idx[better]
        theta[acc] = trial[better]
        cost[acc] = new_cost[better]
        lam[idx] = np.where(better, np.maximum(lam[idx] * 0.3, 1e-12), np.minimum(lam[idx] * 10.0, 1e12))
        iters[idx] += 1
        done = small_step | stall | (cost[idx] == 0.0) | (lam[idx] >= 1e12)
        converged[idx[done]] = (small_step | stall | (cost[idx] == 0.0))[done]
        active[idx[done]] = False
    return theta, cost, iters, converged


def condition_numbers(theta, u, b_m, bh_ref, bv_ref) -> tuple[np.ndarray, np.ndarray]:
    """cond(J^T J) = lambda_max / lambda_min and |grad L| = |2 J^T r| at theta (batched like :func:`solve_batch`)."""
    r, jac = residuals_jacobian(theta, u, b_m, bh_ref, bv_ref)
    lam = np.linalg.eigvalsh(np.einsum("bri,brj->bij", jac, jac))
    with np.errstate(divide="ignore"):
        cond = np.where(lam[:, 0] > 0.0, lam[:, -1] / np.maximum(lam[:, 0], 0.0), np.inf)
    return cond, np.linalg.norm(2.0 * np.einsum("bri,br->bi", jac, r), axis=1)


def start_points(centre, n_starts: int, spread: float, rng: np.random.Generator) -> np.ndarray:
    """The centre itself plus ``n_starts - 1`` points at centre + U(-spread, spread) per parameter (HV Ch 4)."""
    centre = np.asarray(centre, dtype=float)
    pts = np.repeat(centre[None, :], n_starts, axis=0)
    pts[1:] += rng.uniform(-spread, spread, size=(n_starts - 1, N_PARAMS))
    pts[:, 3:] = np.maximum(pts[:, 3:], 0.05)
    return pts


def msa_inputs(g, b_m, where: str = "MSA") -> tuple[np.ndarray, np.ndarray]:
    """Validated (u, b_m), each (N, 3): unit gravity directions and measured field; N >= 3 stations."""
    g, b_m = check_triads(g, b_m, where)
    if g.ndim != 2:
        raise NodesimError(f"{where}: triads must have shape (stations, 3), got {g.shape}")
    if g.shape[0] < MIN_STATIONS:
        raise NodesimError(
            f"{where}: {g.shape[0]} station(s); MSA estimates 6 parameters from 2 residuals per station and "
            f"needs at least {MIN_STATIONS} stations (with varied toolface)"
        )
    return g / np.linalg.norm(g, axis=-1, keepdims=True), b_m


def msa(
    g,
    b_m,
    reference: FieldReference,
    n_starts: int = 8,
    start_spread: float = 0.25,
    start_centre=None,
    seed: int = 0,
    options: SolverOptions = SolverOptions(),
) -> MsaResult:
    """MSA of one survey: triads g (gravity, any scale) and b_m (uT), each (N, 3), against ``reference``.

    ``start_centre`` defaults to no error (b = 0, s = 1); HV started at truth + U(-0.25, 0.25)."""
    if n_starts < 1:
        raise NodesimError(f"MSA: n_starts = {n_starts} must be >= 1")
    if not (np.isfinite(start_spread) and start_spread >= 0.0):
        raise NodesimError(f"MSA: start_spread = {start_spread} must be finite and >= 0")
    u, b_m = msa_inputs(g, b_m)
    centre = TRUTH_FREE_CENTRE if start_centre is None else np.asarray(start_centre, dtype=float)
    if centre.shape != (N_PARAMS,) or not np.all(np.isfinite(centre)) or np.any(centre[3:] <= 0):
        raise NodesimError("MSA: start_centre must be 6 finite numbers (b_x, b_y, b_z, s_x, s_y, s_z) with s > 0")
    starts = start_points(centre, n_starts, start_spread, np.random.default_rng(seed))
    theta, cost, iters, conv = solve_batch(starts, u, b_m, reference.bh_ut, reference.bv_ut, options)
    best = int(np.argmin(cost))
    cond, gnorm = condition_numbers(theta[best : best + 1], u, b_m, reference.bh_ut, reference.bv_ut)
    status = "ok" if conv[best] else "not_converged"
    if status == "ok" and cond[0] > ILL_CONDITIONED:
        status = "ill_conditioned"
    if not cond[0] < 1.0 / UNOBSERVABLE_RCOND:
        status = "unobservable"
    return MsaResult(theta[best], float(cost[best]), int(iters[best]), bool(conv[best]), float(cond[0]), float(gnorm[0]), status, cost)


def corrected_survey(g, b_m, theta):
    """Survey angles after applying the MSA correction (HV 3.2 then 3.7-3.9)."""
    return survey_from_readings(g, correct(b_m, theta))


def corrected_wellpath(md_m, g, b_m, theta, method: str = "minimum_curvature") -> Wellpath:
    """Corrected survey -> positions with the project's wellpath (HV 3.10-3.11: MCM from the first station)."""
    s = corrected_survey(g, b_m, theta)
    survey = make_survey(md_m, s.inc_rad / DEG, s.azi_rad / DEG, where="MSA-corrected survey")
    return wellpath(survey, method)
