"""The whole-process measurement of benchmarks/bench_chain.py (``_process``, ``PEAK``): what the drilling day's
bench rows (wall, peak RSS, CPU) are read from."""

import importlib.util
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[3]


@pytest.fixture(scope="module")
def bench():
    spec = importlib.util.spec_from_file_location("bench_chain_under_test", REPO / "benchmarks" / "bench_chain.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_a_process_reports_its_wall_peak_output_and_cpu(bench):
    code = "import sys\nprint('peak_kib 2048', file=sys.stderr)\nprint('cpu_s 1.25', file=sys.stderr)\nprint('out')"
    wall, peak, text, cpu = bench._process(["-c", code])
    assert wall > 0 and peak == 2048 * 1024 and text == "out\n" and cpu == 1.25
    wall, peak, text, cpu = bench._process(["-c", "print('quiet')"])  # nothing reported: NaN, not 0
    assert peak != peak and cpu != cpu and text == "quiet\n"


def test_peak_prints_the_cpu_time_of_the_whole_process(bench):
    """PEAK's own lines after a command that returns (the CPU of a busy loop is counted)."""
    code = bench.PEAK.replace("from nodesim.cli.main import console",
                             "def console(args):\n    sum(range(3_000_000))\n    return 0")
    _, peak, _, cpu = bench._process(["-c", code])
    assert peak > 1e6 and 0.0 < cpu < 60.0
    with pytest.raises(RuntimeError, match="failed"):
        bench._process(["-c", "raise SystemExit(3)"])
