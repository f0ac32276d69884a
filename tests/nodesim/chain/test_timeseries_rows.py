"""The timeseries rows' compiled pass (nodesim.chain.timeseries_rows) gives the bits of the numpy expressions it
replaces (rad_to_deg, wrap_pi, sqrt), NaN and the wrap's edges included."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from nodesim.chain.run_tables import TIMESERIES_COLUMNS, node_timeseries
from nodesim.units import rad_to_deg, wrap_pi


def _numpy_rows(node, r: int, step: int) -> dict[str, np.ndarray]:
    """The table's rows as numpy expressions (the definition the kernel must equal)."""
    with np.errstate(invalid="ignore"):
        sigma_deg = rad_to_deg(np.sqrt(node.yaw_var_rad2[r]))
    part = {
        "node": np.full(node.t_s.size, node.node_id), "t_s": node.t_s, "running": node.running.astype(int),
        "update": node.update_mask[r].astype(int), "update_age_s": node.update_age_s[r],
        "true_yaw_deg": rad_to_deg(node.true_yaw_rad), "true_inclination_deg": rad_to_deg(node.true_inclination_rad),
        "true_azimuth_deg": rad_to_deg(node.true_azimuth_rad), "yaw_est_deg": rad_to_deg(node.yaw_est_rad[r]),
        "yaw_error_deg": rad_to_deg(wrap_pi(node.yaw_est_rad[r] - node.true_yaw_rad)), "yaw_sigma_deg": sigma_deg,
        "bias_true_deg_s": rad_to_deg(node.true_bias_rad_s[r]), "bias_est_deg_s": rad_to_deg(node.bias_est_rad_s[r]),
        "inclination_deg": rad_to_deg(node.inclination_rad[r]), "azimuth_deg": rad_to_deg(node.azimuth_rad[r]),
    }
    return {k: np.asarray(v)[::step] for k, v in part.items()}


def _node(K: int, R: int, seed: int):
    rng = np.random.default_rng(seed)

    def angles(*shape):
        x = rng.normal(scale=20.0, size=shape)
        edges = np.array([math.pi, -math.pi, 3 * math.pi, -3 * math.pi, 0.0, -0.0, 2 * math.pi, np.nan, 1e300])
        x.flat[rng.choice(x.size, size=min(x.size, edges.size), replace=False)] = edges[:min(x.size, edges.size)]
        return x

    true_yaw = angles(K)
    yaw = angles(R, K)
    var = rng.normal(size=(R, K))
    if K >= 5:
        yaw[0, :5] = true_yaw[:5] + np.array([math.pi, -math.pi, 3 * math.pi, 0.0, -2 * math.pi])  # the wrap's edges
        var[0, :3] = (np.nan, -0.0, 0.0)
    return SimpleNamespace(node_id=7, t_s=np.arange(K) * 0.52, running=rng.random(K) > 0.3,
                           update_mask=rng.random((R, K)) > 0.5, update_age_s=rng.random((R, K)),
                           true_yaw_rad=true_yaw, true_inclination_rad=angles(K), true_azimuth_rad=angles(K),
                           yaw_est_rad=yaw, yaw_var_rad2=var, true_bias_rad_s=angles(R, K), bias_est_rad_s=angles(R, K),
                           inclination_rad=angles(R, K), azimuth_rad=angles(R, K))


@pytest.mark.parametrize("K, R, r, step, seed", [(1000, 2, 0, 1, 1), (999, 3, 2, 3, 2), (1, 1, 0, 1, 3),
                                                 (17, 1, 0, 5, 4)])
def test_the_rows_are_the_bits_of_the_numpy_expressions(K, R, r, step, seed):
    node = _node(K, R, seed)
    got, want = node_timeseries(node, r, step), _numpy_rows(node, r, step)
    assert tuple(got) == TIMESERIES_COLUMNS
    for key in TIMESERIES_COLUMNS:
        assert got[key].dtype == want[key].dtype, key
        assert np.array_equal(got[key].view(np.int64), np.ascontiguousarray(want[key]).view(np.int64)), key


@pytest.mark.parametrize("step", [1, 3, 7, 40])
def test_rows_of_windows_of_ticks_are_the_rows_at_once(step):
    """A node's records cut in windows (first_tick: where each begins) give, window after window, the rows of all its
    ticks at once: every step-th tick of the node's, whatever the windows' edges."""
    node = _node(500, 2, 5)
    want = node_timeseries(node, 1, step)
    cuts = [0, 1, 2, 3, 10, 11, 100, 250, 251, 499, 500]
    parts = []
    for a, b in zip(cuts[:-1], cuts[1:]):
        window = SimpleNamespace(**{k: (v[a:b] if k in ("t_s", "running", "true_yaw_rad", "true_inclination_rad",
                                                        "true_azimuth_rad") else v[:, a:b] if isinstance(v, np.ndarray)
                                        else v) for k, v in vars(node).items()})
        parts.append(node_timeseries(window, 1, step, first_tick=a))
    for key in TIMESERIES_COLUMNS:
        got = np.concatenate([p[key] for p in parts])
        assert np.array_equal(got.view(np.int64), np.ascontiguousarray(want[key]).view(np.int64)), key
