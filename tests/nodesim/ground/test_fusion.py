"""Station fusion (thesis 3.6, 4.3): recursive Bayes, weighting schemes, two-sigma rule."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from nodesim.errors import NodesimError
from nodesim.ground.fusion import (
    StationHistory,
    bayes_update,
    cluster_weights,
    combine_clusters,
    error_decrease_ratio,
    fuse_recursive,
    scheme_weights,
    stale_increment_error,
    update_stations,
)
from nodesim.ground.survey import make_survey


def test_tables_4_23_4_24_bayes_combination():
    """MPU6500 (1.126 %, 0.0422) + VN-100T (0.168 %, 0.0051) -> 0.182 %, 5.06e-3; + sensor C
    (0.1 %, 0.0001) -> 0.100032 %, 9.998e-5 (thesis eqs 4.9-4.10)."""
    m, v = bayes_update(1.126, 0.0422**2, 0.168, 0.0051**2)
    assert m == pytest.approx(0.182, abs=5e-4) and np.sqrt(v) == pytest.approx(5.06e-3, abs=5e-6)
    m2, v2 = bayes_update(0.1, 0.0001**2, m, v)
    assert m2 == pytest.approx(0.100032, abs=5e-7) and np.sqrt(v2) == pytest.approx(9.998e-5, abs=5e-8)


@settings(max_examples=50, deadline=None)
@given(st.lists(st.tuples(st.floats(-10, 10), st.floats(0.01, 5.0)), min_size=1, max_size=8))
def test_recursive_fusion_equals_batch_inverse_variance(meas):
    y = np.array([m[0] for m in meas])
    v = np.array([m[1] for m in meas])
    mean, var = fuse_recursive(y, v)
    w = cluster_weights(v)
    assert mean == pytest.approx(np.sum(w * y), abs=1e-9)
    assert var == pytest.approx(1.0 / np.sum(1.0 / v), rel=1e-9)
    assert var <= v.min() + 1e-15  # never less certain than the best measurement


def test_identical_sensors_give_sigma_over_sqrt_n():
    """Figs 4.28a-c: combining N identical cluster sensors scales the 1-sigma error by 1/sqrt(N)."""
    for n in (1, 2, 4):
        _, var = fuse_recursive(np.zeros(n), np.full(n, 0.04))
        assert np.sqrt(var) == pytest.approx(0.2 / np.sqrt(n))


def test_circular_fusion_across_north():
    m, _ = bayes_update(np.radians(359.0), 1.0, np.radians(1.0), 1.0, circular=True)
    assert np.degrees(m) == pytest.approx(0.0, abs=1e-9) or np.degrees(m) == pytest.approx(360.0, abs=1e-9)


def test_table_4_30_weighting_schemes():
    np.testing.assert_allclose(scheme_weights("equal", 4), [0.25] * 4)
    np.testing.assert_allclose(scheme_weights("linear", 4), np.array([1, 2, 3, 4]) / 10)
    np.testing.assert_allclose(scheme_weights("quadratic", 4), np.array([1, 4, 9, 16]) / 30)
    np.testing.assert_allclose(scheme_weights("cubic", 4), np.array([1, 8, 27, 64]) / 100)
    np.testing.assert_allclose(scheme_weights("cubic_printed", 4), np.array([1, 8, 81, 64]) / 154)
    np.testing.assert_allclose(scheme_weights("linear", 2), [1 / 3, 2 / 3])  # first M, renormalised
    with pytest.raises(NodesimError, match="scheme 'fancy' unknown"):
        scheme_weights("fancy", 3)
    with pytest.raises(NodesimError, match="4 coefficients"):
        scheme_weights("cubic_printed", 5)


def test_fig_4_35_error_decrease_ratios():
    """Linear ~0.75 (SS2) / ~0.67 (SS3); quadratic ~0.53 / 0.4 (thesis fig 4.35, digest 3.5)."""
    assert error_decrease_ratio("linear", 3) == pytest.approx(0.75)
    assert error_decrease_ratio("linear", 2) == pytest.approx(0.667, abs=1e-3)
    assert error_decrease_ratio("quadratic", 3) == pytest.approx(0.536, abs=1e-3)
    assert error_decrease_ratio("quadratic", 2) == pytest.approx(0.40)
    assert error_decrease_ratio("cubic", 3) < error_decrease_ratio("quadratic", 3)


def test_section_4_3_change_at_ss2():
    """Table 4.28 trajectory (SS1-4 at 2/4/6/8 m, I 1 deg, A 120 deg); I at SS2 1 -> 3 deg seen only by
    the newest cluster; equal weights: thesis ~1.18 / 0.85 cm (N, SS2/SS3), ~2 cm E at SS2, 0.08 / 0.06
    cm TVD; SS1 and SS4 unaffected.  Model (digest 3.5): 1.163 / 0.872, 2.014, 0.0812 / 0.0609."""
    old = make_survey([0, 2, 4, 6, 8], [0, 1, 1, 1, 1], [0, 120, 120, 120, 120])
    new = make_survey([0, 2, 4, 6, 8], [0, 1, 3, 1, 1], [0, 120, 120, 120, 120])
    err = np.abs(stale_increment_error(old, new, [0, 4, 3, 2, 1])) * 100
    np.testing.assert_allclose(err[2], [1.163, 2.014, 0.0812], atol=1e-3)
    np.testing.assert_allclose(err[3], [0.872, 1.511, 0.0609], atol=1e-3)
    assert np.all(err[[0, 1, 4]] == 0)
    assert err[2, 0] == pytest.approx(1.18, rel=0.05) and err[3, 0] == pytest.approx(0.85, rel=0.05)
    # table 4.29 (corrected, digest 3.5): SS1 increment -0.8726 / 1.5114 cm
    from nodesim.ground.wellpath import course_displacements

    d = course_displacements(old, "balanced_tangential") * 100
    np.testing.assert_allclose(d[0, :2], [-0.8726, 1.5114], atol=1e-4)
    np.testing.assert_allclose(d[1, :2], [-1.7452, 3.0228], atol=1e-4)


@settings(max_examples=30, deadline=None)
@given(st.floats(1.5, 10.0), st.sampled_from(["linear", "quadratic", "cubic"]))
def test_errors_grow_with_the_step_and_schemes_beat_equal(step, scheme):
    old = make_survey([0, 2, 4, 6, 8], [0, 1, 1, 1, 1], [0, 120, 120, 120, 120])
    small = make_survey([0, 2, 4, 6, 8], [0, 1, step, 1, 1], [0, 120, 120, 120, 120])
    big = make_survey([0, 2, 4, 6, 8], [0, 1, step + 1, 1, 1], [0, 120, 120, 120, 120])
    e_small = np.linalg.norm(stale_increment_error(old, small, [0, 4, 3, 2, 1]), axis=1)
    e_big = np.linalg.norm(stale_increment_error(old, big, [0, 4, 3, 2, 1]), axis=1)
    assert e_big[2] > e_small[2]
    e_s = np.linalg.norm(stale_increment_error(old, small, [0, 4, 3, 2, 1], scheme), axis=1)
    assert e_s[2] < e_small[2]


def test_two_sigma_rule_accepts_resets_and_rejects():
    h = [StationHistory([1.0], [0.01]) for _ in range(4)]
    status = update_stations(h, {0: (1.05, 0.01), 1: (2.0, 0.01), 2: (2.1, 0.01), 3: (1.0, 0.01)})
    assert status == {0: "accepted", 1: "reset", 2: "reset", 3: "accepted"}
    assert h[1].means == [2.0] and h[0].means == [1.0, 1.05]
    status = update_stations(h, {0: (5.0, 0.01)})  # isolated outlier, neighbours unchanged
    assert status == {0: "rejected"} and h[0].means == [1.0, 1.05]
    fused, var = h[0].fused("equal")
    assert fused == pytest.approx(1.025) and var == pytest.approx(0.005)
    empty = [StationHistory()]
    assert update_stations(empty, {0: (3.0, 0.1)}) == {0: "first"}
    with pytest.raises(NodesimError, match="station index 5"):
        update_stations(empty, {5: (1.0, 0.1)})


def test_combine_clusters_variance_and_bad_variance():
    m, v = combine_clusters([1.0, 3.0], [0.5, 0.5], "linear")
    assert m == pytest.approx(1 / 3 + 2) and v == pytest.approx((1 / 9 + 4 / 9) * 0.5)
    with pytest.raises(NodesimError, match="variances must be > 0"):
        bayes_update(0.0, 0.0, 1.0, 1.0)
