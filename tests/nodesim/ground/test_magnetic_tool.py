"""Magnetic MWD tool for simulation runs: exactness, ISCWSA interference term, MSA removal of axial interference."""

import numpy as np
import pytest

from nodesim.errors import NodesimError
from nodesim.ground.magnetic_tool import MagneticMwdTool, interference_sigma_deg
from nodesim.sensors.magnetometer import GeomagneticReference, MagnetometerModel
from nodesim.units import DEG, wrap_pi

REF = GeomagneticReference(50_000.0, 70.0, 3.0)
N = 40
INC = np.linspace(10, 80, N) * DEG
AZI = np.full(N, 90.0 * DEG)
YAW = AZI + np.radians(np.tile([25.0, 115.0, 205.0, 295.0], N // 4))


def err_deg(a, b):
    return np.degrees(wrap_pi(a - b))


def test_error_free_tool_is_exact_with_and_without_msa():
    tool = MagneticMwdTool(REF, MagnetometerModel(), interference=False)
    s = tool.survey(INC, AZI, YAW, np.random.default_rng(0))
    assert np.abs(err_deg(s.azi_rad, AZI)).max() < 1e-9
    assert np.abs(err_deg(s.azi_msa_rad, AZI)).max() < 1e-9
    np.testing.assert_allclose(s.inc_rad, INC, atol=1e-12)
    assert s.msa.status == "ok"


def test_interference_term_formula():
    """ISCWSA term quoted in the drill-string thesis 4.2.4 (Fig 4.23): 0.25 + 0.6 sinI sinA deg (worst E/W, horizontal)."""
    assert interference_sigma_deg(90 * DEG, 90 * DEG) == pytest.approx(0.85)
    assert interference_sigma_deg(0.0, 90 * DEG) == pytest.approx(0.25)
    assert interference_sigma_deg(60 * DEG, 0.0) == pytest.approx(0.25)
    assert interference_sigma_deg(30 * DEG, 270 * DEG) == pytest.approx(0.25 + 0.6 * 0.5)


def test_axial_interference_gives_the_iscwsa_shape_and_msa_removes_it():
    """Uncorrected azimuth error = e1 0.6 sinI sinA + e2 0.25 (first order); after MSA only e2 0.25 is left."""
    tool = MagneticMwdTool(REF, MagnetometerModel(), interference=True)
    rng = np.random.default_rng(11)
    e1, e2 = np.random.default_rng(11).standard_normal(2)
    s = tool.survey(INC, AZI, YAW, rng)
    azm = AZI - REF.declination_deg * DEG
    expected = e1 * 0.6 * np.sin(INC) * np.sin(azm) + e2 * 0.25  # field added along body z (up-hole)
    np.testing.assert_allclose(err_deg(s.azi_rad, AZI), expected, atol=0.02 * abs(e1) * 0.6 + 1e-6)
    np.testing.assert_allclose(err_deg(s.azi_msa_rad, AZI), e2 * 0.25, atol=1e-6)
    # the tool evaluates the term at its own (erroneous) survey, within a fraction of a degree of the truth
    np.testing.assert_allclose(s.sigma_azi_deg, interference_sigma_deg(INC, azm), atol=1e-4)


def test_msa_removes_sensor_scale_and_bias():
    mag = MagnetometerModel((0.01, -0.02, 0.005), (50e-9, -80e-9, 300e-9), 3e-9)
    tool = MagneticMwdTool(REF, mag, interference=False)
    s = tool.survey(INC, AZI, YAW, np.random.default_rng(2))
    raw = np.abs(err_deg(s.azi_rad, AZI)).max()
    corrected = np.abs(err_deg(s.azi_msa_rad, AZI)).max()
    assert raw > 0.3 and corrected < raw / 20  # 3 nT noise leaves ~0.03 deg
    # 3 nT noise: HV Table 9 gives 1.96-sigma scale-z spreads of ~5e-4 for similar surveys
    np.testing.assert_allclose(s.msa.scale, [1.01, 0.98, 1.005], atol=1e-3)


def test_without_msa_and_deterministic():
    tool = MagneticMwdTool(REF, MagnetometerModel(noise_sigma_t=5e-9), use_msa=False)
    a = tool.survey(INC, AZI, YAW, np.random.default_rng(4))
    b = tool.survey(INC, AZI, YAW, np.random.default_rng(4))
    assert a.azi_msa_rad is None and a.msa is None
    np.testing.assert_array_equal(a.azi_rad, b.azi_rad)


def test_bad_input():
    tool = MagneticMwdTool(REF)
    inc = INC.copy()
    inc[3] = np.nan
    with pytest.raises(NodesimError, match="station 4: inclination"):
        tool.survey(inc, AZI, YAW, np.random.default_rng(0))
    with pytest.raises(NodesimError, match="at least 3 stations"):
        tool.survey(INC[:2], AZI[:2], YAW[:2], np.random.default_rng(0))
    with pytest.raises(NodesimError, match="accel_noise"):
        MagneticMwdTool(REF, accel_noise_m_s2=-1.0)
