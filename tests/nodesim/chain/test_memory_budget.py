"""The memory guard: a run that would exhaust memory is refused before any work, and the estimate it uses is the
measured peak of whole ``nodesim run`` processes within a factor of 1.5 (issue 20)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from nodesim.chain.memory_budget import check_run_memory, estimate_run_memory
from nodesim.errors import NodesimError
from nodesim.scenario.schema import Scenario, load_scenario

ROOT = Path(__file__).resolve().parents[3]
PERF = ROOT / "scenarios" / "perf" / "chain100_1h.toml"
DRILLING = ROOT / "scenarios" / "field" / "drilling_10_tubes.toml"


PEAK = ("import sys\nfrom nodesim.cli.main import main\ncode = main(sys.argv[1:])\n"
        "hwm = [l for l in open('/proc/self/status') if l.startswith('VmHWM:')][0].split()[1]\n"
        "print('peak_kib', hwm, file=sys.stderr)\nsys.exit(code)")


def _run(path: Path, out: Path) -> tuple[int, str, float]:
    """(exit code, stderr, peak RSS [bytes]) of a whole ``nodesim run`` process.  The peak is the process's own
    VmHWM: ``ru_maxrss`` of a child carries the parent's size across fork and exec (Linux keeps the larger)."""
    proc = subprocess.run([sys.executable, "-c", PEAK, "run", str(path), "--out", str(out), "--quiet", "--json"],
                          stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, check=False)
    lines = proc.stderr.splitlines()
    peak = [float(x.split()[1]) * 1024.0 for x in lines if x.startswith("peak_kib ")]
    return proc.returncode, "\n".join(x for x in lines if not x.startswith("peak_kib ")), peak[0] if peak else 0.0


def test_a_string_of_100000_nodes_is_refused_at_once_with_its_estimate(tmp_path):
    """A day of 100000 nodes (1.6e10 node-ticks: ~1 TB in memory, or streamed ~5 GB of memory and ~770 GB of disk:
    its whole-run tables on disk and its timeseries table).  (The default 620 s of 100000 nodes needs much less,
    which a 24 GB machine has: the guard lets it pass, and the scenario is then refused for its clock stagger, node
    ~10000 on having no tick inside the run.)"""
    toml = tmp_path / "huge.toml"
    toml.write_text('name = "huge"\n[simulation]\nduration_s = 86400.0\n[chain]\nnodes = 100000\n'
                    '[metrics]\nwindow_end_s = 86400.0\n')
    code, err, _ = _run(toml, tmp_path / "out")
    assert code == 2
    assert err.count("\n") == 0 and "GB of memory" in err and "lower chain.nodes" in err, err
    assert not (tmp_path / "out").exists()  # nothing written


def _perf(tmp_path: Path, nodes: int, duration_s: float, realizations: int, implementation: str) -> Path:
    text = PERF.read_text().replace("duration_s = 3600.0", f"duration_s = {duration_s}")
    text = text.replace("realizations = 1", f"realizations = {realizations}").replace("nodes = 100", f"nodes = {nodes}")
    text = text.replace('implementation = "fixed"', f'implementation = "{implementation}"')
    text = text.replace("window_start_s = 370.0", "window_start_s = 100.0")
    text = text.replace("window_end_s = 3600.0", f"window_end_s = {duration_s}")
    path = tmp_path / f"perf_{nodes}_{realizations}.toml"
    path.write_text(text)
    return path


@pytest.mark.parametrize("nodes, duration_s, realizations, implementation", [
    (30, 1500.0, 1, "fixed"),  # tables dominate
    (8, 400.0, 300, "float"),  # realizations dominate
    (25, 600.0, 20, "fixed"),
])
def test_the_estimate_is_the_measured_peak_within_a_factor_of_1p5(tmp_path, nodes, duration_s, realizations,
                                                                  implementation):
    """Sizes other than the ten the constants were fitted on (nodesim.chain.memory_budget); a run within its
    estimate passes the guard and completes."""
    path = _perf(tmp_path, nodes, duration_s, realizations, implementation)
    scenario = load_scenario(path)[0]
    code, err, peak = _run(path, tmp_path / "out")
    assert code == 0, err
    estimate = estimate_run_memory(scenario, "compiled", streamed=True).total_bytes  # nodesim run streams
    assert 1 / 1.5 < estimate / peak < 1.5, (estimate / 2**20, peak / 2**20)


@pytest.mark.parametrize("engine", ["event", "compiled"])
def test_the_estimate_on_the_drilling_run(tmp_path, engine):
    """Drilling: each node's ticks counted from its insertion (it does not tick before)."""
    text = DRILLING.read_text().replace("realizations = 4", "realizations = 2")
    path = tmp_path / "drilling.toml"
    path.write_text(text.replace(
        "[simulation]", f'[simulation]\nengine = "{engine}"'))
    code, err, peak = _run(path, tmp_path / "out")
    assert code == 0, err
    estimate = estimate_run_memory(load_scenario(path)[0], engine, streamed=True).total_bytes
    assert 1 / 1.5 < estimate / peak < 1.5, (estimate / 2**20, peak / 2**20)


