"""Firmware preprocessing: fixed-point ring-buffer MAF, initial bias, alignment offset, survey resolution
(thesis 4.2.2-4.2.3 procedure, eqs 1.1-1.3 as reconstructed in the thesis digest 1.2 and 5.2)."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from firmware_model import fixedpoint as fp
from firmware_model.errors import FirmwareError
from firmware_model.fixedpoint import Fx, QFormat, Rounding
from firmware_model.preprocessing import (
    FixedMovingAverage,
    alignment_offset,
    check_tick_times,
    corrected_inclination,
    corrected_tilt,
    initial_bias,
    moving_average_fixed,
    tilt_angles,
)
from firmware_model.survey_resolution import resolve, resolve_survey, trailing_moving_average

FMT = QFormat(32, 16)
DEG = math.pi / 180.0


@settings(max_examples=60, deadline=None)
@given(
    st.integers(1, 40),
    st.lists(st.integers(-(2**31), 2**31 - 1), min_size=1, max_size=90),
    st.sampled_from(list(Rounding)),
)
def test_ring_buffer_equals_batch_form_and_exact_rounded_mean(points, values, rounding):
    """Bit-identical ring buffer and batch form; each output is the exactly rounded mean of the window."""
    raw = np.array(values, dtype=np.int64)
    maf = FixedMovingAverage(points, FMT, rounding=rounding)
    ring = np.array([int(maf.push(Fx(np.int64(v), FMT)).raw) for v in raw])
    batch = moving_average_fixed(Fx(raw, FMT), points, rounding).raw
    np.testing.assert_array_equal(ring, batch)
    for k in range(raw.size):  # Python big-int oracle for the windowed mean
        w = [int(v) for v in raw[max(0, k - points + 1) : k + 1]]
        exact = fp.div(Fx(np.int64(sum(w)), FMT), Fx(np.int64(len(w)), QFormat(32, 0)), FMT, rounding)
        assert ring[k] == int(exact.raw)
        lo, hi = min(w), max(w)
        assert lo <= ring[k] <= hi


def test_maf_32_points_tracks_the_float_moving_average_within_one_lsb():
    """The default 32-point MAF (digest 5.2: 16.8 s at 1.9 Hz) against the float trailing average."""
    rng = np.random.default_rng(3)
    x = rng.normal(0.0, 2.0, (5, 3, 200))  # (R, axis, K): accelerometer channels in m/s^2
    fixed = moving_average_fixed(fp.from_float(x, FMT), 32)
    assert np.max(np.abs(fixed.to_float() - trailing_moving_average(x, 32))) <= FMT.lsb
    maf = FixedMovingAverage(32, FMT, batch_shape=(5, 3))
    for k in range(200):
        out = maf.push_float(x[:, :, k])
    np.testing.assert_array_equal(out.raw, fixed.raw[:, :, -1])
    assert 32 * (1.0 / 1.9) == pytest.approx(16.84, abs=0.01)


def test_maf_rejects_bad_input():
    maf = FixedMovingAverage(4, FMT, batch_shape=(2,))
    with pytest.raises(FirmwareError, match=r"moving average sample.*index \(1,\)"):
        maf.push_float([1.0, np.nan])
    with pytest.raises(FirmwareError, match="format"):
        maf.push(Fx(np.zeros(2, dtype=np.int64), QFormat(16, 8)))
    with pytest.raises(FirmwareError, match="1..65536"):
        FixedMovingAverage(0)


def test_initial_bias_is_the_mean_over_the_first_stationary_window():
    """Thesis 4.2.3: the constant bias is the simple average over the first 50 s (stationary)."""
    dt = 1.0 / 1.9
    t = np.arange(200) * dt
    rng = np.random.default_rng(5)
    true_bias = np.array([0.5, -0.3])  # deg/s (turn-on bias)
    rate = true_bias[:, None] + 0.01 * rng.standard_normal((2, t.size)) + np.where(t >= 50.0, 3.6, 0.0)
    b = initial_bias(t, fp.from_float(rate, FMT), 50.0)
    n = int(np.count_nonzero(t < 50.0))
    np.testing.assert_allclose(b.to_float(), rate[:, :n].mean(axis=1), atol=FMT.lsb)
    np.testing.assert_allclose(b.to_float(), true_bias, atol=4 * 0.01 / math.sqrt(n))


@pytest.mark.parametrize(
    "t, match",
    [
        ([0.0, 1.0, 1.0, 2.0], r"index 2 .*dt > 0"),
        ([0.0, 1.0, 0.5], r"index 2 .*strictly increasing"),
        ([0.0, np.nan, 2.0], "non-finite"),
    ],
)
def test_non_monotonic_or_repeated_times_are_rejected(t, match):
    with pytest.raises(FirmwareError, match=match):
        check_tick_times(t)
    with pytest.raises(FirmwareError, match=match):
        initial_bias(t, Fx(np.zeros((1, len(t)), dtype=np.int64), FMT))


def test_initial_bias_rejects_empty_window_and_mismatched_lengths():
    with pytest.raises(FirmwareError, match="window_s"):
        initial_bias([0.0, 1.0], Fx(np.zeros((1, 2), dtype=np.int64), FMT), 0.0)
    with pytest.raises(FirmwareError, match="3 samples for 2 tick times"):
        initial_bias([0.0, 1.0], Fx(np.zeros((1, 3), dtype=np.int64), FMT))


def rotating_tube(inc_rad, azi_rad, yaw, mis_x_rad=0.0, mis_y_rad=0.0):
    """Sensor-frame specific force of a tube at (I, A) rotated by yaw, seen by an IMU mounted with small
    rotations about the tube's x and y axes (the alignment offset)."""
    g = 9.81
    f = np.array([g * math.sin(inc_rad) * math.cos(azi_rad), g * math.sin(inc_rad) * math.sin(azi_rad), g * math.cos(inc_rad)])
    c, s = np.cos(yaw), np.sin(yaw)
    fb = np.stack([c * f[0] + s * f[1], -s * f[0] + c * f[1], np.full_like(c, f[2])], -1)  # tube frame
    rx = np.array([[1, 0, 0], [0, math.cos(mis_x_rad), math.sin(mis_x_rad)], [0, -math.sin(mis_x_rad), math.cos(mis_x_rad)]])
    ry = np.array([[math.cos(mis_y_rad), 0, -math.sin(mis_y_rad)], [0, 1, 0], [math.sin(mis_y_rad), 0, math.cos(mis_y_rad)]])
    return fb @ (ry @ rx).T


