"""IMU calibration: two-direction turn-table method and multi-position weighted least squares.

Measurement model (thesis appendix III eq III.1.1; calibration paper eq 5):  meas = M true + b + w,
with M the 3x3 scale-factor/misalignment matrix (row i = sensor axis i) and b the bias.  Applying a
calibration (thesis III.1.3, paper eq 12): true = M^-1 (meas - b).

* Turn table, two directions (thesis III.1.5-III.1.18): rotate at +r and -r about each axis j (or +g/-g
  for an accelerometer); with the bias constant across the pair, column j of M = (G_P - G_N) / (2 r) and
  b = (G_P + G_N) / 2, averaged over the three pairs.
* Least squares (thesis III.1.19-III.1.29, paper eqs 6-11): 12 unknowns
  theta = [b_x b_y b_z M_xx M_xy M_xz M_yx M_yy M_yz M_zx M_zy M_zz], each position i contributes the
  3x12 rows Pi_i = [I_3 | blkdiag(t_i^T, t_i^T, t_i^T)];  theta = (Pi^T W Pi)^-1 Pi^T W Y with W = R^-1.
  The parameter covariance is s^2 (Pi^T W Pi)^-1 with s^2 the residual variance per degree of freedom
  (W = I) or 1 (W = R^-1 given).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from nodesim.errors import NodesimError
from nodesim.io.csv_input import read_table

MAX_CONDITION = 1e8
AXIS_TOLERANCE = 1e-6


@dataclass(frozen=True)
class Calibration:
    """An estimated calibration: ``meas = matrix @ true + bias``."""

    method: str
    bias: np.ndarray  # (3,)
    matrix: np.ndarray  # (3, 3)
    residuals: np.ndarray  # (N, 3): meas - (matrix @ true + bias) per position
    condition_number: float
    parameter_std: np.ndarray | None = None  # (12,) in theta order, least squares only

    @property
    def rms_residual(self) -> float:
        return float(np.sqrt(np.mean(self.residuals**2)))

    def apply(self, meas) -> np.ndarray:
        """Calibrated (true-frame) values for measurements of shape (..., 3): M^-1 (meas - b)."""
        m = np.asarray(meas, dtype=float)
        return np.linalg.solve(self.matrix, (m - self.bias)[..., None])[..., 0]

    def as_dict(self) -> dict:
        out = {
            "method": self.method,
            "bias": self.bias.tolist(),
            "matrix": self.matrix.tolist(),
            "residuals": self.residuals.tolist(),
            "rms_residual": self.rms_residual,
            "max_abs_residual": float(np.max(np.abs(self.residuals))) if self.residuals.size else 0.0,
            "condition_number": self.condition_number,
            "positions": int(self.residuals.shape[0]),
        }
        if self.parameter_std is not None:
            out["bias_std"] = self.parameter_std[:3].tolist()
            out["matrix_std"] = self.parameter_std[3:].reshape(3, 3).tolist()
        return out


def _check_arrays(true, meas) -> tuple[np.ndarray, np.ndarray]:
    t = np.asarray(true, dtype=float)
    m = np.asarray(meas, dtype=float)
    if t.ndim != 2 or t.shape[1] != 3 or m.shape != t.shape:
        raise NodesimError(f"calibration: true and measured must both be (N, 3) arrays (got {t.shape} and {m.shape})")
    for name, arr in (("true", t), ("meas", m)):
        bad = ~np.all(np.isfinite(arr), axis=1)
        if bad.any():
            raise NodesimError(f"calibration: row {int(np.flatnonzero(bad)[0]) + 1} has a non-finite {name} value")
    return t, m


def design_matrix(true) -> np.ndarray:
    """Stacked regression rows Pi (3N x 12), calibration paper eq 8 / thesis III.1.29."""
    t = np.asarray(true, dtype=float)
    n = t.shape[0]
    pi = np.zeros((n, 3, 12))
    pi[:, :, :3] = np.eye(3)
    for r in range(3):
        pi[:, r, 3 + 3 * r : 6 + 3 * r] = t
    return pi.reshape(3 * n, 12)


def _residuals(true, meas, matrix, bias) -> np.ndarray:
    return meas - (true @ matrix.T + bias)


def least_squares(true, meas, weights=None) -> Calibration:
    """Multi-position weighted least squares (12 parameters; paper eq 11).

    ``weights``: optional (N, 3) inverse noise variances per position and axis (diagonal W = R^-1).
    """
    t, m = _check_arrays(true, meas)
    if 3 * t.shape[0] < 12:
        raise NodesimError(f"calibration lsq: {t.shape[0]} positions give {3 * t.shape[0]} equations; need >= 12 (>= 4 positions)")
    pi = design_matrix(t)
    y = m.reshape(-1)
    w = np.ones_like(y) if weights is None else np.asarray(weights, dtype=float).reshape(-1)
    if w.shape != y.shape or np.any(~np.isfinite(w)) or np.any(w <= 0):
        raise NodesimError("calibration lsq: weights must be positive and finite, one per position and axis")
    sw = np.sqrt(w)
    a = pi * sw[:, None]
    cond = float(np.linalg.cond(a))
    if not cond < MAX_CONDITION:
        raise NodesimError(
            f"calibration lsq: the test positions do not determine the 12 parameters (condition number {cond:.3g}); "
            "use positions whose true vectors span all three axes and are not all equal"
        )
    theta, *_ = np.linalg.lstsq(a, y * sw, rcond=None)
    bias, matrix = theta[:3], theta[3:].reshape(3, 3)
    res = _residuals(t, m, matrix, bias)
    dof = y.size - 12
    normal_inv = np.linalg.inv(a.T @ a)
    if weights is None:
        s2 = float(np.sum(res**2) / dof) if dof > 0 else float("nan")
        cov = s2 * normal_inv
    else:
        cov = normal_inv
    return Calibration("lsq", bias, matrix, res, cond, np.sqrt(np.clip(np.diag(cov), 0.0, None)))


def turntable(true, meas) -> Calibration:
    """Two-direction method: every axis needs positions at +r and -r along it (other components zero)."""
    t, m = _check_arrays(true, meas)
    mags = np.linalg.norm(t, axis=1)
    axis = np.argmax(np.abs(t), axis=1)
    off_axis = np.abs(t) > AXIS_TOLERANCE * np.maximum(mags, 1.0)[:, None]
    off_axis[np.arange(t.shape[0]), axis] = False
    if off_axis.any() or np.any(mags == 0):
        row = int(np.flatnonzero(off_axis.any(axis=1) | (mags == 0))[0]) + 1
        raise NodesimError(
            f"calibration turntable: row {row} true vector {t[row - 1].tolist()} is not along one axis "
            "(the two-direction method needs +r and -r about x, y and z; use --method lsq otherwise)"
        )
    matrix = np.zeros((3, 3))
    pair_bias = []
    for j in range(3):
        sign = np.sign(t[:, j])
        pos = (axis == j) & (sign > 0)
        neg = (axis == j) & (sign < 0)
        if not pos.any() or not neg.any():
            raise NodesimError(f"calibration turntable: axis {'xyz'[j]} needs a positive and a negative position")
        rate_p = t[pos, j].mean()
        rate_n = -t[neg, j].mean()
        if not np.isclose(rate_p, rate_n, rtol=1e-6):
            raise NodesimError(
                f"calibration turntable: axis {'xyz'[j]} rates differ (+{rate_p:g} vs -{rate_n:g}); the method needs equal rates"
            )
        gp, gn = m[pos].mean(axis=0), m[neg].mean(axis=0)
        matrix[:, j] = (gp - gn) / (2.0 * rate_p)
        pair_bias.append(0.5 * (gp + gn))
    bias = np.mean(pair_bias, axis=0)
    return Calibration("turntable", bias, matrix, _residuals(t, m, matrix, bias), float(np.linalg.cond(matrix)))


def calibrate(true, meas, method: str = "lsq") -> Calibration:
    """Dispatch on ``method`` ('turntable' or 'lsq')."""
    if method == "lsq":
        return least_squares(true, meas)
    if method == "turntable":
        return turntable(true, meas)
    raise NodesimError(f"calibration: unknown method {method!r} (allowed: turntable, lsq)")


def six_position_rates(rate: float) -> np.ndarray:
    """True vectors of the two-direction test: +r, -r about x, y, z (rows)."""
    eye = np.eye(3) * rate
    return np.stack([eye[0], -eye[0], eye[1], -eye[1], eye[2], -eye[2]])


def simulate_positions(true, matrix, bias, noise_sigma: float, samples: int, rng: np.random.Generator) -> np.ndarray:
    """Averaged sensor output per position: M t + b + mean of ``samples`` white-noise draws (sigma each)."""
    t = np.asarray(true, dtype=float)
    w = rng.standard_normal(t.shape) * (noise_sigma / np.sqrt(samples))
    return t @ np.asarray(matrix).T + np.asarray(bias) + w


POSITION_COLUMNS = ("true_x", "true_y", "true_z", "meas_x", "meas_y", "meas_z")


def read_positions(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """(true (N,3), meas (N,3)) from a calibration CSV; errors name the file, row and column."""
    path = Path(path)
    header, data, lines = read_table(path, POSITION_COLUMNS, "calibration data")
    idx = [header.index(c) for c in POSITION_COLUMNS]
    values = np.empty((len(data), 6))
    for r, (line, row) in enumerate(zip(lines, data)):
        if len(row) != len(header):
            raise NodesimError(f"{path}, line {line}: {len(row)} fields, the header has {len(header)}")
        for k, (i, name) in enumerate(zip(idx, POSITION_COLUMNS)):
            try:
                values[r, k] = float(row[i])
            except ValueError:
                raise NodesimError(f"{path}, line {line}, column {name}: {row[i]!r} is not a number") from None
            if not np.isfinite(values[r, k]):
                raise NodesimError(f"{path}, line {line}, column {name}: {row[i]!r} is not finite")
    if values.shape[0] == 0:
        raise NodesimError(f"{path}: no data rows")
    return values[:, :3], values[:, 3:]
