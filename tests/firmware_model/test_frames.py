"""Radio frames (firmware_model.frames, firmware_model/c/frames.c): the CRC-16/CCITT-FALSE check value and an
independent oracle (binascii.crc_hqx), the layouts against a third encoder written from the docstring's table
(int.to_bytes), the C reference byte for byte on >= 10,000 hypothesis-generated frames (random kinds, fields at
and beyond their ranges), decode(encode(x)) == x, every single-bit error, burst up to 16 bits and odd-weight
error detected, the wrap / saturate / reject policy, and broken C (polynomial, byte order) caught."""

from __future__ import annotations

import binascii

import numpy as np
import pytest
from numba import njit
from hypothesis import given, settings
from hypothesis import strategies as st

from firmware_model import c_reference
from firmware_model import frames as fr
from firmware_model.errors import FirmwareError

KINDS = sorted(fr.FIELDS)


def field_range(width: int, signed: bool) -> tuple[int, int]:
    bits = 8 * width
    return (-(1 << (bits - 1)), (1 << (bits - 1)) - 1) if signed else (0, (1 << bits) - 1)


def oracle(kind: int, values) -> tuple[bytes | None, int]:
    """The frame as the docstring's table says, with Python ints: (bytes or None if rejected, saturated)."""
    out, n_sat = bytes([kind]), 0
    for (name, width, signed, policy), v in zip(fr.FIELDS[kind], values):
        v = int(v)
        lo, hi = field_range(width, signed)
        if not lo <= v <= hi:
            if policy == fr.REJECT:
                return None, 0
            if policy == fr.SATURATE:
                v, n_sat = min(max(v, lo), hi), n_sat + 1
            else:
                v %= 1 << (8 * width)
                if signed and v > hi:
                    v -= 1 << (8 * width)
        out += v.to_bytes(width, "little", signed=signed)
    return out + binascii.crc_hqx(out, 0xFFFF).to_bytes(2, "little"), n_sat


def c_encode(ffi, lib, kind, values):
    n = fr.LENGTHS[kind]
    buf = ffi.new("uint8_t[]", n)
    status = lib.nf_frame_encode(kind, ffi.new("int64_t[]", [int(v) for v in values]), buf)
    return bytes(ffi.buffer(buf, n)), status


def c_decode(ffi, lib, kind, frame: bytes):
    vals = ffi.new("int64_t[]", len(fr.FIELDS[kind]))
    ok = lib.nf_frame_decode(kind, ffi.new("uint8_t[]", frame), vals)
    return list(vals), bool(ok)


def compare(ffi, lib, kind, values) -> None:
    """C == model == oracle for one frame: status, bytes, decoded fields and validity; round trip."""
    v = np.array([values], dtype=np.int64)
    frames, status = fr.encode_lanes(v, fr.LAYOUTS[kind], kind, fr.LENGTHS[kind])
    want, want_sat = oracle(kind, values)
    cb, cs = c_encode(ffi, lib, kind, values)
    assert cs == int(status[0])
    if want is None:
        assert cs < 0 and fr.FIELDS[kind][-cs - 1][3] == fr.REJECT
        return
    assert cs == want_sat
    assert frames[0].tobytes() == cb == want
    dec, valid = fr.decode(kind, frames)
    cdec, cvalid = c_decode(ffi, lib, kind, cb)
    assert bool(valid[0]) and cvalid
    assert list(dec[0]) == cdec
    # decode(encode(x)) == x up to the documented wrap / saturation
    again, _ = oracle(kind, cdec)
    assert again == want
    if want_sat == 0 and all(field_range(f[1], f[2])[0] <= int(x) <= field_range(f[1], f[2])[1]
                             for f, x in zip(fr.FIELDS[kind], values)):
        assert cdec == [int(x) for x in values]


def sweep(ffi, lib, n: int, seed: int) -> None:
    rng = np.random.default_rng(seed)
    for _ in range(n):
        kind = int(rng.choice(KINDS))
        vals = []
        for _, width, signed, _ in fr.FIELDS[kind]:
            lo, hi = field_range(width, signed)
            if rng.random() < 0.15:  # beyond the field: the wrap / saturate / reject paths
                vals.append(int(rng.integers(-(1 << 40), 1 << 40)))
            else:
                vals.append(int(rng.integers(lo, hi, endpoint=True)))
        compare(ffi, lib, kind, vals)


@pytest.fixture(scope="module")
def cref():
    return c_reference.load()


