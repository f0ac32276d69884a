"""The node firmware pipeline (firmware_model.node_firmware): its integer steps against exact rational arithmetic and
eq 3.29, and against the C reference (firmware_model/c/node_firmware.c) word for word on random tick sequences,
random formats and saturating inputs; a deliberately broken C rounding is caught."""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest
from numba import njit

from firmware_model import c_reference
from firmware_model import fixed_kernel as fk
from firmware_model import fixedpoint as fxp
from firmware_model import node_firmware as nf
from firmware_model.config import GYRO_SENS_X10, FirmwareConfig
from firmware_model.fixed_filter import FixedFormats
from firmware_model.yaw_filter import B_TUNINGS, YawFilterConfig

DEG = math.pi / 180.0


def config(word_bits=32, tuning_b=5.0, extrapolate=False, fs=250, sigma_dps=0.08, offset_deg=0.0,
           b_tuning="noise_gain") -> FirmwareConfig:
    f = YawFilterConfig(dt_s=1 / 1.9, arw_rad_per_sqrt_s=7.38e-3 * DEG, bias_instability_rad_s=3.33e-3 * DEG,
                        bias_tau_s=500.0, tuning_a=1.0, tuning_b=tuning_b, b_tuning=b_tuning)
    return FirmwareConfig(filter=f, formats=FixedFormats().with_word_length(word_bits), gyro_full_scale_dps=fs,
                          sigma_rate_rad_s=sigma_dps * DEG, offset_sigma_rad=offset_deg * DEG,
                          extrapolate_rate=extrapolate)


def round_half_even(x: Fraction) -> int:
    f = math.floor(x)
    r = x - f
    return f + (1 if r > Fraction(1, 2) or (r == Fraction(1, 2) and f % 2 == 1) else 0)


def test_counts_to_rate_is_the_exactly_rounded_mean():
    rng = np.random.default_rng(1)
    for _ in range(3000):
        n = int(rng.integers(1, 80))
        s = int(rng.integers(-32768 * n, 32767 * n + 1))
        sens = int(rng.choice(list(GYRO_SENS_X10.values())))
        frac = int(rng.integers(8, 24))
        want = round_half_even(Fraction(s * 10 * 2**frac, n * sens))
        assert nf.counts_to_rate(s, n, frac, sens) == want


def test_reference_advance_is_eq_3_29_to_the_lsb():
    """psi_ref = psi_prev + omega dt (thesis eq 3.29) in turns: the binary-angle result is within one LSB of the
    exact value (two roundings of half an LSB each, the gain and the increment)."""
    cfg = config()
    fp = cfg.filter_params()
    counts = np.zeros(len(nf.SITES), np.int64)
    rng = np.random.default_rng(2)
    for _ in range(3000):
        yaw = int(rng.integers(-2**31, 2**31))
        omega = int(rng.integers(-200 * 2**16, 200 * 2**16))
        us = int(rng.integers(0, 2_000_000))
        got = nf.advance(yaw, omega, us, fp, counts)
        exact = Fraction(yaw) + Fraction(omega, 2**16) * Fraction(us, 10**6) / 360 * 2**32
        diff = (Fraction(got) - exact) % 2**32
        diff = min(diff, 2**32 - diff)
        k_err = Fraction(1, 2) / 2**nf.ADVANCE_FRAC * abs(omega) / 2**16 * 2**32  # the gain's rounding, in LSB
        assert diff <= Fraction(1, 2) + k_err + Fraction(1, 10**9)
    assert not counts.any()


def test_transfer_times_beyond_the_timer_saturate_and_count():
    counts = np.zeros(len(nf.SITES), np.int64)
    assert nf.transfer_us_sat(1 << 30, counts) == nf.MAX_TRANSFER_US
    assert nf.transfer_us_sat(-5, counts) == 0
    assert counts[nf.X_TRANSFER] == 2