def test_alignment_offset_from_max_min_recovers_inclination():
    """Thesis 4.2.2: offset = (max + min) / 2 of pitch and roll over the slow rotation; I = sqrt(p^2 + r^2).
    A 0.5 deg mounting offset at 2 deg inclination: uncorrected I swings by +/- 0.5 deg with toolface,
    corrected I stays within 0.01 deg of 2 deg (small-angle residual)."""
    yaw = np.linspace(0.0, 2 * 2 * math.pi, 800)  # two slow turns
    f = rotating_tube(2.0 * DEG, 45.0 * DEG, yaw, mis_x_rad=0.3 * DEG, mis_y_rad=-0.4 * DEG)[None]
    pitch, roll = tilt_angles(f)
    off = alignment_offset(pitch, roll, np.ones(yaw.size, dtype=bool))
    assert math.hypot(off.pitch_rad[0], off.roll_rad[0]) == pytest.approx(0.5 * DEG, rel=0.02)
    raw_inc = np.hypot(pitch, roll)
    assert np.ptp(raw_inc) > 0.9 * DEG
    inc = corrected_inclination(pitch, roll, off)
    assert np.max(np.abs(inc - 2.0 * DEG)) < 0.01 * DEG
    # survey after correction: toolface from the corrected tilt plus yaw gives the azimuth (eq 1.3)
    p_c, r_c = corrected_tilt(pitch, roll, off)
    azi = np.remainder(np.arctan2(r_c, p_c) + yaw, 2 * math.pi)
    assert np.max(np.abs(np.angle(np.exp(1j * (azi - 45.0 * DEG))))) < 0.5 * DEG


def test_alignment_offset_rejects_empty_window_and_bad_samples():
    with pytest.raises(FirmwareError, match="no sample"):
        alignment_offset(np.zeros((1, 3)), np.zeros((1, 3)), np.zeros(3, dtype=bool))
    with pytest.raises(FirmwareError, match=r"allowed \(\.\.\., 3\)"):
        tilt_angles(np.zeros((4, 2)))


@settings(max_examples=50, deadline=None)
@given(st.floats(0.5, 60.0), st.floats(0.0, 359.0), st.floats(-720.0, 720.0))
def test_resolve_eqs_1_1_to_1_3(inc_deg, azi_deg, yaw_deg):
    """I independent of yaw, A = tau' + psi (dA/dpsi = 1), A recovers the true azimuth (digest 1.2)."""
    yaw = np.array([yaw_deg * DEG])
    f = rotating_tube(inc_deg * DEG, azi_deg * DEG, yaw)
    s = resolve(f, yaw)
    assert s.inclination_rad[0] == pytest.approx(inc_deg * DEG, abs=1e-12)
    err = np.angle(np.exp(1j * (s.azimuth_rad[0] - azi_deg * DEG)))
    assert abs(err) < 1e-9
    assert np.remainder(s.toolface_rad[0] + yaw[0] - s.azimuth_rad[0] + 1.0, 2 * math.pi) == pytest.approx(1.0)
    s2 = resolve(f, yaw + 0.01)  # a yaw error becomes the same azimuth error
    assert np.angle(np.exp(1j * (s2.azimuth_rad[0] - s.azimuth_rad[0]))) == pytest.approx(0.01, abs=1e-12)
    i, a = resolve_survey(f, yaw)
    assert i[0] == s.inclination_rad[0] and a[0] == s.azimuth_rad[0]


def test_northward_tilt_gives_azimuth_zero():
    """Digest 9 item 2: a bottom displaced northward must give A = 0 (z up-hole, toolface to high side)."""
    f = rotating_tube(3.0 * DEG, 0.0, np.array([0.0]))
    assert resolve(f, np.array([0.0])).azimuth_rad[0] == pytest.approx(0.0, abs=1e-12)
