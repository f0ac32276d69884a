"""Drilling process: tube insertions add a node at the top, held nodes resume their saved state, survey
stops every tube length hand the ground station one survey per station (thesis 2.7, field wellbores 4.1)."""

import csv
import json
import math
from pathlib import Path

import numpy as np
import pytest

from nodesim.chain.network import simulate_chain
from nodesim.motion.chain_motion import build_motion
from nodesim.cli.main import main
from nodesim.scenario.schema import Scenario, load_scenario
from nodesim.units import DEG, wrap_pi

REPO = Path(__file__).resolve().parents[3]
FIELD = REPO / "scenarios" / "field" / "drilling_10_tubes.toml"


def drilling(tubes=3, **over):
    per_tube = 60.0 + 120.0 + 40.0
    return Scenario().with_overrides(**{
        "motion.kind": "drilling", "chain.nodes": tubes, "simulation.duration_s": tubes * per_tube,
        "metrics.window_start_s": 0.0, "metrics.window_end_s": tubes * per_tube, **over})


def test_programme_inserts_the_bit_node_first_and_holds_the_nodes_below():
    motion = build_motion(drilling(3))
    by_id = {tl.node_id: tl for tl in motion.timelines}
    assert [by_id[i].present_from_s for i in (3, 2, 1)] == [0.0, 220.0, 440.0]
    assert by_id[3].filter_start_s == 60.0  # static bias window = its own insertion
    assert by_id[3].holds == ((220.0, 280.0), (440.0, 500.0))
    assert by_id[1].holds == ()
    assert by_id[3].is_top(100.0) and not by_id[3].is_top(230.0) and by_id[2].is_top(230.0)
    assert [(s.station, s.node_id) for s in motion.stops] == [(1, 3), (2, 3), (3, 3)]
    assert [s.md_m for s in motion.stops] == pytest.approx([1.0, 3.0, 5.0])  # node 1 m above the bit
    assert [s.t_survey_s for s in motion.stops] == [200.0, 420.0, 640.0]
    rot = motion.rotation
    assert rot.rate_rad_s(100.0) > 0 and rot.rate_rad_s(230.0) == 0 and rot.rate_rad_s(210.0) == 0
    # true yaw is continuous across the pauses
    t = np.array([179.999, 180.0, 180.001, 219.0, 280.0])
    assert np.all(np.diff(rot.yaw_rad(t)) >= 0) and rot.yaw_rad(219.0) == rot.yaw_rad(280.0)


def test_held_nodes_save_and_resume_their_yaw():
    run = simulate_chain(drilling(3, **{"simulation.realizations": 2}))
    bottom = run.nodes[2]
    hold = (bottom.t_s >= 220.0) & (bottom.t_s < 280.0)
    yaw = bottom.yaw_est_rad[:, hold]
    assert (yaw == yaw[:, :1]).all()  # state saved during the insertion above it
    assert not bottom.running[hold].any() and not bottom.update_mask[:, hold].any()
    after = (bottom.t_s >= 280.0) & (bottom.t_s < 300.0)
    # the new top node starts from an encoder yaw, asks the encoder at its next tick and forwards: from
    # then on the resumed node gets the wave again
    assert not bottom.update_mask[:, after][:, 0].any() and bottom.update_mask[:, after][:, 1:].all()
    new_top = run.nodes[1]
    assert np.isnan(new_top.yaw_est_rad[:, new_top.t_s < 220.0]).all()  # not inserted yet


def test_one_survey_per_station_reaches_the_ground_station():
    run = simulate_chain(drilling(3, **{"simulation.realizations": 2}))
    assert [g.packet.station for g in run.surveys] == [1, 2, 3]
    assert all(g.packet.valid.all() for g in run.surveys)
    # the survey climbs one hop per node present (plus, at station 1, the bottom node is the top node and
    # finishes its encoder request/reply before it sends)
    d = 0.015
    g1, g3 = run.surveys[0], run.surveys[2]
    assert np.all(abs((g1.arrival_s - g1.packet.t_s) - (2 * d + 1 * d)) < 1e-9)  # arrival per realization
    assert np.all(abs((g3.arrival_s - g3.packet.t_s) - 3 * d) < 1e-9)


def test_lossy_links_lose_surveys_and_the_table_says_so(tmp_path):
    from nodesim.api import simulate_scenario

    s = drilling(3, **{"simulation.realizations": 4, "chain.link_loss_probability": 0.4})
    out = simulate_scenario(s, None)
    out.save(tmp_path / "run", plots=False)
    rows = list(csv.DictReader((tmp_path / "run" / "surveys.csv").open()))
    assert len(rows) == 12
    received = [int(r["received"]) for r in rows]
    assert 0 < sum(received) < 12
    assert out.summary["surveys_received"] == sum(received) / 4