def test_the_estimate_grows_with_every_size_key_and_names_the_largest_part_first():
    base = Scenario.model_validate({"chain": {"nodes": 10}, "simulation": {"duration_s": 600.0}})
    est = estimate_run_memory(base, "compiled").total_bytes
    for key, value in (("chain.nodes", 20), ("simulation.duration_s", 1200.0), ("simulation.realizations", 5),
                       ("filter.implementation", "fixed")):
        assert estimate_run_memory(base.with_overrides(**{key: value}), "compiled").total_bytes > est, key
    assert estimate_run_memory(base, "event").total_bytes > est
    fewer = [estimate_run_memory(base.with_overrides(**{"output.timeseries": t}), "compiled").per_tick_bytes
             for t in ("all", "every:2", "decimate:5", "bottom", "none")]
    assert fewer == sorted(fewer, reverse=True) and fewer[-1] == 0
    many = base.with_overrides(**{"simulation.realizations": 100000})
    with pytest.raises(NodesimError, match=r"more than the 1 GB available: lower simulation.realizations, chain.nodes"):
        check_run_memory(many, "compiled", 10**9)
    with pytest.raises(NodesimError, match=r"lower chain.nodes, simulation.duration_s, output.timeseries$"):
        check_run_memory(base.with_overrides(**{"chain.nodes": 100000}), "compiled", 10**9)
    assert check_run_memory(many, "compiled", None).realizations == 100000  # unknown memory: not checked
    assert check_run_memory(base, "compiled", 10**12).total_bytes == est


@pytest.mark.parametrize("nodes", [100, 1000])  # its whole-run tables in memory (10 MB), on disk (110 MB)
def test_a_streamed_run_is_estimated_without_its_tables(nodes):
    """Streamed (nodesim run on the compiled engine) the records and tables are not held: the estimate grows with the
    node-ticks and realizations, not with output.timeseries, and the guard does not name that key."""
    base = Scenario.model_validate({"chain": {"nodes": nodes}, "simulation": {"duration_s": 3600.0},
                                    "metrics": {"window_end_s": 3600.0}})
    streamed = estimate_run_memory(base, "compiled", streamed=True)
    assert streamed.total_bytes < estimate_run_memory(base, "compiled").total_bytes / 2
    for key, value in (("chain.nodes", 2 * nodes), ("simulation.duration_s", 7200.0), ("simulation.realizations", 3)):
        assert estimate_run_memory(base.with_overrides(**{key: value}), "compiled", True).total_bytes > \
            streamed.total_bytes, key
    assert estimate_run_memory(base.with_overrides(**{"output.timeseries": "none"}), "compiled", True) == streamed
    assert estimate_run_memory(base, "event", True) == estimate_run_memory(base, "event")  # holds its records anyway
    with pytest.raises(NodesimError, match=r"lower chain.nodes, simulation.duration_s$"):
        check_run_memory(base.with_overrides(**{"chain.nodes": 100000}), "compiled", 10**9, streamed=True)


def test_the_estimate_of_a_run_with_its_tables_on_disk(tmp_path):
    """The drilling day's first hour (793 nodes: 95 MB of whole-run tables, kept on disk, nodesim.chain.scratch):
    the estimate counts what of them is mapped at a time, not the tables, within a factor of 1.5 of the peak."""
    from nodesim.chain.scratch import spills

    text = (ROOT / "scenarios" / "perf" / "drilling_day_1000.toml").read_text()
    for a, b in (("nodes = 1000", "nodes = 793"), ("duration_s = 86400.0", "duration_s = 3600.0"),
                 ("window_end_s = 86400.0", "window_end_s = 3600.0")):
        text = text.replace(a, b)
    path = tmp_path / "hour.toml"
    path.write_text(text)
    scenario = load_scenario(path)[0]
    if not spills(793, 6841, 1, False):
        pytest.skip("the temporary directory is a RAM file system: nothing is spilled")
    code, err, peak = _run(path, tmp_path / "out")
    assert code == 0, err
    estimate = estimate_run_memory(scenario, "compiled", streamed=True).total_bytes
    assert 1 / 1.5 < estimate / peak < 1.5, (estimate / 2**20, peak / 2**20)


def test_a_run_is_refused_when_the_disk_it_writes_to_has_no_room(tmp_path, monkeypatch):
    """Streamed, the drilling day writes ~2.5 GB of whole-run tables and a ~4.5 GB table: refused at once, one line,
    naming both sizes' sum and where, when the disk has less free; not refused on the SimPy engine (not streamed)."""
    from nodesim.chain import memory_budget

    day = load_scenario(ROOT / "scenarios" / "perf" / "drilling_day_1000.toml")[0]
    needs = memory_budget.disk_needs(day, "compiled", True, tmp_path)
    assert len(needs) == 1 and needs[0][0] == pytest.approx(7.00e9, rel=0.01)  # /tmp and tmp_path: one file system
    monkeypatch.setattr(memory_budget, "free_disk_bytes", lambda where: (5e9, 1))
    with pytest.raises(NodesimError, match=r"7 GB of disk in .* more than the 5 GB free there: lower chain.nodes"):
        check_run_memory(day, "compiled", 10**12, streamed=True, out_dir=tmp_path)
    assert check_run_memory(day, "compiled", 10**12, streamed=False, out_dir=tmp_path).node_ticks > 0
    none = day.with_overrides(**{"output.timeseries": "none"})
    assert memory_budget.disk_needs(none, "compiled", True, tmp_path)[0][0] == pytest.approx(2.47e9, rel=0.01)
