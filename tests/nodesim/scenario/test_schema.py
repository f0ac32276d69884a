"""Scenario validation: every kind of bad input gets one clear message and writes nothing."""

import pytest

from nodesim.cli.main import main
from nodesim.errors import ScenarioError
from nodesim.scenario.schema import Scenario, load_scenario, parse_scenario


def test_defaults_are_valid_and_frozen():
    s = Scenario()
    assert s.chain.firmware_rate_hz == 1.9
    with pytest.raises(Exception):
        s.chain.nodes = 3  # frozen


def test_bundled_lab_scenario_loads(lab_toml):
    scenario, digest = load_scenario(lab_toml)
    assert scenario.name == "lab-continuous"
    assert scenario.sensor.encoder_counts_per_rev == 1024
    assert len(digest) == 64


BAD_CASES = [
    # (toml text, key path named in the message, fragment of the allowed range/problem)
    ('bogus = 1\n', "bogus", "unknown key"),
    ('[chain]\nnodez = 2\n', "chain.nodez", "unknown key"),
    ('[unknown_section]\nx = 1\n', "unknown_section", "unknown key"),
    ('[chain]\nlink_delay_s = -0.1\n', "chain.link_delay_s", "greater than or equal to 0"),
    ('[chain]\nlink_loss_probability = 1.5\n', "chain.link_loss_probability", "less than or equal to 1"),
    ('[chain]\nlink_loss_probability = -0.1\n', "chain.link_loss_probability", "greater than or equal to 0"),
    ('[chain]\nfirmware_rate_hz = 0.0\n', "chain.firmware_rate_hz", "greater than 0"),
    ('[schedule]\nsingle_rate_hz = -1.0\n', "schedule.single_rate_hz", "greater than 0"),
    ('[chain]\nnodes = 0\n', "chain.nodes", "greater than or equal to 1"),
    ('[chain]\nnodes = "three"\n', "chain.nodes", "valid integer"),
    ('[chain]\nnodes = 1.5\n', "chain.nodes", "valid integer"),
    ('[simulation]\nduration_s = "long"\n', "simulation.duration_s", "valid number"),
    ('[schedule]\nmode = "sometimes"\n', "schedule.mode", "'continuous'"),
    ('[sensor]\ngyro_arw_deg_per_sqrt_s = -1e-3\n', "sensor.gyro_arw_deg_per_sqrt_s", "greater than or equal to 0"),
    ('[motion]\ninclination_deg = 190.0\n', "motion.inclination_deg", "less than or equal to 180"),
    ('[filter]\nb_tuning = "linear"\n', "filter.b_tuning", "'noise_gain' or 'process_noise'"),
    ('[metrics]\nwindow_start_s = 500.0\nwindow_end_s = 400.0\n', "metrics", "must be greater than window_start_s"),
    ('[simulation]\nduration_s = 100.0\n', "<top level>", "must not exceed simulation.duration_s"),
    ('[schedule]\nmode = "arbitrary"\nwindows = [[-5.0, 10.0, 1.0]]\n', "schedule", "windows[0] = [-5.0, 10.0, 1.0]: start_s and stop_s must be >= 0"),
    ('[schedule]\nmode = "arbitrary"\nwindows = [[0.0, 100.0, 1.0], [50.0, 200.0, 1.0]]\n', "schedule", "windows[1] = [50.0, 200.0, 1.0] overlaps"),
    ('[schedule]\nmode = "arbitrary"\nwindows = [[0.0, 100.0, 0.0]]\n', "schedule", "rate_hz must be in (0, 1000]"),
    ('[schedule]\nmode = "arbitrary"\nwindows = [[10.0, 5.0, 1.0]]\n', "schedule", "stop_s must be greater than start_s"),
    ('[schedule]\nmode = "arbitrary"\nwindows = [[0.0, 5.0]]\n', "schedule", "windows[0] must be [start_s, stop_s, rate_hz]"),
    ('[schedule]\nmode = "arbitrary"\n', "schedule", "needs windows"),
    ('[schedule]\nmode = "windowed"\nwindows = [[0.0, 5.0, 1.0]]\n', "schedule", "only used with mode = 'arbitrary'"),
    ('[schedule]\nsingle_rate_hz = 0.0\n', "schedule.single_rate_hz", "greater than 0"),
    ('[chain]\nnodes = 2\n[[chain.node]]\nid = 0\n', "chain.node.0.id", "greater than or equal to 1"),
    ('[chain]\nnodes = 2\n[[chain.node]]\nid = 2\n[[chain.node]]\nid = 2\n', "<top level>", "chain.node[1].id = 2: node id given twice"),
    ('[chain]\nnodes = 2\n[[chain.node]]\nid = 1\nclock_offset_s = -1.0\n', "chain.node.0.clock_offset_s", "greater than or equal to 0"),
    ('[chain]\nlink_delay_s = 0.3\n', "<top level>", "must fit in one firmware tick"),
    ('[motion]\nkind = "drilling"\n[chain]\nnodes = 10\n', "<top level>", "must cover the drilling programme of 10 tubes"),
    ('[motion]\nkind = "drilling"\nsurvey_stop_s = 10.0\nsurvey_settle_s = 20.0\n', "motion", "must be less than survey_stop_s"),
    ('[motion]\nkind = "spinning"\n', "motion.kind", "'lab'"),
    ('[motion]\nwellpath = [[0.0, 1.0, 2.0]]\n', "motion", "wellpath is only used with kind = 'drilling'"),
    ('[motion]\nkind = "drilling"\nwellpath = [[0.0, 1.0]]\n', "motion", "wellpath[0] must be [md_m, inclination_deg, azimuth_deg]"),
    ('[motion]\nkind = "drilling"\nwellpath = [[0.0, 1.0, 2.0], [0.0, 2.0, 3.0]]\n', "motion", "wellpath[1] = [0.0, 2.0, 3.0]: MD must increase"),
    ('[motion]\nkind = "drilling"\nwellpath = [[0.0, 190.0, 2.0]]\n', "motion", "inclination must be in [0, 180]"),
    ('[motion]\nkind = "drilling"\nramp_s = 70.0\n', "motion", "ramp_s (70.0): two ramps must fit"),
    ('[motion]\nkind = "drilling"\ninitial_tubes = 0\n', "motion.initial_tubes", "greater than or equal to 1"),
    ('[motion]\nkind = "drilling"\ninitial_tubes = 2.5\n', "motion.initial_tubes", "valid integer"),
    ('[motion]\nkind = "drilling"\ninitial_tubes = "many"\n', "motion.initial_tubes", "valid integer"),
    ('[motion]\nkind = "drilling"\ninitial_tubes = 4\n[chain]\nnodes = 3\n', "motion.initial_tubes = 4",
     "allowed: 1 <= motion.initial_tubes <= chain.nodes = 3"),
    ('[motion]\ninitial_tubes = 2\n[chain]\nnodes = 3\n', "motion", "initial_tubes (2) is only used with kind = 'drilling'"),
    ('[motion]\nkind = "drilling"\nsurvey_nodes = "some"\n', "motion.survey_nodes", "'bottom'"),
    ('[motion]\nsurvey_nodes = "all"\n', "motion", "survey_nodes = 'all' is only used with kind = 'drilling'"),
    ('[motion]\nkind = "drilling"\ninitial_tubes = 3\n[chain]\nnodes = 10\n', "<top level>",
     "must cover the drilling programme of 10 tubes, 3 of them in the hole at the start (motion.initial_tubes): "
     "motion.initial_static_s + 8 x (tube_length_m / rate_of_penetration_m_s + survey_stop_s) + 7 x insertion_s "
     "(allowed: >= 1760 s)"),
]


