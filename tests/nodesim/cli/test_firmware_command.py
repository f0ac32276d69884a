"""``nodesim firmware export-config``: the header of every bundled scenario compiles with the C reference
(gcc -std=c99 -Wall -Werror) and the image built from it runs; bad input is a clear error."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

from firmware_model import c_reference
from nodesim.cli.main import main

ROOT = Path(__file__).resolve().parents[3]
# a scenario with filter.states = 6 has no fixed-point firmware build to export (the 6-state filter is float only;
# tests/nodesim/scenario/test_filter_states.py checks that the export refuses it)
SCENARIOS = sorted(p for p in (ROOT / "scenarios").rglob("*.toml") if not {"sweeps", "optimize"} & set(p.parts)
                   and "\nstates = 6\n" not in p.read_text())


@pytest.mark.skipif(shutil.which("gcc") is None, reason="needs gcc")
@pytest.mark.parametrize("scenario", SCENARIOS, ids=lambda p: str(p.relative_to(ROOT / "scenarios")))
def test_exported_header_compiles_with_the_c_reference(scenario, tmp_path):
    header = tmp_path / "node_config.h"
    assert main(["firmware", "export-config", str(scenario), "-o", str(header)]) == 0
    exe = tmp_path / "image"
    cmd = ["gcc", *c_reference.CFLAGS, f"-I{tmp_path}", f"-I{c_reference.C_DIR}",
           str(c_reference.C_DIR / "app" / "config_check.c"), *map(str, c_reference.sources()), "-o", str(exe),
           *c_reference.LDLIBS]
    subprocess.run(cmd, check=True, capture_output=True, text=True)
    out = subprocess.run([str(exe)], check=True, capture_output=True, text=True).stdout.split()
    assert len(out) == 3 and int(out[1]) != 0  # the static window's 1 deg/s became the bias


def test_header_to_stdout_names_the_formats(capsys):
    assert main(["firmware", "export-config", str(ROOT / "scenarios/lab/continuous.toml")]) == 0
    text = capsys.readouterr().out
    assert "#define NF_FMT_YAW 32, 32" in text and "NF_PARAMS_INIT" in text


def test_missing_scenario_is_a_clear_error(tmp_path, capsys):
    assert main(["firmware", "export-config", str(tmp_path / "nope.toml")]) == 2
    assert "cannot read scenario file" in capsys.readouterr().err


def _filter_params(header: str) -> list[int]:
    line = next(x for x in header.splitlines() if x.startswith("#define NF_FILTER_PARAMS_INIT"))
    return [int(v.strip().rstrip("L")) for v in line.split("{", 1)[1].rsplit("}", 1)[0].split(",")]


def test_b_tuning_reaches_the_header_as_q_bb_only(tmp_path, capsys):
    """The exported build under each reading of B (filter.b_tuning): the headers differ in the quantised q_bb
    constant and the tuning comment alone; the process-noise q_bb is the noise-gain one / B (B = 5)."""
    from firmware_model import fixed_kernel as fk

    text = (ROOT / "scenarios/lab/continuous.toml").read_text()
    headers = {}
    for reading in ("noise_gain", "process_noise"):
        path = tmp_path / f"{reading}.toml"
        path.write_text(text.replace("[filter]\n", f'[filter]\nb_tuning = "{reading}"\n', 1))
        assert main(["firmware", "export-config", str(path)]) == 0
        headers[reading] = capsys.readouterr().out
        assert f"b_tuning = {reading}" in headers[reading]
    ng, pn = (_filter_params(headers[r]) for r in ("noise_gain", "process_noise"))
    assert [i for i, (a, b) in enumerate(zip(ng, pn)) if a != b] == [fk.C_QBB]
    assert abs(pn[fk.C_QBB] - ng[fk.C_QBB] / 5.0) <= 1.0
    differing = [(a, b) for a, b in zip(headers["noise_gain"].splitlines(), headers["process_noise"].splitlines()) if a != b]
    assert len(differing) == 2  # the tuning comment and NF_FILTER_PARAMS_INIT
