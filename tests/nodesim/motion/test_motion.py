"""Rate profiles, lab profile, drilling process with tube insertions, encoder and magnetometer."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from firmware_model.survey_resolution import resolve_survey
from nodesim.motion.drilling import DrillingProcess, Wellpath
from nodesim.errors import NodesimError
from nodesim.motion.rotation import LabRotationProfile, RateProfile
from nodesim.sensors.encoder import RotaryEncoder
from nodesim.sensors.magnetometer import (
    GeomagneticReference,
    MagnetometerModel,
    field_body,
    magnetic_survey,
    specific_force_body,
)
from nodesim.units import DEG

WB1 = Wellpath.from_degrees([(0, 0, 0), (2, 0.08, 248.2), (4, 0.32, 243.43), (10, 1.32, 257.47), (20, 3.41, 260.34)])


def test_lab_profile_thesis_timings_via_rate_profile():
    """Thesis 4.2.3 (digest 5.2): 50 s static, 2 turns at 3.6 deg/s (50-250 s), 10 s pause, 20 turns at 71 deg/s."""
    lab = LabRotationProfile(2 * DEG, 45 * DEG)
    rp = lab.rate_profile()
    assert rp.angle_rad(250.0) == pytest.approx(720 * DEG)
    assert rp.angle_rad(260.0) == pytest.approx(720 * DEG)
    end = 260 + 7200 / 71
    assert rp.angle_rad(end) == pytest.approx((720 + 7200) * DEG)
    assert rp.rate_rad_s(np.array([49.9, 50.0, 255.0, 300.0, end + 1]))[[0, 2, 4]].tolist() == [0.0, 0.0, 0.0]
    assert lab.rotation_end_s == pytest.approx(end) and end < 365  # rotation ends before the 370 s window


@settings(max_examples=30, deadline=None)
@given(st.floats(0.1, 50), st.floats(0.1, 100), st.floats(-2, 2))
def test_ramp_turns_half_rate_times_time_and_angle_is_integral_of_rate(ramp, hold, rate):
    rp = RateProfile.from_phases([("ramp", ramp, rate), ("hold", hold, 0.0), ("ramp", ramp, 0.0), ("stop", 5.0, 0.0)])
    assert rp.angle_rad(ramp) == pytest.approx(0.5 * rate * ramp, abs=1e-12)
    t = np.linspace(0, 2 * ramp + hold + 5, 20001)
    integral = np.concatenate([[0], np.cumsum(0.5 * (rp.rate_rad_s(t[1:]) + rp.rate_rad_s(t[:-1])) * np.diff(t))])
    assert np.allclose(rp.angle_rad(t), integral, atol=1e-3 * (abs(rate) * (ramp + hold) + 1e-9) + 1e-9)
    assert rp.angle_rad(t[-1]) == pytest.approx(rate * (ramp + hold), rel=1e-9, abs=1e-12)


def test_rate_profile_rejects_bad_phases():
    with pytest.raises(NodesimError, match="phase 1 .*duration_s"):
        RateProfile.from_phases([("ramp", 1.0, 1.0), ("hold", 0.0, 0.0)])
    with pytest.raises(NodesimError, match="kind 'spin'"):
        RateProfile.from_phases([("spin", 1.0, 1.0)])


def test_tube_insertion_adds_nodes_at_the_right_times():
    dp = DrillingProcess(WB1, tube_length_m=2.0, rop_m_s=0.01, survey_stop_s=30, insertion_s=60)
    assert dp.tubes == 10
    cycle = 200 + 30 + 60
    assert np.allclose(dp.insertion_times_s(), [0] + [cycle * k for k in range(1, 10)])
    assert dp.node_count(np.array([0.0, 289.9, 290.0, 290 * 9 + 1])).tolist() == [1, 1, 2, 10]
    assert dp.duration_s == pytest.approx(10 * 230 + 9 * 60)
    truth = dp.truth(np.array([289.0, 291.0]))
    assert truth.present[1].tolist() == [False, True] and np.isnan(truth.md_m[1, 0])
    # bit advances one tube per drilling phase; node k sits k tubes plus its offset above the bit
    assert dp.bit_md_m(230.0) == pytest.approx(2.0) and dp.bit_md_m(dp.duration_s) == pytest.approx(20.0)
    end = dp.truth(np.array([dp.duration_s]))
    assert np.allclose(end.md_m[:, 0], 20.0 - 2.0 * np.arange(10) - 1.0)


def test_yaw_and_inclination_continuous_and_frozen_during_pauses():
    dp = DrillingProcess(WB1, mount_yaw_rad=tuple(np.linspace(0, 3, 10)))
    t = np.linspace(0, dp.duration_s, 100_001)
    tr = dp.truth(t)
    step = t[1] - t[0]
    max_rate = dp.drilling_rate_rad_s * (1 + 1e-3)
    assert np.nanmax(np.abs(np.diff(tr.yaw_rad, axis=1))) <= max_rate * step + 1e-9
    assert np.nanmax(np.abs(np.diff(tr.inclination_rad, axis=1))) < 1e-4
    for start, end in dp.survey_windows_s():
        inside = (t > start) & (t < end)
        here = tr.present[:, inside].all(axis=1)
        assert np.ptp(tr.yaw_rad[here][:, inside], axis=1).max() == 0.0
        assert np.all(tr.spin_rate_rad_s[inside] == 0.0)
    # a node's yaw at insertion is its mounting yaw
    t_in = dp.insertion_times_s()
    at = dp.truth(t_in)
    assert np.allclose(np.diag(at.yaw_rad), np.linspace(0, 3, 10))


def test_nodes_reach_the_wellpath_attitude_and_toolface_resolves_azimuth():
    dp = DrillingProcess(WB1)
    tr = dp.truth(np.array([dp.duration_s - 1.0]))
    inc, azi = WB1.attitude_at(tr.md_m[:, 0])
    assert np.allclose(tr.inclination_rad[:, 0], inc)
    f = specific_force_body(tr.inclination_rad[:, 0], tr.azimuth_rad[:, 0], tr.yaw_rad[:, 0])
    inc_s, azi_s = resolve_survey(f, tr.yaw_rad[:, 0])
    assert np.allclose(inc_s, inc, atol=1e-12)
    assert np.allclose(np.remainder(tr.azimuth_rad[:, 0] - tr.yaw_rad[:, 0], 2 * np.pi), tr.toolface_rad[:, 0])
    deep = tr.inclination_rad[:, 0] > 0.5 * DEG
    assert np.allclose(np.remainder(azi_s[deep] - azi[deep] + np.pi, 2 * np.pi) - np.pi, 0, atol=1e-9)


def test_wellpath_interpolation_hits_stations_and_straight_hole_has_no_twist():
    inc, azi = WB1.attitude_at(WB1.md_m)
    assert np.allclose(inc, WB1.inclination_rad)
    straight = Wellpath.from_degrees([(0, 5, 30), (50, 5, 30)])
    assert abs(float(straight.twist_rad(50.0))) < 1e-12
    # twist of a constant-inclination turn (stations every degree of azimuth): (1 - cos I) * dA
    turn = Wellpath.from_degrees([(2.5 * k, 30, k) for k in range(41)])
    assert float(turn.twist_rad(100.0)) == pytest.approx((1 - math.cos(30 * DEG)) * 40 * DEG, rel=0.02)


@pytest.mark.parametrize(
    "kw,match",
    [
        ({"rop_m_s": 0.0}, "rop_m_s"),
        ({"ramp_s": 150.0}, "ramp"),
        ({"node_offset_m": 3.0}, "node_offset_m"),
        ({"n_tubes": 0}, "n_tubes"),
        ({"mount_yaw_rad": (0.0,)}, "mount_yaw_rad"),
    ],
)
def test_drilling_bad_parameters(kw, match):
    with pytest.raises(NodesimError, match=match):
        DrillingProcess(WB1, **kw)


def test_wellpath_bad_stations():
    with pytest.raises(NodesimError, match="station 2 MD"):
        Wellpath.from_degrees([(0, 0, 0), (2, 1, 0), (2, 1, 0)])
    with pytest.raises(NodesimError, match="station 1 inclination"):
        Wellpath.from_degrees([(0, 0, 0), (2, 190, 0)])


def test_encoder_quantisation_clock_offset_and_rate():
    enc = RotaryEncoder(1024)
    rng = np.random.default_rng(4)
    angles = rng.uniform(-50, 50, 200_000)
    r = enc.read(lambda t: t, angles)  # angle == time: read returns the quantised time
    assert np.std(r.yaw_rad - angles) == pytest.approx(0.1015 * DEG, rel=0.01)  # thesis digest 2.6
    assert np.all(np.abs(r.yaw_rad - angles) <= enc.step_rad / 2 + 1e-12)
    lab = LabRotationProfile(2 * DEG, 0.0)
    shifted = RotaryEncoder(1024, clock_offset_s=0.5).read(lab.yaw_rad, np.array([300.0]))
    plain = RotaryEncoder(1024).read(lab.yaw_rad, np.array([300.5]))
    assert shifted.counts.tolist() == plain.counts.tolist()
    rate = RotaryEncoder(1024, rate_window_s=1.0).read(lab.yaw_rad, np.array([150.0, 300.0]))
    assert np.allclose(rate.rate_rad_s, [3.6 * DEG, 71 * DEG], atol=enc.step_rad)
    with pytest.raises(NodesimError, match="counts_per_rev"):
        RotaryEncoder(0)


def test_magnetic_survey_round_trip_and_noise_effect():
    ref = GeomagneticReference(49_000, 67.0, 3.0)
    inc, azi, yaw = 10 * DEG, 100 * DEG, 2.0
    f = specific_force_body(inc, azi, yaw)
    m = field_body(ref, inc, azi, yaw)
    assert np.linalg.norm(m) == pytest.approx(49e-6)
    i2, a2 = magnetic_survey(f, m, ref.declination_deg)
    assert float(i2) == pytest.approx(inc) and float(a2) == pytest.approx(azi)
    noisy = MagnetometerModel(noise_sigma_t=100e-9).measure(np.tile(m, (2000, 1)), np.random.default_rng(0))
    _, a3 = magnetic_survey(np.tile(f, (2000, 1)), noisy, ref.declination_deg)
    err = np.std(a3 - azi)
    # horizontal field F cos(dip) = 19.1 uT; 100 nT noise across two horizontal axes -> ~0.3 deg
    assert 0.1 * DEG < err < 1.0 * DEG
    with pytest.raises(NodesimError, match="dip_deg"):
        GeomagneticReference(dip_deg=95.0)
    with pytest.raises(NodesimError, match="noise_sigma_t"):
        MagnetometerModel(noise_sigma_t=-1.0)


def test_node_imu_along_drilling_integrates_to_the_string_angle_and_reads_the_inclination():
    from nodesim.rng.streams import RunStreams
    from nodesim.sensors.catalogue import load_sensor
    from nodesim.sensors.imu import average_per_tick
    from nodesim.sensors.node_imu import simulate_node_imu

    dp = DrillingProcess(WB1)
    imu = load_sensor("MPU6500").imu_spec(gyro_bias_stability_deg_s=0.0)
    streams = RunStreams(seed=3, n_nodes=10)
    rec = simulate_node_imu(dp, imu, 0, 0.0, 600.0, streams.sensor(0, 0, "gyro"), streams.sensor(0, 0, "accel"))
    ticks = np.arange(1, int(600 * 1.9)) / 1.9
    z = average_per_tick(rec.t_s, rec.gyro.value, ticks)[:, 2]
    turned = np.sum(z) / 1.9
    expected = dp.rate_profile().angle_rad(ticks[-1]) - dp.rate_profile().angle_rad(0.0)
    # ARW 7.38e-3 deg/sqrt(s) over ~600 s -> ~0.18 deg; scale/misalignment residual 1e-3 of the turned angle
    assert abs(turned - expected) < 1e-3 * expected + 1.0 * DEG
    survey = (rec.t_s > 205) & (rec.t_s < 225)  # first survey stop, node 0 at MD 1 m
    f = rec.accel.value[survey].mean(axis=0)
    inc = math.atan2(math.hypot(f[0], f[1]), f[2])
    assert inc == pytest.approx(float(WB1.attitude_at(1.0)[0]), abs=0.1 * DEG)  # misalignment 1e-3 rad ~ 0.06 deg


@pytest.mark.parametrize("initial", [1, 4])
def test_node_truth_is_the_truth_row_bit_for_bit(initial):
    """DrillingProcess.node_truth (O(K) per node, what the chain's attitude uses) and truth (every node) are one
    implementation: equal arrays, NaN where the same, on the curved WB1 path at random times (before t = 0, before
    and after each insertion, at the phase boundaries)."""
    rng = np.random.default_rng(5)
    dp = DrillingProcess(WB1, mount_yaw_rad=tuple(rng.uniform(0, 6, 10)), initial_tubes=initial)
    t_in = dp.insertion_times_s()
    t = np.concatenate([rng.uniform(-100.0, dp.duration_s + 100.0, 4000), t_in, t_in - 1e-3,
                        [p.end_s for p in dp.phases()]])
    rng.shuffle(t)
    every = dp.truth(t)
    assert every.present.sum(axis=1)[initial:].min() < t.size  # some times are before an insertion
    for k in range(dp.tubes):
        one = dp.node_truth(k, t)
        assert np.array_equal(one.present, every.present[k])
        for key in ("md_m", "inclination_rad", "azimuth_rad", "yaw_rad", "toolface_rad"):
            assert np.array_equal(getattr(one, key), getattr(every, key)[k], equal_nan=True), (k, key)
        assert np.array_equal(one.spin_rate_rad_s, every.spin_rate_rad_s)
    with pytest.raises(NodesimError, match=r"node 10 does not exist \(allowed: 0..9\)"):
        dp.node_truth(10, t)


def test_initial_tubes_start_in_the_hole_and_the_programme_drills_the_rest():
    """M = 3 of 10 tubes in the hole at t = 0: the bit starts (M - 1) L deeper, the programme drills tube M - 1 (the
    top initial one) first: N - M + 1 drills and survey stops, N - M insertions, length
    (N - M + 1) (L / ROP + stop) + (N - M) insertion (module doc of nodesim.motion.drilling)."""
    L, rop, stop, ins, off = 2.0, 0.01, 30.0, 60.0, 1.0
    dp = DrillingProcess(WB1, tube_length_m=L, rop_m_s=rop, survey_stop_s=stop, insertion_s=ins, node_offset_m=off,
                         initial_tubes=3)
    phases = dp.phases()
    assert [p.tube for p in phases if p.name == "drill"] == list(range(2, 10))
    assert [p.tube for p in phases if p.name == "survey"] == list(range(2, 10))
    assert [p.tube for p in phases if p.name == "insertion"] == list(range(3, 10))
    assert dp.duration_s == pytest.approx(8 * (L / rop + stop) + 7 * ins)
    cycle = L / rop + stop + ins
    assert np.allclose(dp.insertion_times_s(), [0, 0, 0] + [cycle * j for j in range(1, 8)])
    assert dp.bit_start_md_m == 4.0 and dp.bit_md_m(0.0) == 4.0 and dp.bit_md_m(dp.duration_s) == pytest.approx(20.0)
    start = dp.truth(np.array([0.0]))
    assert start.present[:, 0].tolist() == [True] * 3 + [False] * 7
    assert start.md_m[:3, 0].tolist() == [4.0 - k * L - off for k in range(3)]  # the top one at -off, as tube 0 for M = 1
    assert dp.node_count(np.array([0.0, cycle - 1e-6, cycle])).tolist() == [3, 3, 4]
    # the initial nodes' yaw is the string angle from t = 0 on (plus the twist along the path)
    t = np.array([dp.duration_s])
    end = dp.truth(t)
    gamma = WB1.twist_rad(end.md_m[:3, 0]) - WB1.twist_rad(np.maximum(start.md_m[:3, 0], 0.0))
    assert np.allclose(end.yaw_rad[:3, 0], dp.rate_profile().angle_rad(t) + gamma, rtol=0, atol=1e-12)
    one = DrillingProcess(WB1, tube_length_m=L, rop_m_s=rop, survey_stop_s=stop, insertion_s=ins)
    assert one.bit_start_md_m == 0.0 and one.phases()[0] == type(phases[0])("drill", 0, 0.0, L / rop)


@pytest.mark.parametrize("initial", [0, 11, 2.5, -1])
def test_initial_tubes_out_of_range_is_an_error(initial):
    with pytest.raises(NodesimError, match=r"initial_tubes = .* must be an integer in \[1, 10\]"):
        DrillingProcess(WB1, initial_tubes=initial)


def test_process_parts_are_computed_once():
    """Phases, rate profile, insertion times and the wellpath's twist grid are cached on the (frozen) process: the
    same objects on every call, and a replaced process computes its own."""
    from dataclasses import replace

    dp = DrillingProcess(WB1)
    assert dp.phases() is dp.phases() and dp.rate_profile() is dp.rate_profile()
    assert dp.insertion_times_s() is dp.insertion_times_s() and not dp.insertion_times_s().flags.writeable
    assert WB1._twist_grid is WB1._twist_grid
    other = replace(dp, insertion_s=90.0)
    assert other.insertion_times_s()[1] == dp.insertion_times_s()[1] + 30.0


def test_node_timeline_holding_by_bisection_matches_the_intervals():
    from nodesim.motion.timelines import NodeTimeline

    holds = tuple((220.0 * j, 220.0 * j + 60.0) for j in range(1, 200))
    tl = NodeTimeline(1, 0.0, 60.0, holds, 220.0)
    t = np.concatenate([np.random.default_rng(2).uniform(-10, 45_000, 5000), [a for a, _ in holds], [b for _, b in holds]])
    assert [tl.holding(x) for x in t] == [any(a <= x < b for a, b in holds) for x in t]
    assert not NodeTimeline(1, 0.0, 60.0, (), 0.0).holding(100.0)
    with pytest.raises(NodesimError, match=r"holds\[1\] = \(5.0, 30.0\)"):
        NodeTimeline(1, 0.0, 60.0, ((0.0, 10.0), (5.0, 30.0)), 0.0)


@pytest.mark.parametrize("rows, bound_rad", [
    ([[0, 2, 120], [22, 6, 135]], 5e-9),  # the field scenario's path
    ([[0, 10, 0], [30, 40, 60], [60, 70, 100], [90, 80, 170]], 5e-8),  # doglegs of ~1 deg/m
    ([[0, 0.5, 10], [30, 30, 200], [60, 0.2, 10]], 1e-5),  # intervals passing near vertical
    ([[0, 0, 0], [100, 0, 0], [400, 30, 45], [1000, 90, 45]], 1e-5),  # vertical, build, horizontal
])
def test_attitude_along_is_the_minimum_curvature_attitude_within_its_bound(rows, bound_rad):
    """Wellpath.attitude_along (linear on a 1 cm grid with the stations on it) against the exact slerp of
    attitude_at at random MDs: inclination, and azimuth weighted by sin I (what reaches the sensors)."""
    from nodesim.motion.drilling import Wellpath

    wp = Wellpath.from_degrees(rows)
    md = np.random.default_rng(1).uniform(rows[0][0], rows[-1][0], 100_000)
    md = np.concatenate([md, wp.md_m])  # the stations themselves
    inc, azi = wp.attitude_at(md)
    inc2, azi2 = wp.attitude_along(md)
    assert np.abs(inc - inc2).max() < bound_rad
    assert np.abs(np.sin(inc) * np.angle(np.exp(1j * (azi - azi2)))).max() < bound_rad
    assert np.all((azi2 >= 0.0) & (azi2 < 2.0 * np.pi))


def _field_drilling(**overrides):
    from importlib import resources

    from nodesim.scenario.schema import load_scenario

    with resources.as_file(resources.files("scenarios") / "field" / "drilling_10_tubes.toml") as p:
        scenario, _ = load_scenario(p)
    return scenario.with_overrides(**overrides)


def test_a_straight_hole_shares_one_attitude_a_curved_one_or_a_turn_before_insertion_does_not():
    """ChainMotion.shared_attitude (drilling_timelines.straight_hole_attitude): in a straight hole every node's truth,
    from its first sensor sample on (two ticks before it is powered), is (theta(t), I, A) up to rounding; the field scenario's
    curved wellpath, or a survey stop shorter than the margin (the string still turning at the next node's first
    samples), gives None."""
    from nodesim.motion.chain_motion import build_motion

    straight = _field_drilling(**{"motion.wellpath": [[0.0, 5.0, 120.0], [22.0, 5.0, 120.0]]})
    motion = build_motion(straight)
    assert motion.shared_attitude is not None
    margin_s = 2.0 / straight.chain.firmware_rate_hz
    for i, tl in enumerate(motion.timelines):
        t = np.linspace(tl.present_from_s - margin_s, straight.simulation.duration_s, 4001)
        own, shared = motion.attitude(i, t), motion.shared_attitude(t)
        for key in ("yaw_rad", "inclination_rad", "azimuth_rad"):  # the same up to rounding (the slerp's, the mount's)
            assert np.allclose(getattr(own, key), getattr(shared, key), rtol=0.0, atol=1e-12), (i, key)
        assert np.all(shared.inclination_rad == 5.0 * DEG)
    assert build_motion(_field_drilling()).shared_attitude is None  # the scenario's build section
    short_stop = straight.with_overrides(**{"motion.survey_stop_s": 0.5, "motion.survey_settle_s": 0.25})
    assert build_motion(short_stop).shared_attitude is None


@settings(max_examples=40, deadline=None)
@given(inc_deg=st.floats(0.0, 180.0), azi_deg=st.floats(0.0, 359.999), stations=st.integers(2, 6),
       md=st.lists(st.one_of(st.floats(-50.0, 700.0), st.just(math.nan), st.just(math.inf), st.just(-math.inf)),
                   min_size=1, max_size=30))
def test_a_straight_hole_s_attitude_and_twist_are_the_interpolations_bit_for_bit(inc_deg, azi_deg, stations, md):
    """In a straight hole (every station at one inclination and azimuth) attitude_along and twist_rad return the
    constant without interpolating: the same bits as np.interp on their grids (NaN where the depth is NaN, the end
    values beyond the grid), arrays and scalars alike."""
    wp = Wellpath(np.linspace(0.0, 600.0, stations), np.full(stations, inc_deg * DEG), np.full(stations, azi_deg * DEG))
    grid, inc, azi = wp._attitude_grid
    assert np.all(inc == wp.inclination_rad[0])  # a straight interval's attitude is its stations', exactly
    assert np.all(azi == np.remainder(wp.azimuth_rad[0], 2.0 * math.pi))
    assert wp._constant_attitude is not None  # so attitude_along does not interpolate
    for x in (np.array(md), np.float64(md[0])):
        want_azi = np.interp(x, grid, azi)
        want_azi = want_azi if wp._azimuth_grid_wrapped else np.remainder(want_azi, 2.0 * math.pi)
        got_inc, got_azi = wp.attitude_along(x)
        tg, tv = wp._twist_grid
        for got, want in ((got_inc, np.interp(x, grid, inc)), (got_azi, want_azi), (wp.twist_rad(x), np.interp(x, tg, tv))):
            assert np.shape(got) == np.shape(want) and type(got) is type(want)
            assert np.array_equal(got, want, equal_nan=True)
            assert np.array_equal(np.signbit(got), np.signbit(want))


def test_a_curved_hole_s_attitude_is_interpolated():
    wp = Wellpath(np.array([0.0, 100.0, 200.0]), np.array([0.0, 10.0, 20.0]) * DEG, np.array([30.0, 30.0, 40.0]) * DEG)
    assert wp._constant_attitude is None
    md = np.linspace(0.0, 200.0, 77)
    grid, inc, azi = wp._attitude_grid
    assert np.array_equal(wp.attitude_along(md)[0], np.interp(md, grid, inc))