def test_static_window_bias_is_the_mean_of_all_its_samples():
    cfg = config()
    p, fp = cfg.params(), cfg.filter_params()
    st, counts = np.zeros(nf.STATE_SIZE, np.int64), np.zeros(len(nf.SITES), np.int64)
    nf.init_lane(st)
    inp, out = np.zeros(len(nf.INPUTS), np.int64), np.zeros(len(nf.OUTPUTS), np.int64)
    sums, ns = [131 * 34 + 7, 131 * 35 - 3, 131 * 34], [34, 35, 34]
    for s, n in zip(sums, ns):
        inp[:] = 0
        inp[nf.IN_PHASE], inp[nf.IN_GZ], inp[nf.IN_N] = nf.STATIC, s, n
        nf.node_tick(st, p, fp, counts, inp, out)
    inp[nf.IN_PHASE] = nf.START
    nf.node_tick(st, p, fp, counts, inp, out)
    assert st[fk.I_BIAS] == round_half_even(Fraction(sum(sums) * 10 * 2**16, sum(ns) * 1310))
    assert st[nf.S_RUNNING] == 1 and st[fk.I_PYY] == p[nf.P_P0_YY]


# ---- against the C reference --------------------------------------------------------------------------------
@njit
def _run_model(state, params, fparams, counts, inputs, outputs, states_out):
    for k in range(inputs.shape[0]):
        nf.node_tick(state, params, fparams, counts, inputs[k], outputs[k])
        states_out[k] = state