def test_crc_check_value_and_oracle(cref):
    ffi, lib = cref
    check = np.frombuffer(b"123456789", np.uint8)
    assert fr.crc16(check, 9) == fr.CRC16_CHECK == 0x29B1
    assert lib.nf_crc16(ffi.new("uint8_t[]", b"123456789"), 9) == 0x29B1
    assert fr.crc16(check, 0) == 0xFFFF  # init, nothing shifted in
    rng = np.random.default_rng(0)
    for n in list(range(0, 40)) + [255, 1000]:
        b = rng.integers(0, 256, n).astype(np.uint8)
        want = binascii.crc_hqx(b.tobytes(), 0xFFFF)
        assert fr.crc16(b, n) == want == lib.nf_crc16(ffi.new("uint8_t[]", b.tobytes()), n)


def test_lengths_and_field_counts_match_the_c(cref):
    ffi, lib = cref
    assert fr.LENGTHS == {fr.ESTIMATE: 27, fr.SURVEY: 25, fr.ENC_REQUEST: 7, fr.ENC_REPLY: 19}
    for k in KINDS:
        assert lib.nf_frame_length(k) == fr.LENGTHS[k]
        assert lib.nf_frame_fields(k) == len(fr.FIELDS[k])
        assert fr.LAYOUTS[k][-1, 0] + fr.LAYOUTS[k][-1, 1] + 2 == fr.LENGTHS[k]
    assert lib.nf_frame_length(9) == -1 and lib.nf_frame_fields(0) == -1


def test_estimate_frame_bytes_by_hand():
    """node 3, seq 258, t 0x01020304 us, yaw -1 (one LSB below zero), P_yy 2^24 (1 deg^2), rate -2^16
    (-1 deg/s), bias 1: every byte written out."""
    frames, sat = fr.encode(fr.ESTIMATE, [[3, 258, 0x01020304, -1, 1 << 24, -(1 << 16), 1]])
    body = bytes([1, 3, 0, 2, 1, 4, 3, 2, 1, 0xFF, 0xFF, 0xFF, 0xFF, 0, 0, 0, 1, 0, 0, 0xFF, 0xFF, 1, 0, 0, 0])
    assert frames[0].tobytes() == body + binascii.crc_hqx(body, 0xFFFF).to_bytes(2, "little")
    assert sat[0] == 0


def _value_strategy(width: int, signed: bool):
    lo, hi = field_range(width, signed)
    edges = st.sampled_from([lo, hi, lo - 1, hi + 1, 0, -1, 1, 2 * lo - 1, 2 * hi + 2,
                             -(1 << 62), (1 << 62), -(1 << 63), (1 << 63) - 1])
    return st.one_of(st.integers(lo, hi), st.integers(lo, hi), edges,
                     st.integers(-(1 << 63), (1 << 63) - 1))


@st.composite
def frame_case(draw):
    kind = draw(st.sampled_from(KINDS))
    return kind, [draw(_value_strategy(w, s)) for _, w, s, _ in fr.FIELDS[kind]]


@settings(max_examples=10_000, deadline=None)
@given(frame_case())
def test_c_equals_model_byte_for_byte(cref, case):
    ffi, lib = cref
    compare(ffi, lib, *case)


def test_lanes_batch_equals_one_frame_at_a_time(cref):
    ffi, lib = cref
    rng = np.random.default_rng(5)
    for k in KINDS:
        cols = [rng.integers(*field_range(w, s), size=500, endpoint=True) for _, w, s, _ in fr.FIELDS[k]]
        v = np.stack(cols, axis=1).astype(np.int64)
        frames, sat = fr.encode(k, v)
        assert frames.shape == (500, fr.LENGTHS[k]) and frames.dtype == np.uint8 and not sat.any()
        for r in range(0, 500, 37):
            assert frames[r].tobytes() == c_encode(ffi, lib, k, v[r])[0]
        dec, valid = fr.decode(k, frames)
        assert valid.all() and np.array_equal(dec, v)


