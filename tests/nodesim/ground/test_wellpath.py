"""Wellpath: minimum curvature, balanced tangential, interpolation, vertical section, A/B axes."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from nodesim.errors import NodesimError
from nodesim.ground.survey import make_survey
from nodesim.ground.wellpath import (
    ab_to_ne,
    course_displacements,
    dogleg_rad,
    interpolate_md,
    ne_to_ab,
    ratio_factor,
    rotate_horizontal,
    vertical_section,
    wellpath,
)


def test_mcm_worked_example_sv_appendix_8_1():
    """Covariance-method thesis app. 8.1: MD 3500 -> 3600 ft, I 15 -> 25, A 20 -> 45 deg.
    SV prints dN 27.22, dE 19.45 ft, beta 0.22605 rad; dTVD 93.01 and RF 1.00408 are typos for
    94.012 and 1.004280 (digest msa 7, recomputed)."""
    s = make_survey([3500.0, 3600.0], [15.0, 25.0], [20.0, 45.0])
    d = course_displacements(s)[0]
    assert d[0] == pytest.approx(27.22, abs=0.005)
    assert d[1] == pytest.approx(19.45, abs=0.005)
    assert d[2] == pytest.approx(94.012, abs=0.001)
    dl = dogleg_rad(s.inc_rad[0], s.azi_rad[0], s.inc_rad[1], s.azi_rad[1])
    assert dl == pytest.approx(0.22605, abs=5e-6)
    assert ratio_factor(dl) == pytest.approx(1.004280, abs=1e-6)


@given(st.floats(0.0, 2e-4))
def test_ratio_factor_continuous_through_the_series_threshold(dl):
    exact = 2.0 / dl * np.tan(dl / 2.0) if dl > 1e-8 else 1.0
    assert ratio_factor(dl) == pytest.approx(exact, rel=1e-12)
    assert ratio_factor(dl) >= 1.0


def test_ratio_factor_zero_dogleg_is_one_and_no_warning():
    with np.errstate(all="raise"):
        assert ratio_factor(0.0) == 1.0
        assert ratio_factor(np.array([0.0, 1e-12]))[1] == pytest.approx(1.0)


def test_straight_hole_methods_agree_and_equal_geometry():
    s = make_survey([0, 100, 250], [30, 30, 30], [45, 45, 45])
    a, b = wellpath(s), wellpath(s, "balanced_tangential")
    np.testing.assert_allclose(a.nev_m, b.nev_m, atol=1e-12)
    assert a.tvd_m[-1] == pytest.approx(250 * np.cos(np.radians(30)))
    assert a.n_m[-1] == pytest.approx(a.e_m[-1])


def test_constant_build_arc_is_exact_with_minimum_curvature():
    """A 90 deg build over a quarter circle of radius R: MCM reproduces the arc end point exactly."""
    r = 100.0
    md = np.linspace(0, np.pi / 2 * r, 7)
    s = make_survey(md, np.degrees(md / r), np.zeros_like(md))
    p = wellpath(s)
    assert p.n_m[-1] == pytest.approx(r, rel=1e-12)
    assert p.tvd_m[-1] == pytest.approx(r, rel=1e-12)
    bt = wellpath(s, "balanced_tangential")
    assert bt.n_m[-1] < r  # balanced tangential cuts the corner


@settings(max_examples=40, deadline=None)
@given(st.floats(1.0, 170.0), st.floats(0, 359), st.floats(-20, 20), st.floats(-40, 40), st.floats(0.05, 0.95))
def test_interpolation_stays_on_the_arc(i0, a0, di, da, f):
    """Interpolated points lie on the MCM arc: splitting a course at any MD gives the same end point."""
    i1 = float(np.clip(i0 + di, 0.5, 179.5))
    s = make_survey([0.0, 30.0], [i0, i1], [a0, a0 + da])
    p = wellpath(s)
    mid = 30.0 * f
    pos_mid = interpolate_md(p, [mid])[0]
    from nodesim.ground.wellpath import interpolate_direction

    inc_m, azi_m = interpolate_direction(s, np.array([mid]), np.array([1]))
    s2 = make_survey([mid, 30.0], [np.degrees(inc_m[0]), i1], [np.degrees(azi_m[0]), a0 + da])
    end = pos_mid + course_displacements(s2)[0]
    np.testing.assert_allclose(end, p.nev_m[-1], atol=1e-9)


def test_interpolation_at_stations_returns_station_positions_and_rejects_outside():
    s = make_survey([0, 30, 60, 90], [0, 10, 20, 25], [0, 40, 50, 55])
    p = wellpath(s)
    np.testing.assert_allclose(interpolate_md(p, s.md_m), p.nev_m, atol=1e-9)
    with pytest.raises(NodesimError, match="within"):
        interpolate_md(p, [100.0])


def test_vertical_section_and_rotation():
    s = make_survey([0, 100], [90, 90], [30, 30])
    p = wellpath(s)
    assert vertical_section(p, 30.0)[-1] == pytest.approx(100.0)
    assert vertical_section(p, 120.0)[-1] == pytest.approx(0.0, abs=1e-9)
    x, y = rotate_horizontal(p.n_m, p.e_m, 30.0)
    assert x[-1] == pytest.approx(100.0) and y[-1] == pytest.approx(0.0, abs=1e-9)


def test_ab_axes_reproduce_thesis_table_4_1_azimuths():
    """Thesis table 4.1: Az = atan2(A, -B) with N = -B, E = +A (digest 1.2), every printed row."""
    b = np.array([0.1, 0.5, 0.75, 0.75, 1, 1.75, 2.75, 3, 2.25, 2])
    a = np.array([-0.25, -1, -2, -3, -4.5, -5.75, -7.75, -9.25, -10.25, -11.75])
    az_printed = np.array([248.20, 243.43, 249.44, 255.96, 257.47, 253.07, 250.46, 252.03, 257.62, 260.34])
    n, e = ab_to_ne(a, b)
    az = np.degrees(np.arctan2(e, n)) % 360
    np.testing.assert_allclose(az, az_printed, atol=0.006)
    a2, b2 = ne_to_ab(n, e)
    np.testing.assert_allclose(a2, a)
    np.testing.assert_allclose(b2, b)


@pytest.mark.parametrize(
    "name, n_ref, e_ref",
    [("iscwsa1_rev5", 1530.727, 5712.749), ("iscwsa3_rev5", 721.338, -791.284), ("iscwsa2_rev5", -1692.692 * 0.3048, -1026.136 * 0.3048)],
)
def test_iscwsa_wellpaths_match(iscwsa_dir, name, n_ref, e_ref):
    """Oracle README 'Survey sanity checks': final N/E and TVD against the workbook TVD column."""
    from nodesim.ground.iscwsa import load_iscwsa

    w = load_iscwsa(iscwsa_dir / f"{name}.json")
    p = wellpath(w.survey)
    assert p.n_m[-1] == pytest.approx(n_ref, abs=2e-3)
    assert p.e_m[-1] == pytest.approx(e_ref, abs=2e-3)
    assert np.max(np.abs(p.tvd_m - w.tvd_m)) < 0.037  # TVD typed to 2 dp (I/A to 2 dp in #2/#3)


def test_table_4_1_inclinations_from_ab_displacements():
    """Thesis eqs 4.1-4.2 applied to the printed (cumulative) A/B displacements reproduce the I and Az
    columns of table 4.1 (I to the printed 0.01 deg, which truncates: SS10 asin(11.75/200) = 3.368)."""
    from nodesim.ground.wellpath import survey_angles_from_ab

    b = np.array([0.1, 0.5, 0.75, 0.75, 1, 1.75, 2.75, 3, 2.25, 2]) / 100
    a = np.array([-0.25, -1, -2, -3, -4.5, -5.75, -7.75, -9.25, -10.25, -11.75]) / 100
    inc_printed = [0.08, 0.32, 0.61, 0.89, 1.32, 1.72, 2.35, 2.78, 3.00, 3.41]
    az_printed = [248.20, 243.43, 249.44, 255.96, 257.47, 253.07, 250.46, 252.03, 257.62, 260.34]
    inc, az = survey_angles_from_ab(a, b)
    np.testing.assert_allclose(inc, inc_printed, atol=0.011)
    np.testing.assert_allclose(az, az_printed, atol=0.006)
    inc_inc, _ = survey_angles_from_ab(a, b, cumulative=False)
    assert inc_inc.max() < 0.7  # increments over 2 m: at most 2.24 cm (SS7), i.e. 0.64 deg
    with pytest.raises(NodesimError, match="larger than the course"):
        survey_angles_from_ab([3.0], [0.0])
