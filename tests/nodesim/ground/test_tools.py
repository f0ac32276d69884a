"""Tool models as data (thesis 4.1.3 tables 4.4, 4.7, 4.10, 4.13, 4.16; 4.2.4 filtered variant)."""

import numpy as np
import pytest

from nodesim.errors import NodesimError
from nodesim.ground.tools import load_tool, parse_tool, tool_names


def test_bundled_tools():
    assert set(tool_names()) >= {"dip", "vn100t", "stim300", "ipst_rqh", "mpu6500", "mpu6500_filtered"}
    for name in tool_names():
        m = load_tool(name)
        assert m.sources and not m.magnetic_azimuth


@pytest.mark.parametrize(
    "tool, code, value",
    [
        ("vn100t", "ABXY-TI1S", 4.99611e-4),  # table 4.7
        ("vn100t", "GYRO-DRIFT", np.radians(2.78e-3)),
        ("stim300", "ABZ", 1.222e-8),  # table 4.10
        ("stim300", "ASZ", 2e-4),
        ("ipst_rqh", "GYRO-DRIFT", np.radians(8.33e-7)),  # table 4.13
        ("mpu6500", "ABXY-TI1S", 5.886e-1),  # table 4.16
        ("dip", "DSF-STRETCH", 1.4e-4),  # table 4.4
        ("mpu6500_filtered", "AZ-FILTER", np.radians(0.25)),  # thesis 4.2.4
    ],
)
def test_printed_magnitudes(tool, code, value):
    assert load_tool(tool).source(code).value == pytest.approx(value)


def test_filtered_variant_replaces_the_gyro_terms():
    plain = {s.code for s in load_tool("mpu6500").sources}
    filt = load_tool("mpu6500_filtered")
    assert {c for c in plain if c.startswith("GYRO")} == {"GYRO-DRIFT", "GYRO-ARW"}
    assert not any(s.code.startswith("GYRO") for s in filt.sources)
    assert filt.source("AZ-FILTER").propagation == "R"
    assert {s.code for s in filt.sources} - {"AZ-FILTER"} == {c for c in plain if not c.startswith("GYRO")}


def test_unknown_tool_and_bad_tool_files(tmp_path):
    with pytest.raises(NodesimError, match="unknown tool 'nope'; allowed: dip"):
        load_tool("nope")
    cases = [
        ('name="t"\ncolour="red"\nsources=[]\n', r"unknown key\(s\) \['colour'\]"),
        ('name="t"\n[[sources]]\ncode="A"\nweight="AZ"\nmagnitude=1\nunit="deg"\n', r"sources\[0\]: missing key\(s\) \['propagation'\]"),
        ('name="t"\n[[sources]]\ncode="A"\nweight="WHAT"\nmagnitude=1\nunit="deg"\npropagation="S"\n', r"sources\[0\]: error source A: unknown weighting function 'WHAT'"),
        ('name="t"\n[[sources]]\ncode="A"\nweight="AZ"\nmagnitude="big"\nunit="deg"\npropagation="S"\n', r"sources\[0\]\.magnitude: must be a number"),
        ("name = \n", r"not valid TOML"),
    ]
    for text, pattern in cases:
        with pytest.raises(NodesimError, match=pattern):
            parse_tool(text, "t.toml")
    p = tmp_path / "mine.toml"
    p.write_text('name="mine"\n[[sources]]\ncode="A"\nweight="AZ"\nmagnitude=0.5\nunit="deg"\npropagation="R"\n')
    assert load_tool(p).name == "mine"