@pytest.mark.parametrize("text,key,fragment", BAD_CASES, ids=[c[1] + ":" + c[2][:20] for c in BAD_CASES])
def test_bad_scenario_is_rejected_with_key_and_range(write_toml, text, key, fragment):
    path = write_toml(text)
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    msg = str(info.value)
    assert str(path) in msg
    assert key in msg
    assert fragment in msg


@pytest.mark.parametrize("text,key,fragment", BAD_CASES[:6], ids=[c[1] for c in BAD_CASES[:6]])
def test_cli_rejects_bad_scenario_exit_2_and_writes_nothing(write_toml, tmp_path, capsys, text, key, fragment):
    path = write_toml(text)
    out = tmp_path / "run-out"
    code = main(["run", str(path), "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2
    assert key in err and "Traceback" not in err
    assert not out.exists()


def test_not_toml_and_missing_file_are_clear(write_toml, tmp_path):
    with pytest.raises(ScenarioError, match="not valid TOML"):
        load_scenario(write_toml("name = [unclosed\n"))
    with pytest.raises(ScenarioError, match="cannot read scenario file"):
        load_scenario(tmp_path / "nope.toml")


def test_unknown_node_id_is_a_clear_error_and_writes_nothing(write_toml, tmp_path, capsys):
    path = write_toml('[chain]\nnodes = 3\n[[chain.node]]\nid = 4\nclock_offset_s = 0.1\n')
    out = tmp_path / "run-out"
    assert main(["run", str(path), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "chain.node[0].id = 4" in err and "allowed: 1..3" in err
    assert not out.exists()


def test_overrides_are_revalidated():
    s = Scenario()
    assert s.with_overrides(**{"simulation.realizations": 4}).simulation.realizations == 4
    with pytest.raises(ScenarioError, match="simulation.realizations"):
        s.with_overrides(**{"simulation.realizations": 0})


def test_parse_accepts_int_for_float_fields():
    assert parse_scenario({"simulation": {"duration_s": 620}}).simulation.duration_s == 620.0


def test_fixed_word_below_12_bits_is_a_clear_error():
    # below 12 bits the fixed filter's 1 / S division would need a shift beyond 30 bits (FixedYawFilter
    # raises at the first update); the scenario says so up front
    with pytest.raises(ScenarioError, match=r"filter.fixed_word_bits.*greater than or equal to 12"):
        Scenario().with_overrides(**{"filter.fixed_word_bits": 11})
    assert Scenario().with_overrides(**{"filter.fixed_word_bits": 12}).filter.fixed_word_bits == 12


def test_engine_key_is_checked():
    with pytest.raises(ScenarioError, match="simulation.engine"):
        Scenario().with_overrides(**{"simulation.engine": "fast"})


@pytest.mark.parametrize("initial", [1, 2, 7, 10])
def test_drilling_duration_check_is_the_programme_with_initial_tubes(initial):
    """simulation.duration_s must cover initial_static_s + (N - M + 1) (L / ROP + survey_stop_s) + (N - M) insertion_s
    (a tube: drilling L at the rate of penetration, its survey stop, the next insertion); no other minimum per tube."""
    motion = {"kind": "drilling", "initial_tubes": initial, "tube_length_m": 3.0, "rate_of_penetration_m_s": 0.02,
              "survey_stop_s": 25.0, "survey_settle_s": 10.0, "insertion_s": 45.0, "initial_static_s": 30.0}
    drilled = 10 - initial + 1
    needed = 30.0 + drilled * (3.0 / 0.02 + 25.0) + (drilled - 1) * 45.0
    ok = {"motion": motion, "chain": {"nodes": 10}, "simulation": {"duration_s": needed},
          "metrics": {"window_start_s": 0.0, "window_end_s": needed}}
    s = parse_scenario(ok)
    assert s.motion.drilling_duration_s(10) == pytest.approx(needed, rel=1e-15)
    from nodesim.motion.drilling_timelines import drilling_process

    assert drilling_process(s).duration_s + 30.0 == pytest.approx(needed, rel=1e-15)  # the process agrees
    short = {**ok, "simulation": {"duration_s": needed - 0.5}, "metrics": {"window_start_s": 0.0, "window_end_s": 1.0}}
    with pytest.raises(ScenarioError, match=rf"drilling programme of 10 tubes, {initial} of them .*allowed: >= {needed:.6g} s"):
        parse_scenario(short)


def test_b_tuning_is_checked_and_reaches_the_filter_config():
    """filter.b_tuning (thesis eqs 4.14-4.15, how B enters the bias process noise) is validated and is what the
    float filter and the fixed build are configured with (nodesim.chain.estimator: one YawFilterConfig)."""
    from nodesim.chain.estimator import filter_config, firmware_config

    with pytest.raises(ScenarioError, match=r"filter.b_tuning.*'noise_gain' or 'process_noise'"):
        Scenario().with_overrides(**{"filter.b_tuning": "B^2"})
    for reading in ("noise_gain", "process_noise"):
        s = Scenario().with_overrides(**{"filter.b_tuning": reading})
        assert filter_config(s).b_tuning == reading
        assert firmware_config(s).filter == filter_config(s)
