"""filter.states = 2 | 6 (issue 24): validated, its 6-state settings checked and carried to the 6-state filter's
configuration; a run with 6 goes through the CLI on both engines, and every entry that would build a 2-state filter
or a firmware build (the replayer, the fixed-point header) refuses it, so nothing pretends."""

import json
import math

import pytest

from firmware_model.six_state_filter import SixStateFilterConfig
from nodesim.api import simulate
from nodesim.chain.estimator import filter_config, require_engine_filter, six_state_config
from nodesim.chain.network import simulate_chain
from nodesim.cli.main import main
from nodesim.errors import NodesimError, ScenarioError
from nodesim.replay.replayer import FirmwareSetup
from nodesim.scenario.schema import Scenario, load_scenario

SIX = {"filter.states": 6}
REFUSED = "only the chain engines run the 6-state filter"


@pytest.mark.parametrize("text, fragments", [
    ("[filter]\nstates = 3\n", ("filter.states", "2 or 6", "got 3")),
    ("[filter]\nstates = 6.0\n", ("filter.states", "2 or 6")),
    ('[filter]\nstates = "6"\n', ("filter.states", "2 or 6")),
    ("[filter]\nstates = 6\ntuning_b = -5.0\n", ("filter.tuning_b", "greater than 0")),
    ("[filter]\nstates = 6\ntuning_a = 0.0\n", ("filter.tuning_a", "greater than 0")),
    ("[filter]\nstates = 6\nbias_tau_s = -500.0\n", ("filter.bias_tau_s", "greater than 0")),
    ("[filter]\nstates = 6\nsingularity_margin_deg = 90.0\n", ("filter.singularity_margin_deg", "less than 90")),
    ("[filter]\nstates = 6\nsingularity_margin_deg = 0.0\n", ("filter.singularity_margin_deg", "greater than 0")),
    ('[filter]\nstates = 6\nsingularity = "switch"\n', ("filter.singularity", "'hold' or 'decouple'")),
    ('[filter]\nstates = 6\ndiscretisation = "rk4"\n', ("filter.discretisation", "'rotation' or 'euler'")),
    ('[filter]\nstates = 6\nimplementation = "fixed"\ndiscretisation = "euler"\n',
     ("filter.discretisation = 'euler'", "filter.implementation = 'fixed'", "allowed: discretisation = 'rotation'")),
    ('[filter]\nstates = 6\nimplementation = "fixed"\nfixed_word_bits = 16\n',
     ("filter.fixed_word_bits = 16", "filter.states = 6", "allowed: 32")),
    ('[filter]\nsingularity = "decouple"\n', ("filter.singularity = 'decouple'", "only used with filter.states = 6")),
    ("[filter]\nsingularity_margin_deg = 3.0\n", ("filter.singularity_margin_deg", "only used with filter.states = 6")),
])
def test_bad_filter_states_configurations_are_rejected_naming_the_key(write_toml, text, fragments):
    """states 3 (or a non-integer), a tuning that would make Q negative (B < 0 makes Q_bb = B 2 sigma_b^2/tau dt
    negative under b_tuning = 'process_noise' and sqrt(B) imaginary; tau <= 0 makes 2 sigma_b^2/tau negative), the
    6-state settings out of range or without states = 6, and a fixed-point 6-state filter with what it does not
    implement (the "euler" discretisation, words other than 32 bits)."""
    path = write_toml(text)
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    msg = str(info.value)
    assert str(path) in msg
    for fragment in fragments:
        assert fragment in msg


def test_states_default_is_2_and_6_validates_with_its_settings():
    assert Scenario().filter.states == 2
    s = Scenario().with_overrides(**SIX, **{"filter.singularity_margin_deg": 3.0, "filter.singularity": "decouple",
                                             "filter.discretisation": "euler"})
    assert (s.filter.states, s.filter.singularity, s.filter.discretisation) == (6, "decouple", "euler")
    assert s.with_overrides(seed=3).filter.states == 6  # overrides re-validate the dumped 6-state settings


def test_six_state_config_carries_the_scenario_tuning():
    """The 6-state tuning is the scenario's 2-state tuning on all three axes plus its 6-state settings."""
    s = Scenario().with_overrides(**SIX, **{"filter.tuning_a": 1.5, "filter.tuning_b": 3.0,
                                             "filter.b_tuning": "noise_gain", "filter.bias_tau_s": 800.0,
                                             "filter.singularity_margin_deg": 2.5, "filter.singularity": "decouple"})
    cfg = six_state_config(s)
    two = filter_config(Scenario().with_overrides(**{"filter.tuning_a": 1.5, "filter.tuning_b": 3.0,
                                                     "filter.b_tuning": "noise_gain", "filter.bias_tau_s": 800.0}))
    assert isinstance(cfg, SixStateFilterConfig)
    assert (cfg.dt_s, cfg.tuning_a, cfg.tuning_b, cfg.b_tuning) == (two.dt_s, 1.5, 3.0, "noise_gain")
    assert cfg.bias_tau_s == (800.0,) * 3 and cfg.arw_rad_per_sqrt_s == (two.arw_rad_per_sqrt_s,) * 3
    assert cfg.singularity_margin_rad == pytest.approx(math.radians(2.5)) and cfg.singularity == "decouple"
    assert cfg.discretisation == "rotation"


