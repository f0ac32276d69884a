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
SCENARIOS = sorted(p for p in (ROOT / "scenarios").rglob("*.toml") if not {"sweeps", "optimize"} & set(p.parts))


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
