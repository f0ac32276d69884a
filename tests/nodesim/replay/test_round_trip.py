"""Record -> replay: a simulated run written with ``nodesim run --record`` and replayed with the same firmware
configuration gives bit-identical firmware outputs; an imposed timeout schedule on a continuous recording
reproduces, on the same data, the simulated timeout schedule (and its error growth)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from nodesim.chain.network import simulate_chain
from nodesim.cli.main import main
from nodesim.replay.chain_log import record_chain_run
from nodesim.replay.session import replay
from nodesim.scenario.schema import load_scenario
from nodesim.units import rad_to_deg, wrap_pi

LAB = Path(__file__).resolve().parents[3] / "scenarios" / "lab"


def short_lab(tmp_path: Path, text_edits: dict[str, str], name: str) -> tuple[Path, object]:
    """continuous.toml with some lines replaced (``key = value`` by key), written to tmp_path."""
    lines = (LAB / "continuous.toml").read_text().splitlines()
    if "duration_s" in text_edits:  # keep the metrics window inside the run
        d = float(text_edits["duration_s"])
        text_edits = {"window_start_s": repr(d / 2), "window_end_s": repr(d), **text_edits}
    done = set()
    for i, line in enumerate(lines):
        key = line.split("=")[0].strip()
        if key in text_edits and key not in done:
            lines[i] = f"{key} = {text_edits[key]}"
            done.add(key)
    missing = set(text_edits) - done
    assert not missing, f"keys not in continuous.toml: {missing}"
    path = tmp_path / f"{name}.toml"
    path.write_text("\n".join(lines) + "\n")
    return path, load_scenario(path)[0]


def outputs(run, node: int = 0):
    n = run.nodes[node]
    return n.yaw_est_rad[0], n.yaw_var_rad2[0], n.bias_est_rad_s[0], n.inclination_rad[0], n.azimuth_rad[0]


def replayed(outcome, node: int = 0):
    r = outcome.replays[node]
    return r.yaw_rad, r.yaw_var_rad2, r.bias_rad_s, r.inclination_rad, r.azimuth_rad


def assert_bit_identical(a, b):
    for x, y in zip(a, b):
        assert x.shape == y.shape
        assert np.array_equal(x, y, equal_nan=True)


@pytest.mark.parametrize("suffix", ["csv", "parquet"])
def test_record_then_replay_is_bit_identical(tmp_path, suffix):
    cfg, scenario = short_lab(tmp_path, {"duration_s": "420.0"}, "lab")
    run = simulate_chain(scenario)
    log = record_chain_run(tmp_path / f"lab.{suffix}", run, scenario)
    out = replay(log, cfg, write=False)
    assert out.summary["schedule"] == "recorded"
    assert_bit_identical(outputs(run), replayed(out))
    assert out.summary["bit_identical"] is True and out.summary["first_divergence"] is None
    assert np.array_equal(out.replays[0].update, run.nodes[0].update_mask[0])


def test_fixed_point_two_node_chain_round_trip(tmp_path):
    cfg, scenario = short_lab(tmp_path, {"duration_s": "300.0", "nodes": "2", "implementation": '"fixed"'}, "two")
    run = simulate_chain(scenario)
    log = record_chain_run(tmp_path / "two.csv", run, scenario)
    out = replay(log, cfg, write=False)
    for k in range(2):
        assert_bit_identical(outputs(run, k), replayed(out, k))
    assert out.summary["bit_identical"] is True
    # frames included: the replay re-encodes, from its own firmware words, every frame the top node sent
    frame = out.summary["comparison"]["1"]["frame"]
    sent = int((run.nodes[0].estimate_frames[0, :, 0] != 0).sum())
    assert frame["compared_ticks"] == sent > 100 and frame["identical_ticks"] == sent
    assert np.array_equal(out.replays[0].frames, run.nodes[0].estimate_frames[0])
    assert "frame" not in out.summary["comparison"]["2"] or out.summary["comparison"]["2"]["frame"]["compared_ticks"] == 0


def test_a_changed_frame_in_the_log_is_a_divergence_naming_its_line(tmp_path):
    """One recorded frame re-encoded with another yaw word (a valid frame, CRC and all): the replay's frame
    differs there, and the first divergence gives its tick and line."""
    from firmware_model import frames as fr

    cfg, scenario = short_lab(tmp_path, {"duration_s": "200.0", "nodes": "2", "implementation": '"fixed"'}, "two")
    run = simulate_chain(scenario)
    log = record_chain_run(tmp_path / "two.csv", run, scenario)
    lines = log.read_text().splitlines()
    names = next(line for line in lines if not line.startswith("#")).split(",")
    col = names.index("frame")
    i = next(j for j, line in enumerate(lines) if not line.startswith("#") and len(line.split(",")[col]) == 54)
    cells = lines[i].split(",")
    values, _ = fr.decode(fr.ESTIMATE, np.frombuffer(bytes.fromhex(cells[col]), np.uint8)[None])
    values[0, fr.EST_YAW] += 1
    cells[col] = fr.encode(fr.ESTIMATE, values)[0][0].tobytes().hex()
    lines[i] = ",".join(cells)
    log.write_text("\n".join(lines) + "\n")
    out = replay(log, cfg, write=False)
    assert out.summary["bit_identical"] is False
    first = out.summary["first_divergence"]
    assert first["quantity"] == "frame" and first["line"] == i + 1 and first["diff"] >= 1
    assert first["recorded"] == cells[col]


def test_short_word_fixed_point_round_trip(tmp_path):
    """filter.fixed_word_bits reaches both the simulated and the replayed firmware (same formats)."""
    cfg, _ = short_lab(tmp_path, {"duration_s": "300.0", "implementation": '"fixed"'}, "w20")
    cfg.write_text(cfg.read_text().replace('implementation = "fixed"', 'implementation = "fixed"\nfixed_word_bits = 20'))
    scenario = load_scenario(cfg)[0]
    assert scenario.filter.fixed_word_bits == 20
    run = simulate_chain(scenario)
    out = replay(record_chain_run(tmp_path / "w20.csv", run, scenario), cfg, write=False)
    assert_bit_identical(outputs(run), replayed(out))
    full = simulate_chain(scenario.with_overrides(**{"filter.fixed_word_bits": 32}))
    assert not np.array_equal(outputs(full)[0], outputs(run)[0])  # 12 fewer fraction bits change the output


def test_first_divergence_names_tick_and_line(tmp_path):
    """A changed gyro sample makes the model leave the recorded firmware exactly at that tick."""
    cfg, scenario = short_lab(tmp_path, {"duration_s": "200.0"}, "div")
    log = record_chain_run(tmp_path / "div.csv", simulate_chain(scenario), scenario)
    lines = log.read_text().splitlines()
    names = next(line for line in lines if line.startswith("node,")).split(",")
    first_data = next(i for i, line in enumerate(lines) if line.startswith("node,")) + 1
    tick = 250
    cells = lines[first_data + tick].split(",")
    cells[names.index("gyro_z")] = repr(float(cells[names.index("gyro_z")]) + 1e-4)
    lines[first_data + tick] = ",".join(cells)
    log.write_text("\n".join(lines) + "\n")
    out = replay(log, cfg, write=False)
    first = out.summary["first_divergence"]
    assert out.summary["bit_identical"] is False
    assert first["tick"] == tick and first["line"] == first_data + tick + 1
    assert first["quantity"] in ("fw_yaw", "fw_yaw_var", "fw_bias", "fw_azimuth")
    yaw = out.summary["comparison"]["1"]["fw_yaw"]
    assert yaw["first_divergence"]["tick"] == tick and yaw["identical_ticks"] == tick
    # a tolerance above the effect (1e-4 rad/s for one 0.53 s tick: ~3e-3 deg) reports no divergence in yaw
    loose = replay(log, cfg, write=False, tolerances={"fw_yaw": 0.01, "fw_yaw_var": 1.0, "fw_bias": 1.0,
                                                      "fw_inclination": 1.0, "fw_azimuth": 0.01})
    assert loose.summary["first_divergence"] is None and loose.summary["bit_identical"] is False


def timeout_error_growth(t, yaw, true_yaw, update_s=20.0, timeout_s=30.0, after_s=400.0):
    """Largest |yaw error| (deg) inside each timeout window after ``after_s`` (when the string is still)."""
    err = np.abs(rad_to_deg(wrap_pi(yaw - true_yaw)))
    period = update_s + timeout_s
    phase = np.remainder(t, period)
    cycles = np.floor(t / period)
    out = []
    for c in np.unique(cycles[(t > after_s) & (phase >= update_s)]):
        sel = (cycles == c) & (phase >= update_s)
        out.append(err[sel].max())
    return np.array(out)


def test_imposed_timeout_schedule_reproduces_the_simulated_schedule(tmp_path):
    """Continuous recording + imposed windowed 20 s / 30 s = the windowed simulation on the same sensor data."""
    cfg, continuous = short_lab(tmp_path, {"duration_s": "700.0"}, "cont")
    log = record_chain_run(tmp_path / "cont.csv", simulate_chain(continuous), continuous)
    imposed = replay(log, cfg, schedule="windowed:20:30", write=False)
    windowed = continuous.with_overrides(**{"schedule.mode": "windowed", "schedule.update_s": 20.0,
                                            "schedule.timeout_s": 30.0})
    sim = simulate_chain(windowed)
    assert_bit_identical(outputs(sim), replayed(imposed))
    n = sim.nodes[0]
    grow_sim = timeout_error_growth(n.t_s, n.yaw_est_rad[0], n.true_yaw_rad)
    grow_rep = timeout_error_growth(imposed.replays[0].t_s, imposed.replays[0].yaw_rad, n.true_yaw_rad)
    assert np.array_equal(grow_sim, grow_rep) and grow_sim.size >= 5
    # and the timeouts do let the error grow: above the continuous run's error in the same windows
    recorded = replay(log, cfg, write=False)
    grow_cont = timeout_error_growth(n.t_s, recorded.replays[0].yaw_rad, n.true_yaw_rad)
    assert grow_rep.mean() > 1.5 * grow_cont.mean()


def test_cli_run_record_then_replay_json(tmp_path, capsys):
    cfg, _ = short_lab(tmp_path, {"duration_s": "150.0"}, "cli")
    log = tmp_path / "cli.csv"
    assert main(["run", str(cfg), "--out", str(tmp_path / "run"), "--record", str(log), "--json"]) == 0
    capsys.readouterr()
    assert main(["replay", str(log), "--firmware", str(cfg), "--out", str(tmp_path / "rep"), "--json", "--no-plots"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["bit_identical"] is True and summary["yaw_error_reference"] == "truth"
    for name in ("summary.json", "manifest.json", "timeseries.csv", "comparison.csv"):
        assert (tmp_path / "rep" / name).is_file()
    # bad schedule text: one clear line, exit 2
    assert main(["replay", str(log), "--firmware", str(cfg), "--schedule", "windowed:20", "--no-plots",
                 "--out", str(tmp_path / "bad")]) == 2
    assert "windowed:UPDATE_S:TIMEOUT_S" in capsys.readouterr().err and not (tmp_path / "bad").exists()


def test_drilling_run_with_insertions_round_trips(tmp_path):
    """Three tubes of the field drilling scenario (per-node static windows, holds during tube insertions,
    forwarded references): the log's ``static``/``hold``/``ref_*`` columns make the replay bit-identical."""
    field = Path(__file__).resolve().parents[3] / "scenarios" / "field" / "drilling_10_tubes.toml"
    text = field.read_text().replace("nodes = 10", "nodes = 3").replace("duration_s = 2200.0", "duration_s = 700.0")
    text = text.replace("realizations = 4", "realizations = 2").replace("window_end_s = 2200.0", "window_end_s = 700.0")
    cfg = tmp_path / "drill.toml"
    cfg.write_text(text)
    scenario = load_scenario(cfg)[0]
    run = simulate_chain(scenario)
    assert any(not n.running[np.searchsorted(n.t_s, n.filter_start_s) + 1:].all() for n in run.nodes)  # holds occur
    log = record_chain_run(tmp_path / "drill.parquet", run, scenario, realization=1)
    out = replay(log, cfg, write=False)
    for k in range(3):
        n = run.nodes[k]
        present = n.t_s >= n.present_from_s
        mine = replayed(out, k)
        theirs = (n.yaw_est_rad[1], n.yaw_var_rad2[1], n.bias_est_rad_s[1], n.inclination_rad[1], n.azimuth_rad[1])
        assert_bit_identical([x[present] for x in theirs], mine)
    assert out.summary["bit_identical"] is True