def test_six_states_are_refused_where_a_two_state_filter_is_built(lab_toml):
    """The 2-state filter builder and the replayer's setup refuse states = 6 with one message naming filter.states
    (the replayer does not run the 6-state filter); the chain entry's check passes it (both engines run it)."""
    scenario, _ = load_scenario(lab_toml)
    six = scenario.with_overrides(**SIX)
    require_engine_filter(scenario)
    require_engine_filter(six)
    for call in (lambda: filter_config(six), lambda: FirmwareSetup.from_scenario(six)):
        with pytest.raises(NodesimError, match=f"filter.states = 6: {REFUSED}"):
            call()


def _six_state_toml(lab_toml, tmp_path, engine="auto"):
    text = lab_toml.read_text()
    assert "[filter]\n" in text and "[simulation]\n" in text
    text = text.replace("[filter]\n", "[filter]\nstates = 6\n", 1)
    text = text.replace("[simulation]\n", f'[simulation]\nengine = "{engine}"\n', 1)
    path = tmp_path / "six.toml"
    path.write_text(text)
    return path


def _short(text):
    """The lab scenario cut to 120 s (its metrics window inside)."""
    for old, new in (("duration_s = 620.0", "duration_s = 120.0"), ("window_start_s = 370.0", "window_start_s = 60.0"),
                     ("window_end_s = 570.0", "window_end_s = 120.0")):
        assert old in text
        text = text.replace(old, new)
    return text


@pytest.mark.parametrize("engine", ["event", "compiled"])
def test_cli_run_with_six_states_writes_its_run_directory(lab_toml, tmp_path, capsys, engine):
    """Near vertical (the lab's 2 deg) no tick is singular: the summary says 0 and no warning is printed."""
    path = _six_state_toml(lab_toml, tmp_path, engine)
    path.write_text(_short(path.read_text()))
    out = tmp_path / "run-out"
    code = main(["run", str(path), "--out", str(out), "--json", "--quiet"])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    summary = json.loads(captured.out)
    assert summary["engine"] == engine
    assert summary["singular_ticks"] == 0 and "singular_ticks" not in captured.err
    assert (out / "summary.json").exists()


def test_cli_run_warns_when_six_state_ticks_are_singular(lab_toml, tmp_path, capsys):
    """At 89 deg inclination the string's spin swings the pitch through the 5 deg margin: the run prints the
    warning on stderr (stdout keeps the JSON alone) and the summary counts the node-ticks."""
    path = _six_state_toml(lab_toml, tmp_path)
    text = _short(path.read_text())
    path.write_text(text.replace("inclination_deg = 2.0\n", "inclination_deg = 89.0\n", 1))
    assert load_scenario(path)[0].motion.inclination_deg == 89.0
    code = main(["run", str(path), "--out", str(tmp_path / "o"), "--json", "--quiet"])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    summary = json.loads(captured.out)
    assert summary["singular_ticks"] > 0
    assert "nodesim run: warning: singular_ticks" in captured.err


def test_firmware_export_refuses_six_states(lab_toml, tmp_path, capsys):
    """No C header for a 6-state build: the export (firmware_model.config.FirmwareConfig) writes the 2-state
    filter's parameters; the 6-state fixed filter's (firmware_model.six_state_fixed) are not exported yet."""
    code = main(["firmware", "export-config", str(_six_state_toml(lab_toml, tmp_path)), "-o", str(tmp_path / "node.h")])
    err = capsys.readouterr().err
    assert code == 2 and REFUSED in err
    assert not (tmp_path / "node.h").exists()


def test_a_run_with_the_fixed_six_state_filter_writes_its_run_directory(lab_toml, tmp_path, capsys):
    """The fixed-point 6-state node firmware (firmware_model.six_state_firmware) runs through the CLI: its summary
    counts the saturations and the singular ticks (none at the lab's 2 deg) like the other builds'."""
    text = _short(lab_toml.read_text())
    assert "[filter]" in text and 'implementation = "float"' in text
    path = tmp_path / "six_fixed.toml"
    path.write_text(text.replace('implementation = "float"', 'implementation = "fixed"')
                    .replace("[filter]", "[filter]\nstates = 6"))
    out = tmp_path / "run-out"
    code = main(["run", str(path), "--out", str(out), "--json", "--quiet"])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    summary = json.loads(captured.out)
    assert summary["singular_ticks"] == 0 and summary["firmware_saturations"] == 0
    assert math.isfinite(summary["rms_yaw_error_deg"])
    assert (out / "summary.json").exists()
