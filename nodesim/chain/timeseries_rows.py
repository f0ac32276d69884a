"""One node's rows of the timeseries table in one compiled pass (:func:`nodesim.chain.run_tables.node_timeseries`).

Per kept tick k (every ``step``-th) of one realization, from the node's records in SI units:
    node, running (0/1), update (0/1), t_s, update_age_s             copied
    x_deg = x_rad / DEG                                               (:func:`nodesim.units.rad_to_deg`)
    yaw_error = wrap_pi(psi_hat - psi_true),  wrap_pi(a) = ((a + pi) mod 2 pi) - pi, -pi -> pi
                                                                      (:func:`nodesim.units.wrap_pi`)
    yaw_sigma = sqrt(P_yy) / DEG  (NaN for a diverged filter's negative P_yy)
the same IEEE operations as the numpy expressions they replace, so the same bits.  One pass instead of ~20 numpy
calls per node: a streamed run makes these rows on its output thread beside phase 2, and each numpy call there
gives up and takes back the GIL (this kernel releases it once, ``nogil``).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from nodesim.chain.compiled.angles import mod_two_pi
from nodesim.units import DEG

INT_COLUMNS = ("node", "running", "update")
FLOAT_COLUMNS = ("t_s", "update_age_s", "true_yaw_deg", "true_inclination_deg", "true_azimuth_deg", "yaw_est_deg",
                 "yaw_error_deg", "yaw_sigma_deg", "bias_true_deg_s", "bias_est_deg_s", "inclination_deg",
                 "azimuth_deg")


@njit(cache=True, _nrt=False, nogil=True, inline="always")
def wrap_pi(a: float) -> float:
    """:func:`nodesim.units.wrap_pi` of one float (:func:`~nodesim.chain.compiled.angles.mod_two_pi`: numpy's
    remainder without its fmod call where the difference is within a turn, as it almost always is;
    tests/nodesim/chain/test_timeseries_rows.py checks the bits)."""
    wrapped = mod_two_pi(a + math.pi) - math.pi
    return math.pi if wrapped == -math.pi else wrapped


@njit(cache=True, _nrt=False, nogil=True)
def fill_rows(node_id, start, step, t_s, running, update, age_s, true_yaw, true_inc, true_azi, yaw, var, true_bias,
              bias, inc, azi, ints, floats) -> None:
    """``ints`` (3, n) and ``floats`` (12, n) = the :data:`INT_COLUMNS` and :data:`FLOAT_COLUMNS` of ticks
    ``start``, ``start + step``, ... (module docstring); every input is one realization's (K,) record."""
    j = 0
    for k in range(start, t_s.size, step):
        ints[0, j], ints[1, j], ints[2, j] = node_id, running[k], update[k]
        v = var[k]
        sigma = np.sqrt(v)  # NaN (the sqrt instruction's, as numpy's) for v < 0
        floats[0, j], floats[1, j] = t_s[k], age_s[k]
        floats[2, j], floats[3, j], floats[4, j] = true_yaw[k] / DEG, true_inc[k] / DEG, true_azi[k] / DEG
        floats[5, j], floats[6, j] = yaw[k] / DEG, wrap_pi(yaw[k] - true_yaw[k]) / DEG
        floats[7, j], floats[8, j], floats[9, j] = sigma / DEG, true_bias[k] / DEG, bias[k] / DEG
        floats[10, j], floats[11, j] = inc[k] / DEG, azi[k] / DEG
        j += 1


def _f64(x) -> np.ndarray:
    return np.ascontiguousarray(x, dtype=np.float64)


def _flags(x) -> np.ndarray:
    """A 0/1 record as the kernel reads it: bool as it is (no int64 copy; the kernel stores it as 0 or 1)."""
    x = np.asarray(x)
    return np.ascontiguousarray(x, dtype=np.bool_ if x.dtype == np.bool_ else np.int64)


def rows(node, r: int = 0, step: int = 1, first_tick: int = 0) -> dict[str, np.ndarray]:
    """Realization ``r``'s rows of one node (:class:`~nodesim.chain.records.NodeRun`), every ``step``-th tick of
    the node's (tick 0, ``step``, ...), as columns (int64 and float64 rows of two blocks); ``first_tick``: the
    node's tick the records begin at (a window of its ticks, :meth:`NodeRun.ticks`: the windows' rows are the
    rows of all ticks at once, in order)."""
    K = node.t_s.size
    start = -first_tick % step  # the window's first tick that is a multiple of step
    n = len(range(start, K, step))
    ints, floats = np.empty((len(INT_COLUMNS), n), np.int64), np.empty((len(FLOAT_COLUMNS), n))
    fill_rows(node.node_id, start, step, _f64(node.t_s), _flags(node.running), _flags(node.update_mask[r]),
              _f64(node.update_age_s[r]),
              _f64(node.true_yaw_rad), _f64(node.true_inclination_rad), _f64(node.true_azimuth_rad),
              _f64(node.yaw_est_rad[r]), _f64(node.yaw_var_rad2[r]), _f64(node.true_bias_rad_s[r]),
              _f64(node.bias_est_rad_s[r]), _f64(node.inclination_rad[r]), _f64(node.azimuth_rad[r]), ints, floats)
    out = dict(zip(INT_COLUMNS, ints))
    out.update(zip(FLOAT_COLUMNS, floats))
    return out