def random_sequence(rng, n_ticks: int) -> np.ndarray:
    """A node's tick inputs: a static window, the start, then running ticks with random references, holds and
    extreme values (full-scale gyro sums, huge and negative transfer times, saturating variances)."""
    x = np.zeros((n_ticks, len(nf.INPUTS)), np.int64)
    n_static = int(rng.integers(0, 6))
    n = rng.integers(1, 70, n_ticks)
    extreme = rng.random(n_ticks) < 0.1
    gz = np.where(extreme, rng.choice([-32768, 32767], n_ticks) * n, rng.integers(-3000, 3000, n_ticks) * n // 10)
    x[:, nf.IN_GZ], x[:, nf.IN_N] = gz, n
    x[:n_static, nf.IN_PHASE] = nf.STATIC
    if n_static < n_ticks:
        x[n_static, nf.IN_PHASE] = nf.START
        x[n_static, nf.IN_YAW0] = rng.integers(-2**31, 2**31)
    run = np.arange(n_ticks) > n_static
    x[run, nf.IN_PHASE] = np.where(rng.random(run.sum()) < 0.05, nf.HOLD, nf.RUN)
    x[rng.random(n_ticks) < 0.03, nf.IN_PHASE] = nf.ABSENT
    kind = rng.integers(0, 4, n_ticks)
    x[:, nf.IN_REF] = kind
    x[:, nf.IN_REF_YAW] = rng.integers(-2**31, 2**31, n_ticks)
    aux_big = rng.random(n_ticks) < 0.1
    x[:, nf.IN_REF_AUX] = np.where(kind == nf.ENCODER_REF, rng.integers(-2**31, 2**31, n_ticks) >> rng.integers(0, 24, n_ticks),
                                   np.where(aux_big, 2**31 - 1, rng.integers(1, 2**26, n_ticks)))
    tr = rng.integers(0, 3_000_000, n_ticks)
    tr = np.where(rng.random(n_ticks) < 0.05, rng.choice([-1000, 1 << 25, (1 << 24) - 1], n_ticks), tr)
    x[:, nf.IN_TRANSFER] = tr
    return x


def compare_with_c(cfg: FirmwareConfig, inputs: np.ndarray, lib, ffi) -> None:
    p, fp = cfg.params(), cfg.filter_params()
    K = inputs.shape[0]
    st_m, st_c = np.zeros(nf.STATE_SIZE, np.int64), np.zeros(nf.STATE_SIZE, np.int64)
    nf.init_lane(st_m)
    lib.nf_init_lane(ffi.from_buffer("int64_t[]", st_c))
    cnt_m, cnt_c = np.zeros(len(nf.SITES), np.int64), np.zeros(len(nf.SITES), np.int64)
    out_m, out_c = np.zeros((K, len(nf.OUTPUTS)), np.int64), np.zeros((K, len(nf.OUTPUTS)), np.int64)
    hist_m, hist_c = np.zeros((K, nf.STATE_SIZE), np.int64), np.zeros((K, nf.STATE_SIZE), np.int64)
    _run_model(st_m, p, fp, cnt_m, inputs, out_m, hist_m)
    buf = lambda a: ffi.from_buffer("int64_t[]", a)  # noqa: E731
    lib.node_firmware_run(buf(st_c), buf(p), buf(fp), buf(cnt_c), buf(np.ascontiguousarray(inputs)), buf(out_c),
                          buf(hist_c), K)
    bad = np.flatnonzero((hist_m != hist_c).any(axis=1) | (out_m != out_c).any(axis=1))
    assert bad.size == 0, f"first differing tick {bad[0]}: model {hist_m[bad[0]]} {out_m[bad[0]]}, C {hist_c[bad[0]]} {out_c[bad[0]]}"
    np.testing.assert_array_equal(cnt_m, cnt_c)


def sweep(lib, ffi, n_sequences: int, seed: int) -> int:
    """``n_sequences`` random sequences, each with its own random build (B entering as noise gain and as process
    noise, filter.b_tuning, on alternate sequences); returns the number of sequences compared."""
    rng = np.random.default_rng(seed)
    saturated = 0
    for i in range(n_sequences):
        cfg = config(word_bits=int(rng.integers(12, 33)), tuning_b=float(rng.uniform(0.2, 20.0)),
                     extrapolate=bool(rng.integers(0, 2)), fs=int(rng.choice(list(GYRO_SENS_X10))),
                     sigma_dps=float(rng.uniform(0.0, 2.0)), offset_deg=float(rng.uniform(0.0, 1.0)),
                     b_tuning=B_TUNINGS[i % 2])
        x = random_sequence(rng, int(rng.integers(2, 40)))
        compare_with_c(cfg, x, lib, ffi)
        saturated += 1
    return saturated


@pytest.mark.parametrize("b", [0.5, 5.0, 20.0])
def test_b_tuning_changes_only_the_quantised_q_bb(b):
    """filter.b_tuning reaches the fixed build through the one float Q (YawFilterConfig.q_d): the two readings'
    builds differ in the q_bb constant alone, and each q_bb is its float Q_bb in (deg/s)^2, rounded into P_bb's
    format."""
    ng, pn = config(tuning_b=b), config(tuning_b=b, b_tuning="process_noise")
    fp_ng, fp_pn = ng.filter_params(), pn.filter_params()
    assert set(np.flatnonzero(fp_ng != fp_pn)) == {fk.C_QBB}
    np.testing.assert_array_equal(ng.params(), pn.params())
    for cfg, params in ((ng, fp_ng), (pn, fp_pn)):
        q_bb = cfg.filter.q_d[1, 1] * (180.0 / math.pi) ** 2
        assert params[fk.C_QBB] == int(fxp.from_float(q_bb, cfg.formats.p_bb).raw)
        assert params[fk.C_QBB + 1] == cfg.formats.p_bb.frac_bits
    assert abs(fp_pn[fk.C_QBB] - fp_ng[fk.C_QBB] / b) <= 1.0  # B against B^2, to one LSB of the two roundings


def test_c_reference_equals_the_model_on_10000_random_tick_sequences():
    ffi, lib = c_reference.load()
    assert sweep(lib, ffi, 10_000, seed=19) == 10_000


def test_the_sequences_reach_saturation_at_every_firmware_site():
    """The random sequences are not gentle: the firmware's sites saturate somewhere (the advance gain and the
    transfer sigma cannot: their formats hold the timer's whole range)."""
    rng = np.random.default_rng(5)
    seen = np.zeros(len(nf.SITES), np.int64)
    for _ in range(400):
        cfg = config(word_bits=int(rng.integers(12, 33)), sigma_dps=float(rng.uniform(0.0, 2.0)))
        x = random_sequence(rng, 40)
        p, fp = cfg.params(), cfg.filter_params()
        st = np.zeros(nf.STATE_SIZE, np.int64)
        nf.init_lane(st)
        out, hist = np.zeros((40, len(nf.OUTPUTS)), np.int64), np.zeros((40, nf.STATE_SIZE), np.int64)
        _run_model(st, p, fp, seen, x, out, hist)
    for site in ("tick rate", "initial bias", "transfer time", "omega", "R transfer", "R sum", "S = P_yy + R",
                 "rate - bias", "yaw increment"):
        assert seen[nf.SITES.index(site)] > 0, site


@pytest.mark.parametrize("file,old,new", [
    ("fixedpoint.c", "if (r > d || (r == d && (q & 1) == 1)) q += 1;", "if (r >= d) q += 1;"),  # half up
    ("node_firmware.c", "return fx_wrap(yaw + inc, wy);", "return fx_wrap(yaw + inc + (inc > 0), wy);"),
])
def test_a_broken_c_rounding_is_caught(tmp_path, file, old, new):
    ffi, lib = c_reference.load_modified({file: (old, new)}, tmp_path)
    with pytest.raises(AssertionError):
        sweep(lib, ffi, 300, seed=3)