def test_fixed_point_drilling_run_round_trips_with_its_frames(tmp_path):
    """The fixed firmware on three tubes of the field drilling run: nodes power up at their insertion, so a
    frame's seq counts the ticks since then; the replay re-encodes every frame bit for bit."""
    field = Path(__file__).resolve().parents[3] / "scenarios" / "field" / "drilling_10_tubes.toml"
    text = field.read_text().replace("nodes = 10", "nodes = 3").replace("duration_s = 2200.0", "duration_s = 700.0")
    text = text.replace("realizations = 4", "realizations = 1").replace("window_end_s = 2200.0", "window_end_s = 700.0")
    cfg = tmp_path / "drill.toml"
    cfg.write_text(text + '\n[filter]\nimplementation = "fixed"\n' if "[filter]" not in text else
                   text.replace("[filter]", '[filter]\nimplementation = "fixed"'))
    scenario = load_scenario(cfg)[0]
    assert scenario.filter.implementation == "fixed"
    run = simulate_chain(scenario)
    out = replay(record_chain_run(tmp_path / "drill.csv", run, scenario), cfg, write=False)
    assert out.summary["bit_identical"] is True
    compared = [out.summary["comparison"][str(n.node_id)].get("frame", {}).get("compared_ticks", 0) for n in run.nodes]
    assert sum(compared) > 50
    for rep, n in zip(out.replays, run.nodes):
        present = n.t_s >= n.present_from_s
        assert np.array_equal(rep.frames, n.estimate_frames[0][present])
    late = [n for n in run.nodes if n.present_from_s > 0 and (n.estimate_frames[0, :, 0] != 0).any()]
    assert late  # a node inserted later sent frames: its seq starts at its power-up
