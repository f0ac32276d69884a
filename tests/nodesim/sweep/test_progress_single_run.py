"""Progress of one long run: the callback sees the simulated time advance, and it changes no result."""

import io
import json

import numpy as np
import pytest

from nodesim.chain.network import simulate_chain
from nodesim.cli.main import main
from nodesim.scenario.schema import Scenario
from nodesim.sweep.progress import SimulatedTimeProgress


def _scenario(engine="auto"):
    return Scenario().with_overrides(**{
        "simulation.duration_s": 120.0, "simulation.realizations": 2, "chain.nodes": 2,
        "metrics.window_start_s": 60.0, "metrics.window_end_s": 120.0, "simulation.engine": engine,
    })


@pytest.mark.parametrize("engine, calls", [("event", 100), ("compiled", 3)])  # simulated-time steps; phases
def test_progress_callback_is_monotone_and_changes_nothing(engine, calls):
    seen = []
    with_cb = simulate_chain(_scenario(engine), progress=seen.append)
    without = simulate_chain(_scenario(engine))
    assert seen[-1] == 1.0 and len(seen) >= calls
    assert all(b > a for a, b in zip(seen, seen[1:]))
    for a, b in zip(with_cb.nodes, without.nodes):
        assert np.array_equal(a.yaw_est_rad, b.yaw_est_rad, equal_nan=True)
        assert np.array_equal(a.bias_est_rad_s, b.bias_est_rad_s, equal_nan=True)
    assert with_cb.simpy_events == without.simpy_events


class _Tty(io.StringIO):
    def isatty(self):
        return True


def test_simulated_time_bar_draws_on_a_terminal_only():
    tty = _Tty()
    with SimulatedTimeProgress(620.0, stream=tty) as bar:
        bar.update(0.5)
        bar.update(1.0)
    assert "simulated 620/620 s" in tty.getvalue() and tty.getvalue().endswith("\n")
    pipe = io.StringIO()
    with SimulatedTimeProgress(620.0, stream=pipe) as bar:
        bar.update(1.0)
    assert pipe.getvalue() == ""
    quiet = _Tty()
    with SimulatedTimeProgress(620.0, stream=quiet, quiet=True) as bar:
        bar.update(1.0)
    assert quiet.getvalue() == ""


def test_run_json_output_stays_clean(lab_toml, tmp_path, capsys):
    assert main(["run", str(lab_toml), "--out", str(tmp_path / "r"), "--json"]) == 0
    captured = capsys.readouterr()
    json.loads(captured.out)
    assert captured.err == ""