def _field_run(tmp_path, capsys, name: str, extra_toml: str = ""):
    """`nodesim run` of the bundled field scenario (plus ``extra_toml``): its summary and realization 0's surveys."""
    scenario = tmp_path / f"{name}.toml"
    scenario.write_text(FIELD.read_text() + extra_toml)
    out = tmp_path / name
    assert main(["run", str(scenario), "--out", str(out), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    rows = [r for r in csv.DictReader((out / "surveys.csv").open()) if r["realization"] == "0"]
    return out, summary, rows


def test_ten_tube_field_scenario_end_to_end(tmp_path, capsys):
    """Must-show of the chain issue: a 10-tube (20 m) drilling run hands the ground station one survey per
    station (drilling kinematics of nodesim.motion.drilling along a building, turning wellpath)."""
    out, summary, r0 = _field_run(tmp_path, capsys, "field")
    assert summary["nodes"] == 10 and summary["surveys_received"] == 10.0
    assert summary["node1_update_fraction"] > 0.9
    # the bottom node sits node_offset_m = 1 m above the bit: stations every 2 m from MD 1 m
    assert [float(r["md_m"]) for r in r0] == pytest.approx([2.0 * i - 1.0 for i in range(1, 11)])
    assert all(r["received"] == "1" and r["node"] == "10" for r in r0)
    true_inc = [float(r["true_inclination_deg"]) for r in r0]
    assert true_inc == sorted(true_inc) and 2.0 < true_inc[0] < true_inc[-1] < 6.0  # the building hole
    # sanity bounds, not sigma bounds: 20 s after a stop the yaw still carries part of the bias transient of the
    # rotation (residual scale-factor error), which the filter's P does not model; and the drilling programme
    # has no calibration rotation, so the node's residual sensor tilt (sigma, thesis table 4.20) stays: it moves
    # the inclination by up to the tilt and the azimuth by up to the tilt / sin I (thesis eq 1.3), here 4 sigma
    tilt_deg = Scenario().sensor.residual_tilt_sigma_deg
    for r, inc in zip(r0, true_inc):
        assert abs(float(r["inclination_deg"]) - inc) < 0.05 + 4 * tilt_deg
        lever = 4 * tilt_deg / np.sin(np.radians(inc))
        assert abs(float(r["azimuth_deg"]) - float(r["true_azimuth_deg"])) < 1.0 + lever
    assert {"timeseries.parquet", "yaw_error.png", "realizations.csv", "summary.json"} <= {p.name for p in out.iterdir()}
    # the ground station's uncertainty command reads the received surveys as they are
    assert main(["uncertainty", str(out / "ground_survey.csv"), "--tool", "mpu6500", "--json"]) == 0
    stations = json.loads(capsys.readouterr().out)["stations"]
    assert [s["md_m"] for s in stations] == pytest.approx([2.0 * i - 1.0 for i in range(1, 11)])


def test_ten_tube_field_scenario_without_the_residual_tilt(tmp_path, capsys):
    """The same field run with a perfectly calibrated sensor frame: what is left is the chain's own error (the
    bounds the field run had before the count model gave every node its residual tilt)."""
    _, summary, r0 = _field_run(tmp_path, capsys, "untilted", "\n[sensor]\nresidual_tilt_sigma_deg = 0.0\n")
    assert summary["node10_rms_azimuth_error_deg"] < 1.0
    for r in r0:
        assert abs(float(r["inclination_deg"]) - float(r["true_inclination_deg"])) < 0.05
        assert abs(float(r["azimuth_deg"]) - float(r["true_azimuth_deg"])) < 1.0


def test_survey_table_holds_the_bottom_nodes_firmware_values_at_the_survey_tick():
    from nodesim.chain.run_tables import survey_columns
    from nodesim.units import rad_to_deg

    run = simulate_chain(drilling(2, **{"simulation.realizations": 3}))
    table = survey_columns(run)
    bottom = run.nodes[-1]
    ticks = {g.packet.station: g.packet.tick for g in run.surveys}
    assert len(table["station"]) == 6
    for r, station, azi, inc in zip(table["realization"], table["station"], table["azimuth_deg"], table["inclination_deg"]):
        assert azi == rad_to_deg(bottom.azimuth_rad[r, ticks[station]])
        assert inc == rad_to_deg(bottom.inclination_rad[r, ticks[station]])


def test_rate_ramps_make_the_tick_mean_compensation_lag_hop_by_hop_and_extrapolation_shortens_it():
    """Eq 3.29 advances a forwarded estimate by the receiver's tick-mean rate, which is the rate half a tick
    ago: through a ramp (angular acceleration a) each hop adds about (dt - transfer)/2 x a x transfer, here
    (0.526 - 0.06)/2 x 12 deg/s^2 x 0.06 s = 0.17 deg, for the whole ramp, so the error grows with the hop
    count.  Extrapolating the rate linearly to the middle of the transfer removes the sustained lag; what is
    left is a one-tick overshoot where a ramp ends.  Noise-free sensors except the gyro white noise (so the
    filters follow their references)."""
    quiet = {
        "sensor.gyro_turn_on_bias_deg_s": 0.0, "sensor.gyro_residual_bias_deg_s": 0.0,
        "sensor.gyro_scale_factor_error": 0.0, "sensor.gyro_bias_instability_deg_s": 0.0,
        "sensor.accel_noise_ug_per_sqrt_hz": 0.0, "sensor.encoder_counts_per_rev": 1 << 24,
    }

    def errors(mode):
        run = simulate_chain(drilling(5, **quiet, **{"chain.rate_compensation": mode}))
        return [np.abs(wrap_pi(n.yaw_est_rad[0] - n.true_yaw_rad)[n.running]) / DEG for n in run.nodes]

    lag, ext = errors("tick_mean"), errors("extrapolated")
    worst = [float(e.max()) for e in lag]
    assert worst[0] < 0.05  # the top node uses the encoder
    assert all(b > a + 0.1 for a, b in zip(worst[1:], worst[2:]))  # grows ~0.17 deg per hop
    assert 0.5 < worst[-1] / (0.17 * 4) < 1.5
    rms = [float(np.sqrt(np.mean(e**2))) for e in lag]
    rms_ext = [float(np.sqrt(np.mean(e**2))) for e in ext]
    for a, b, ea, eb in zip(rms[1:], rms_ext[1:], lag[1:], ext[1:]):
        assert b < 0.35 * a  # the bottom node: 0.022 vs 0.099 deg
        assert (eb > 0.1).sum() < 0.3 * (ea > 0.1).sum()  # only the ramp-end ticks are left


def test_same_seed_same_run_directory_bytes(tmp_path):
    """Determinism of the chain issue: same scenario and seed -> identical tables (drilling, lossy links)."""
    from nodesim.api import simulate_scenario

    s = drilling(3, **{"simulation.realizations": 2, "chain.link_loss_probability": 0.2})
    for name in ("a", "b"):
        simulate_scenario(s, None).save(tmp_path / name, plots=False)
    for table in ("surveys.csv", "ground_survey.csv", "timeseries.parquet", "realizations.csv"):
        assert (tmp_path / "a" / table).read_bytes() == (tmp_path / "b" / table).read_bytes()
    other = simulate_scenario(s.with_overrides(seed=s.seed + 1), None)
    other.save(tmp_path / "c", plots=False)
    assert (tmp_path / "c" / "surveys.csv").read_bytes() != (tmp_path / "a" / "surveys.csv").read_bytes()
    assert other.summary["nodes"] == 3


@pytest.mark.parametrize("initial", [1, 3])
def test_field_programme_from_first_principles(initial):
    """The field scenario's motion (10 tubes, 2 m at 1 m/min: 120 s drilling, 40 s stop, 60 s insertion, 60 s at
    rest first, 60 deg/s with 5 s ramps) with motion.initial_tubes = M, against the programme worked out by hand:
    one tube cycle is 220 s; tube k >= M is inserted at 220 (k - M + 1) s; the stop of tube k (station k + 1) starts
    at 60 + 220 (k - M + 1) + 120 s with the bit at 2 (k + 1) m; a drilled tube turns the string by w (120 - 5) s
    (two 5 s ramps turn w 5 s); a node's yaw is the string angle since its insertion (its mount is the string
    angle then) plus the wellpath twist between its MDs.  M = 1 is the programme as it always was (the tests
    above); the numbers of the previous implementation were also checked bit for bit by hashes when M was added."""
    from nodesim.motion.drilling_timelines import drilling_process

    scenario, _ = load_scenario(FIELD)
    s = scenario.with_overrides(**{"motion.initial_tubes": initial})
    if initial == 1:
        assert build_motion(s).timelines == build_motion(scenario).timelines
    n, M, w = 10, initial, 60.0 * DEG
    motion = build_motion(s)
    by_id = {tl.node_id: tl for tl in motion.timelines}
    ins_start = [0.0] * M + [220.0 * (k - M + 1) for k in range(M, n)]  # by process node k (0 = bit)
    for k in range(n):
        tl = by_id[n - k]
        assert tl.present_from_s == pytest.approx(ins_start[k], abs=1e-9)
        assert tl.filter_start_s == pytest.approx(ins_start[k] + 60.0, abs=1e-9)
        holds = [(220.0 * (j - M + 1), 220.0 * (j - M + 1) + 60.0) for j in range(max(k + 1, M), n)]
        assert np.allclose(np.reshape(tl.holds, (-1, 2)), np.reshape(holds, (-1, 2)), rtol=0, atol=1e-9)
        top_until = math.inf if k == n - 1 else (220.0 * (k - M + 2) if k >= M - 1 else 0.0)
        assert tl.top_until_s == pytest.approx(top_until)
    assert [tl.node_id for tl in motion.timelines if tl.is_top(1.0)] == [n - M + 1]
    assert [(st.station, st.node_id) for st in motion.stops] == [(k + 1, n) for k in range(M - 1, n)]
    t_survey = [60.0 + 220.0 * (k - M + 1) + 120.0 + 20.0 for k in range(M - 1, n)]
    assert [st.t_survey_s for st in motion.stops] == pytest.approx(t_survey)
    assert [st.md_m for st in motion.stops] == pytest.approx([2.0 * (k + 1) - 1.0 for k in range(M - 1, n)])
    assert s.motion.drilling_duration_s(n) == pytest.approx(60.0 + (n - M + 1) * 160.0 + (n - M) * 60.0)
    proc = drilling_process(s)
    wp = proc.wellpath
    for k_stop, t in zip(range(M - 1, n), t_survey):
        theta = (k_stop - M + 2) * w * 115.0
        for j in range(k_stop + 1):  # the nodes present at this stop
            att = motion.attitude(n - 1 - j, np.array([t]))
            md = 2.0 * (k_stop + 1) - 2.0 * j - 1.0
            md_in = 2.0 * (M - 1 - j) - 1.0 if j < M else -1.0  # MD at insertion (the bit at 2 j m)
            gamma = float(wp.twist_rad(md) - wp.twist_rad(max(md_in, 0.0)))
            inc, azi = wp.attitude_at(md)
            assert float(att.yaw_rad[0]) == pytest.approx(theta + gamma, abs=1e-9)
            assert float(att.inclination_rad[0]) == pytest.approx(float(inc), abs=1e-12)
            assert float(att.azimuth_rad[0]) == pytest.approx(float(azi), abs=1e-12)
    # before the filter start every node present rests as at t = 0 (the initial ones) or as at its insertion
    assert float(motion.attitude(n - 1, np.array([10.0])).yaw_rad[0]) == 0.0


def test_initial_tubes_run_on_the_event_engine():
    """Three of five tubes in the hole at t = 0 (SimPy engine): the three nodes average their gyros over the first
    60 s and run from then on; node 3, the top initial one, uses the encoder until tube 4 is inserted; all three hold
    during both insertions; stations 3..5 reach the ground station."""
    s = drilling(5, **{"motion.initial_tubes": 3, "simulation.duration_s": 60.0 + 3 * 160.0 + 2 * 60.0,
                       "metrics.window_end_s": 660.0, "simulation.engine": "event"})
    run = simulate_chain(s)
    for node in run.nodes[2:]:
        assert not node.running[node.t_s < 60.0].any() and node.running[(node.t_s > 62.0) & (node.t_s < 220.0)].all()
        for a, b in ((220.0, 280.0), (440.0, 500.0)):
            hold = (node.t_s >= a) & (node.t_s < b)
            assert not node.running[hold].any() and (node.yaw_est_rad[:, hold] == node.yaw_est_rad[:, hold][:, :1]).all()
    # node 3 is the top node before the first insertion: the encoder updates it every tick; node 4 gets them forwarded
    early = (run.nodes[2].t_s > 62.0) & (run.nodes[2].t_s < 180.0)
    assert run.nodes[2].update_mask[:, early].all() and run.nodes[3].update_mask[:, early].mean() > 0.9
    assert [g.packet.station for g in run.surveys] == [3, 4, 5]
    assert all(g.packet.valid.all() and g.packet.node_id == 5 for g in run.surveys)


def test_survey_nodes_all_sends_every_present_nodes_survey_and_the_ground_survey_keeps_the_bottom_ones(tmp_path):
    """motion.survey_nodes = "all" (SimPy engine): at each stop every node present takes its survey at the stop's
    survey time at its own MD and sends it up: one ground survey per present node per station, each with its node
    id.  The ground survey (what the wellpath and its covariance are built from) and the metric windows stay one
    per station, the bottom node's: the same as with "bottom"."""
    from nodesim.api import simulate_scenario

    n, M = 4, 2
    over = {"motion.initial_tubes": M, "simulation.duration_s": 60.0 + 3 * 160.0 + 2 * 60.0,
            "metrics.window_end_s": 660.0, "simulation.realizations": 2, "simulation.engine": "event"}
    bottom = drilling(n, **over)
    every = bottom.with_overrides(**{"motion.survey_nodes": "all"})
    motion = build_motion(every)
    assert motion.metric_windows == build_motion(bottom).metric_windows and len(motion.metric_windows) == n - M + 1
    run = simulate_chain(every)
    got = sorted((g.packet.station, g.packet.node_id) for g in run.surveys)
    # station s is the stop of tube s - 1: process nodes 0 .. s - 1 (ids n .. n - s + 1) are in the hole
    assert got == sorted((st, n - k) for st in range(M, n + 1) for k in range(st))
    t_survey = {st.station: st.t_survey_s for st in motion.stops if st.node_id == n}
    for g in run.surveys:
        p = g.packet
        assert p.valid.all() and np.all(g.arrival_s > p.t_s)
        assert t_survey[p.station] <= p.t_s < t_survey[p.station] + 1.0 / 1.9  # its first tick at or after
        assert p.md_m == pytest.approx(2.0 * p.station - 2.0 * (n - p.node_id) - 1.0)  # bit at 2 x station m
    a, b = simulate_scenario(bottom, None), simulate_scenario(every, None)
    assert b.summary["surveys_received"] == len(got) and a.summary["surveys_received"] == n - M + 1
    assert a.ground_survey.equals(b.ground_survey) and len(b.ground_survey) == n - M + 1
    table = b.surveys
    assert len(table) == 2 * len(got)
    assert sorted(zip(table["station"][table["realization"] == 0], table["node"][table["realization"] == 0])) == got
    b.save(tmp_path / "all", plots=False)
    rows = list(csv.DictReader((tmp_path / "all" / "ground_survey.csv").open()))
    assert [float(r["md_m"]) for r in rows] == pytest.approx([2.0 * st - 1.0 for st in range(M, n + 1)])


def test_drilling_day_scenario_is_its_programme_exactly_and_cheap_to_set_up():
    """scenarios/perf/drilling_day_1000.toml: 1000 tubes, 785 in the hole, 24 h at 24 m/h: its duration is the
    programme, 60 + 216 (2 / (24 / 3600) + 40) + 215 x 60 s; its motion builds (the truth is per node, no
    whole-chain truth per survey stop); its soil hops lose about 10 % of the estimate frames per try (the comment's PER, from the link
    budget)."""
    from nodesim.chain.radio import hop_channels
    from nodesim.rng.streams import RunStreams

    s, _ = load_scenario(REPO / "scenarios" / "perf" / "drilling_day_1000.toml")
    n, M = 1000, 785
    assert (s.chain.nodes, s.motion.initial_tubes, s.filter.implementation) == (n, M, "fixed")
    assert s.simulation.duration_s == s.motion.drilling_duration_s(n) == 60 + 216 * (2 / (24 / 3600) + 40) + 215 * 60
    motion = build_motion(s)
    assert [st.station for st in motion.stops] == list(range(M, n + 1)) and {st.node_id for st in motion.stops} == {n}
    assert motion.stops[-1].end_s == pytest.approx(s.simulation.duration_s)
    assert motion.stops[0].md_m == pytest.approx(2.0 * M - 1.0) and motion.stops[-1].md_m == pytest.approx(2.0 * n - 1.0)
    assert [tl.node_id for tl in motion.timelines if tl.present_from_s == 0.0] == list(range(n - M + 1, n + 1))
    assert motion.timelines[n - M].top_until_s == pytest.approx(60.0 + 300.0 + 40.0)  # node 216 until tube 785's insertion
    small = s.with_overrides(**{"chain.nodes": 3, "motion.initial_tubes": 1, "simulation.duration_s": 1300.0,
                                "metrics.window_end_s": 1300.0})
    hops, _ = hop_channels(small, RunStreams(seed=1, n_nodes=3), 1)
    assert hops[0].per_data(np.array([100.0]))[0] == 0.0  # the cable to the top node
    assert float(hops[1].per_data(np.array([100.0]))[0]) == pytest.approx(0.108, abs=0.001)