def _random_estimates(n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    cols = [rng.integers(*field_range(w, s), size=n, endpoint=True) for _, w, s, _ in fr.FIELDS[fr.ESTIMATE]]
    return fr.encode(fr.ESTIMATE, np.stack(cols, axis=1))[0]


def _flip(frames: np.ndarray, bits: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """Rows of ``frames`` with bit ``bits[r, j]`` (MSB-first over the frame) flipped where ``mask[r, j]``."""
    out = frames.copy()
    for j in range(bits.shape[1]):
        r = np.flatnonzero(mask[:, j])
        b = bits[r, j]
        out[r, b // 8] ^= (0x80 >> (b % 8)).astype(np.uint8)
    return out


def test_every_single_bit_error_is_detected(cref):
    ffi, lib = cref
    n_bits = 8 * fr.ESTIMATE_BYTES
    frames = np.repeat(_random_estimates(20, 1), n_bits, axis=0)
    bits = np.tile(np.arange(n_bits), 20)[:, None]
    bad = _flip(frames, bits, np.ones_like(bits, bool))
    assert not fr.decode(fr.ESTIMATE, bad)[1].any()
    for r in range(0, bad.shape[0], 53):
        assert not c_decode(ffi, lib, fr.ESTIMATE, bad[r].tobytes())[1]


def test_every_burst_up_to_16_bits_is_detected():
    """A burst of length L: first and last bit flipped, the L-2 between random; CRC-16 detects every burst of
    length <= 16 (the remainder of x^i B(x), deg B < 16, by a degree-16 polynomial with x^0 term is never 0)."""
    n_bits = 8 * fr.ESTIMATE_BYTES
    rng = np.random.default_rng(2)
    base = _random_estimates(1, 3)
    n_tested = 0
    for L in range(1, 17):
        starts = np.repeat(np.arange(n_bits - L + 1), 8)
        pattern = rng.integers(0, 2, (starts.size, L)).astype(bool)
        pattern[:, 0] = pattern[:, -1] = True
        bits = starts[:, None] + np.arange(L)[None, :]
        bad = _flip(np.repeat(base, starts.size, axis=0), bits, pattern)
        assert not fr.decode(fr.ESTIMATE, bad)[1].any(), L
        n_tested += starts.size
    assert n_tested > 25_000


def test_odd_weight_errors_are_detected():
    """0x11021 = (x + 1)(x^15 + x^14 + x^13 + x^12 + x^4 + x^3 + x^2 + x + 1): every odd number of bit errors
    anywhere is detected (3 and 5 random bits here)."""
    n_bits = 8 * fr.ESTIMATE_BYTES
    rng = np.random.default_rng(4)
    frames = np.repeat(_random_estimates(50, 5), 200, axis=0)
    for w in (3, 5):
        bits = np.array([rng.choice(n_bits, w, replace=False) for _ in range(frames.shape[0])])
        bad = _flip(frames, bits, np.ones_like(bits, bool))
        assert not fr.decode(fr.ESTIMATE, bad)[1].any()


def test_wrong_type_byte_is_invalid_even_with_a_good_crc():
    frames, _ = fr.encode(fr.ENC_REQUEST, [[1, 2]])
    f = frames.copy()
    f[0, 0] = fr.ENC_REPLY
    c = binascii.crc_hqx(f[0, :-2].tobytes(), 0xFFFF)
    f[0, -2:] = [c & 0xFF, c >> 8]
    assert not fr.decode(fr.ENC_REQUEST, f)[1][0]


def test_wrap_saturate_and_reject_policies():
    # wrap: seq mod 2^16, timer mod 2^32, the binary angle mod one turn (two's complement)
    frames, sat = fr.encode(fr.ESTIMATE, [[0, 65536 + 7, (1 << 32) + 9, (1 << 31) + 5, 0, 0, 0]])
    dec, ok = fr.decode(fr.ESTIMATE, frames)
    assert ok[0] and sat[0] == 0 and list(dec[0, 1:4]) == [7, 9, -(1 << 31) + 5]
    frames, _ = fr.encode(fr.ESTIMATE, [[0, -1, -1, 0, 0, 0, 0]])
    assert list(fr.decode(fr.ESTIMATE, frames)[0][0, 1:3]) == [65535, (1 << 32) - 1]
    # saturate: the sigmas, counted per frame
    frames, sat = fr.encode(fr.SURVEY, [[1, 2, 3, 4, 5, 6, 70_000, -3]])
    dec, ok = fr.decode(fr.SURVEY, frames)
    assert ok[0] and sat[0] == 2 and list(dec[0, 6:]) == [65535, 0]
    # reject: identifiers and 32-bit fixed-point words
    with pytest.raises(FirmwareError, match="lane 1: field node = 65536"):
        fr.encode(fr.ESTIMATE, [[0] * 7, [65536, 0, 0, 0, 0, 0, 0]])
    with pytest.raises(FirmwareError, match="field P_yy = 2147483648"):
        fr.encode(fr.ESTIMATE, [[0, 0, 0, 0, 1 << 31, 0, 0]])
    with pytest.raises(FirmwareError, match="field rate"):
        fr.encode(fr.ENC_REPLY, [[0, 0, 0, 0, -(1 << 31) - 1]])
    with pytest.raises(FirmwareError, match="field cluster"):
        fr.encode(fr.SURVEY, [[0, 0, -1, 0, 0, 0, 0, 0]])


@njit(cache=False)
def _statuses_and_fields(values, layout, kind, n_bytes):
    """Per row of ``values``: encode_frame's status and decoded fields, frame_status and field_value."""
    R, F = values.shape
    got = np.zeros((R, 2 + 2 * F), np.int64)
    out = np.zeros(n_bytes, np.uint8)
    for r in range(R):
        got[r, 0] = fr.encode_frame(values[r], layout, kind, out)
        got[r, 1] = fr.frame_status(values[r], layout)
        for i in range(F):
            got[r, 2 + i] = fr.decode_field(out, layout, i)
            got[r, 2 + F + i] = fr.field_value(values[r, i], layout, i)
    return got


@pytest.mark.parametrize("kind", [fr.ESTIMATE, fr.SURVEY, fr.ENC_REQUEST, fr.ENC_REPLY])
def test_status_and_field_values_without_the_bytes_equal_the_encoded_frame(kind):
    """frame_status = encode_frame's status, and field_value = the decoded field of every frame it sent (status
    >= 0), for values in, at the edges of and outside every field's range (wrap, saturate, reject); the
    estimate helpers are those for the estimate layout (the compiled engine's windows send no bytes)."""
    layout, F = fr.LAYOUTS[kind], len(fr.FIELDS[kind])
    rng = np.random.default_rng(kind)
    def draw(width, signed, policy):
        lo, hi = (-(1 << (8 * width - 1)), (1 << (8 * width - 1)) - 1) if signed else (0, (1 << (8 * width)) - 1)
        if rng.random() < (0.03 if policy == fr.REJECT else 0.4):  # outside the field
            return rng.choice([lo - 1, hi + 1, 3 * hi + 7, lo - 3 * hi - 5, rng.integers(hi + 1, 1 << 40)])
        return rng.choice([lo, lo + 1, 0, hi - 1, hi, rng.integers(lo, hi + 1)])

    values = np.array([[draw(*layout[i, 1:4]) for i in range(F)] for _ in range(3000)], np.int64)
    got = _statuses_and_fields(values, layout, kind, fr.LENGTHS[kind])
    assert np.array_equal(got[:, 0], got[:, 1])
    sent = got[:, 0] >= 0
    assert 100 < sent.sum() < len(values) - 100  # both sent and rejected frames
    assert np.array_equal(got[sent, 2:2 + F], got[sent, 2 + F:])
    if kind == fr.ESTIMATE:
        work = np.zeros(7, np.int64)
        for row, decoded in zip(values[:500], got[:500]):
            assert _estimate_status(*row, work) == decoded[0]
            if decoded[0] >= 0:  # the yaw and P_yy words the receiver reads back from the bytes
                assert _estimate_words_sent(row[3], row[4]) == (decoded[2 + fr.EST_YAW], decoded[2 + fr.EST_PYY])


@njit(cache=False)
def _estimate_status(node, seq, t, yaw, p_yy, rate, bias, work):
    return fr.estimate_status(node, seq, t, yaw, p_yy, rate, bias, work)


@njit(cache=False)
def _estimate_words_sent(yaw, p_yy):
    return fr.estimate_words_sent(yaw, p_yy)


def test_bad_shapes_and_kinds_raise():
    with pytest.raises(FirmwareError, match=r"must be \(R, 7\)"):
        fr.encode(fr.ESTIMATE, np.zeros((2, 6), np.int64))
    with pytest.raises(FirmwareError, match="integers"):
        fr.encode(fr.ESTIMATE, np.zeros((2, 7)))
    with pytest.raises(FirmwareError, match=r"\(R, 25\) uint8"):
        fr.decode(fr.SURVEY, np.zeros((2, 27), np.uint8))
    with pytest.raises(FirmwareError, match="unknown frame type"):
        fr.encode(7, np.zeros((1, 2), np.int64))
    with pytest.raises(FirmwareError, match="no field"):
        fr.field_index(fr.ESTIMATE, "yaw_rate")
    assert fr.field_index(fr.ESTIMATE, "yaw") == 3


def test_the_model_sweep_passes_on_the_reference(cref):
    sweep(*cref, 500, seed=7)


@pytest.mark.parametrize("old,new", [
    ("(uint16_t)((c << 1) ^ 0x1021u)", "(uint16_t)((c << 1) ^ 0x1023u)"),  # wrong polynomial
    ("out[off + j] = (uint8_t)((u >> (8 * j)) & 0xFFu);",
     "out[off + j] = (uint8_t)((u >> (8 * (f[i].width - 1 - j))) & 0xFFu);"),  # big-endian fields
    ("out[len - 2] = (uint8_t)(c & 0xFFu);\n    out[len - 1] = (uint8_t)(c >> 8);",
     "out[len - 1] = (uint8_t)(c & 0xFFu);\n    out[len - 2] = (uint8_t)(c >> 8);"),  # big-endian CRC
    ("if (f[i].policy == SATURATE) {", "if (f[i].policy != SATURATE) {"),  # wrap where it should saturate
])
def test_a_broken_c_frame_is_caught(tmp_path, old, new):
    ffi, lib = c_reference.load_modified({"frames.c": (old, new)}, tmp_path)
    with pytest.raises(AssertionError):
        sweep(ffi, lib, 300, seed=3)
