"""Radio frames as bytes: the layouts as data, encode/decode over lanes, CRC-16/CCITT-FALSE (docs/firmware.md "Frames").

Every frame is little-endian and packed: a type byte, the payload fields in the order of the layout, then the
CRC-16/CCITT-FALSE of every byte before it (poly 0x1021, init 0xFFFF, no reflection, xorout 0; check value
0x29B1 for ``b"123456789"``), itself little-endian.  The payloads are those of thesis digest 2.6 ("Payload":
{node_id, seq, t_read, psi, P_psipsi, psi_dot, b_z}; survey packets add {station, I, A, sigma_I, sigma_A,
cluster id}) plus the encoder exchange of the top node (digest 2.6 "Encoder": the module sends position and
angular velocity).  The C twin is ``firmware_model/c/frames.c`` (``nf_frame_*``, ``nf_crc16``).

Layouts (bytes; the type byte is offset 0, the CRC the last two bytes):

============  ====  =========================================================================  =====
frame         type  fields after the type byte (name: width/sign, format)                      bytes
============  ====  =========================================================================  =====
estimate      1     node u16, seq u16, t_read_us u32, yaw i32 (Q0.32 binary angle),             27
                    P_yy i32 (Q8.24 deg^2), rate i32 (Q16.16 deg/s), bias i32 (Q16.16 deg/s)
survey        2     station u16, node u16, cluster u16, t_us u32, I i32, A i32 (Q0.32 binary    25
                    angles), sigma_I u16, sigma_A u16 (unsigned, LSB 2**-20 turn)
enc_request   3     node u16, seq u16                                                            7
enc_reply     4     node u16, seq u16, t_read_us u32, yaw i32 (Q0.32), rate i32 (Q16.16 deg/s)  19
============  ====  =========================================================================  =====

sigma_I / sigma_A (our choice; the thesis gives no format): an unsigned 16-bit angle with LSB 2**-20 turn
(360 / 2**20 = 3.43e-4 deg), i.e. the Q0.32 binary angle shifted right by 12, full scale 22.5 deg.

Values that do not fit their field (our policy, one per field, ``POLICY`` in the layout):

- ``WRAP``: the field is modular by nature and keeps the value modulo ``2**bits`` (binary angles are exact mod
  one turn, the sequence number and the free-running microsecond timer wrap on the MCU: ``t_us`` wraps every
  2**32 us = 71.6 min and the receiver unwraps it against its own clock).  Decoding gives the value in the
  field's range (two's complement for a signed field);
- ``SATURATE``: clamped to the field's range and counted (the sigmas: anything above 22.5 deg is "unknown");
- ``REJECT``: the frame is not encoded; the encoder returns ``-(1 + field index)`` and :func:`encode` raises
  :class:`~firmware_model.errors.FirmwareError` (identifiers, and fixed-point words whose format is already
  32 bits: a value outside means the caller's format does not match the field, a bug, not data).

The njit kernels (:func:`crc16`, :func:`encode_frame`, :func:`decode_frame`, :func:`encode_lanes`,
:func:`decode_lanes`) take the layout array (``LAYOUTS[kind]``, int64 rows ``(offset, width, signed,
policy)``) so a compiled caller can use them directly; :func:`encode` / :func:`decode` are the checked Python
entry points over lanes ``values (R, n_fields)`` int64 <-> ``frames (R, n_bytes)`` uint8.  The chain's
estimate frames go through :func:`encode_estimate` / :func:`estimate_words` (one lane; the SimPy engine through
:func:`encode_estimates` and :func:`decode_lanes`, the compiled engine from its own loops): ``seq`` is the sender's
tick count since power-up (mod 2^16), ``t_read_us`` its tick time in microseconds.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from firmware_model.errors import FirmwareError

WRAP, SATURATE, REJECT = 0, 1, 2
ESTIMATE, SURVEY, ENC_REQUEST, ENC_REPLY = 1, 2, 3, 4
KIND_NAMES = {ESTIMATE: "estimate", SURVEY: "survey", ENC_REQUEST: "enc_request", ENC_REPLY: "enc_reply"}
CRC_BYTES = 2
TYPE_BYTES = 1
CRC16_CHECK = 0x29B1  # CRC-16/CCITT-FALSE of b"123456789"
SIGMA_SHIFT = 12  # sigma field = Q0.32 binary angle >> 12 (LSB 2**-20 turn)
SIGMA_LSB_DEG = 360.0 / 2**20

# (name, width in bytes, signed, policy) after the type byte, in wire order
FIELDS: dict[int, tuple[tuple[str, int, bool, int], ...]] = {
    ESTIMATE: (("node", 2, False, REJECT), ("seq", 2, False, WRAP), ("t_read_us", 4, False, WRAP),
               ("yaw", 4, True, WRAP), ("P_yy", 4, True, REJECT), ("rate", 4, True, REJECT),
               ("bias", 4, True, REJECT)),
    SURVEY: (("station", 2, False, REJECT), ("node", 2, False, REJECT), ("cluster", 2, False, REJECT),
             ("t_us", 4, False, WRAP), ("I", 4, True, WRAP), ("A", 4, True, WRAP),
             ("sigma_I", 2, False, SATURATE), ("sigma_A", 2, False, SATURATE)),
    ENC_REQUEST: (("node", 2, False, REJECT), ("seq", 2, False, WRAP)),
    ENC_REPLY: (("node", 2, False, REJECT), ("seq", 2, False, WRAP), ("t_read_us", 4, False, WRAP),
                ("yaw", 4, True, WRAP), ("rate", 4, True, REJECT)),
}


def _layout(fields) -> np.ndarray:
    rows, off = [], TYPE_BYTES
    for _, width, signed, policy in fields:
        rows.append((off, width, int(signed), policy))
        off += width
    return np.array(rows, dtype=np.int64)


LAYOUTS: dict[int, np.ndarray] = {k: _layout(f) for k, f in FIELDS.items()}
LENGTHS: dict[int, int] = {k: TYPE_BYTES + sum(f[1] for f in v) + CRC_BYTES for k, v in FIELDS.items()}
ESTIMATE_BYTES = LENGTHS[ESTIMATE]  # 27
SURVEY_BYTES = LENGTHS[SURVEY]  # 25
ENC_REQUEST_BYTES = LENGTHS[ENC_REQUEST]  # 7
ENC_REPLY_BYTES = LENGTHS[ENC_REPLY]  # 19


def field_index(kind: int, name: str) -> int:
    """Column of field ``name`` in the values of a ``kind`` frame."""
    for i, f in enumerate(FIELDS[kind]):
        if f[0] == name:
            return i
    raise FirmwareError(f"{KIND_NAMES.get(kind, kind)} frame has no field {name!r}; "
                        f"fields: {[f[0] for f in FIELDS[kind]]}")


def _crc_table() -> np.ndarray:
    table = np.zeros(256, dtype=np.int64)
    for b in range(256):
        c = b << 8
        for _ in range(8):
            c = ((c << 1) ^ 0x1021) if c & 0x8000 else (c << 1)
            c &= 0xFFFF
        table[b] = c
    return table


CRC_TABLE = _crc_table()
CRC_SLICE = 8  # crc16 takes this many bytes a step


def _crc_slices(table: np.ndarray) -> np.ndarray:
    """(CRC_SLICE, 256): row m = the register after byte x followed by m zero bytes, from a zero register (row 0 =
    ``table``; a zero byte moves s to ``(s << 8) ^ T[s >> 8]`` mod 2^16)."""
    rows = [table]
    for _ in range(CRC_SLICE - 1):
        s = rows[-1]
        rows.append(((s << 8) & 0xFFFF) ^ table[s >> 8])
    return np.stack(rows).astype(np.int64)


CRC_TABLES = _crc_slices(CRC_TABLE)


@njit(cache=True, inline="always")  # inlined (with the codecs below) into the engines' loops: ~2.5x faster
def crc16(buf, n):
    """CRC-16/CCITT-FALSE of ``buf[:n]`` (uint8), table-driven: byte by byte ``c = (c << 8) ^ T[(c >> 8) ^ b]``
    from ``c = 0xFFFF``, ``T[b]`` the MSB-first division of ``b << 8`` by x^16 + x^12 + x^5 + 1 (0x1021).  Eight
    bytes a step (slicing by eight, the same register: the update is linear, so a step is the XOR of each byte's
    contribution followed by the zero bytes after it, the register's two bytes XORed into the first two):
    ``c = T7[(c >> 8) ^ b0] ^ T6[(c & 0xFF) ^ b1] ^ T5[b2] ^ ... ^ T0[b7]`` (:data:`CRC_TABLES`), then the last
    bytes one by one: 4 steps instead of 13 two-byte ones for an estimate frame, whose CRC was ~85 % of encoding it
    (the compiled engine's :func:`nodesim.chain.compiled.frame_pass.send_frames`)."""
    T = CRC_TABLES
    c = 0xFFFF
    i = 0
    while i + CRC_SLICE <= n:
        c = (T[7, (c >> 8) ^ np.int64(buf[i])] ^ T[6, (c & 0xFF) ^ np.int64(buf[i + 1])]
             ^ T[5, np.int64(buf[i + 2])] ^ T[4, np.int64(buf[i + 3])] ^ T[3, np.int64(buf[i + 4])]
             ^ T[2, np.int64(buf[i + 5])] ^ T[1, np.int64(buf[i + 6])] ^ T[0, np.int64(buf[i + 7])])
        i += CRC_SLICE
    while i < n:
        c = ((c << 8) & 0xFFFF) ^ T[0, ((c >> 8) ^ np.int64(buf[i])) & 0xFF]
        i += 1
    return c


@njit(cache=True, inline="always")
def field_range(width, signed):
    """(lo, hi): the values a field of ``width`` bytes holds, signed or not."""
    bits = 8 * width
    lo = -(np.int64(1) << (bits - 1)) if signed else np.int64(0)
    hi = (np.int64(1) << (bits - 1)) - 1 if signed else (np.int64(1) << bits) - 1
    return lo, hi


KEPT, SATURATED, REJECTED = 0, 1, 2  # what :func:`fit_field` did with a value (kept: it fits, or WRAP)


@njit(cache=True, inline="always")
def fit_field(v, layout, i):
    """(the value field ``i`` (layout row ``i``) stores of ``v``, KEPT / SATURATED / REJECTED): a value outside the
    field's range is clamped (SATURATE), rejected (REJECT) or kept whole, its low bits written (WRAP: the value
    modulo ``2**bits``).  The one place the field policies (module docstring) are applied."""
    lo, hi = field_range(layout[i, 1], layout[i, 2])
    if lo <= v <= hi:
        return v, KEPT
    if layout[i, 3] == REJECT:
        return v, REJECTED
    if layout[i, 3] == SATURATE:
        return (lo if v < lo else hi), SATURATED
    return v, KEPT


@njit(cache=True, inline="always")
def encode_frame(values, layout, kind, out):
    """Write one frame of type ``kind`` into ``out`` (uint8, the frame length) from ``values`` (int64, one per
    layout row).  Returns the number of saturated fields (>= 0), or ``-(1 + i)`` if field ``i`` has policy
    REJECT and its value does not fit (``out`` is then left partly written and must not be sent)."""
    n_sat = 0
    out[0] = np.uint8(kind)
    for i in range(layout.shape[0]):
        off, width = layout[i, 0], layout[i, 1]
        v, what = fit_field(values[i], layout, i)
        if what == REJECTED:
            return -(1 + i)
        if what == SATURATED:
            n_sat += 1
        u = v & ((np.int64(1) << (8 * width)) - 1)
        for j in range(width):
            out[off + j] = np.uint8((u >> (8 * j)) & 0xFF)
    n = out.shape[0] - 2
    c = crc16(out, n)
    out[n] = np.uint8(c & 0xFF)
    out[n + 1] = np.uint8(c >> 8)
    return n_sat


@njit(cache=True, inline="always")
def frame_status(values, layout):
    """What :func:`encode_frame` returns for ``values``, without writing the frame: the number of saturated fields
    (>= 0), or ``-(1 + i)`` for the first REJECT field ``i`` whose value does not fit."""
    n_sat = 0
    for i in range(layout.shape[0]):
        what = fit_field(values[i], layout, i)[1]
        if what == REJECTED:
            return -(1 + i)
        if what == SATURATED:
            n_sat += 1
    return n_sat


@njit(cache=True, inline="always")
def field_value(v, layout, i):
    """What field ``i`` (layout row ``i``) of a frame :func:`encode_frame` wrote from ``v`` decodes to
    (:func:`decode_field`), without the bytes: :func:`fit_field`'s value, its low bits sign-extended for a signed
    field (for a frame that was sent: no REJECT field out of range)."""
    width, signed = layout[i, 1], layout[i, 2]
    bits = 8 * width
    u = fit_field(v, layout, i)[0] & ((np.int64(1) << bits) - 1)
    if signed and u >= (np.int64(1) << (bits - 1)):
        u -= np.int64(1) << bits
    return u


@njit(cache=True, inline="always")
def decode_field(frame, layout, i):
    """Field ``i`` (layout row ``i``) of one frame, sign-extended for a signed field."""
    off, width, signed = layout[i, 0], layout[i, 1], layout[i, 2]
    u = np.int64(0)
    for j in range(width):
        u |= np.int64(frame[off + j]) << (8 * j)
    bits = 8 * width
    if signed and u >= (np.int64(1) << (bits - 1)):
        u -= np.int64(1) << bits
    return u


@njit(cache=True, inline="always")
def decode_frame(frame, layout, kind, values):
    """Read the fields of one frame into ``values`` (int64); True iff the CRC matches and the type byte is
    ``kind``.  The fields are decoded whatever the validity (sign-extended for a signed field)."""
    for i in range(layout.shape[0]):
        values[i] = decode_field(frame, layout, i)
    n = frame.shape[0] - 2
    got = np.int64(frame[n]) | (np.int64(frame[n + 1]) << 8)
    return got == crc16(frame, n) and np.int64(frame[0]) == kind


ESTIMATE_LAYOUT = LAYOUTS[ESTIMATE]
EST_YAW, EST_PYY = field_index(ESTIMATE, "yaw"), field_index(ESTIMATE, "P_yy")  # columns of the decoded words


@njit(cache=True, _nrt=False, inline="always")
def estimate_values(node, seq, t_read_us, yaw, p_yy, rate, bias, values) -> None:
    """The estimate frame's field values in wire order (:data:`FIELDS`) into the work row ``values`` (7,) int64."""
    values[0], values[1], values[2], values[3] = node, seq, t_read_us, yaw
    values[4], values[5], values[6] = p_yy, rate, bias


@njit(cache=True, _nrt=False)  # allocation-free: no reference counting around the call, whichever caller compiles it
def encode_estimate(node, seq, t_read_us, yaw, p_yy, rate, bias, values, out):
    """The estimate frame of one lane into ``out`` (27 uint8) through :func:`encode_frame`: node id, the sender's
    tick counter as ``seq`` (mod 2^16), its microsecond timer ``t_read_us`` (mod 2^32) and the firmware words
    (yaw binary angle, P_yy, bias-corrected rate, bias); ``values`` (7,) int64 is the work row.  Both engines
    send their estimates through it (the SimPy engine by :func:`encode_estimates`).  Returns
    :func:`encode_frame`'s status (< 0: a word does not fit its field, the frame must not be sent)."""
    estimate_values(node, seq, t_read_us, yaw, p_yy, rate, bias, values)
    return encode_frame(values, ESTIMATE_LAYOUT, ESTIMATE, out)


@njit(cache=True)
def encode_estimates(node, seq, t_read_us, yaw, p_yy, rate, bias, frames, values):
    """:func:`encode_estimate` lane by lane (``yaw`` ... ``bias`` (R,), ``frames`` (R, 27), ``values`` (R, 7));
    returns the lowest status (< 0: some lane's word does not fit)."""
    worst = 0
    for r in range(frames.shape[0]):
        s = encode_estimate(node, seq, t_read_us, yaw[r], p_yy[r], rate[r], bias[r], values[r], frames[r])
        worst = min(worst, s)
    return worst


@njit(cache=True, _nrt=False)
def estimate_words(frame):
    """The (yaw, P_yy) words of an estimate frame (:func:`decode_field`), without the CRC and the other fields: the
    compiled engine's receiver, whose CRC verdict phase 1 has already made (the frames it takes passed the check, or
    are the errors it let through), ~10x cheaper than :func:`decode_frame` on the drilling day."""
    return decode_field(frame, ESTIMATE_LAYOUT, EST_YAW), decode_field(frame, ESTIMATE_LAYOUT, EST_PYY)


@njit(cache=True, _nrt=False, inline="always")
def estimate_status(node, seq, t_read_us, yaw, p_yy, rate, bias, values):
    """What :func:`encode_estimate` returns for these words (:func:`frame_status`), without writing the frame;
    ``values`` (7,) int64 is the work row."""
    estimate_values(node, seq, t_read_us, yaw, p_yy, rate, bias, values)
    return frame_status(values, ESTIMATE_LAYOUT)


@njit(cache=True, _nrt=False, inline="always")
def estimate_words_sent(yaw, p_yy):
    """The (yaw, P_yy) words :func:`estimate_words` reads back from the frame :func:`encode_estimate` made of the
    words ``yaw``, ``p_yy`` (:func:`field_value`), for a frame it sent (status >= 0), without the bytes."""
    return field_value(yaw, ESTIMATE_LAYOUT, EST_YAW), field_value(p_yy, ESTIMATE_LAYOUT, EST_PYY)


@njit(cache=True)
def encode_lanes(values, layout, kind, n_bytes):
    """(frames (R, n_bytes) uint8, status (R,) int64) of :func:`encode_frame` lane by lane."""
    R = values.shape[0]
    frames = np.zeros((R, n_bytes), dtype=np.uint8)
    status = np.zeros(R, dtype=np.int64)
    for r in range(R):
        status[r] = encode_frame(values[r], layout, kind, frames[r])
    return frames, status


@njit(cache=True)
def decode_lanes(frames, layout, kind):
    """(values (R, n_fields) int64, valid (R,) bool) of :func:`decode_frame` lane by lane."""
    R = frames.shape[0]
    values = np.zeros((R, layout.shape[0]), dtype=np.int64)
    valid = np.zeros(R, dtype=np.bool_)
    for r in range(R):
        valid[r] = decode_frame(frames[r], layout, kind, values[r])
    return values, valid


def _kind(kind: int) -> int:
    if kind not in LAYOUTS:
        raise FirmwareError(f"unknown frame type {kind!r}; allowed: {KIND_NAMES}")
    return int(kind)


def encode(kind: int, values) -> tuple[np.ndarray, np.ndarray]:
    """Frames ``(R, LENGTHS[kind])`` uint8 and the saturated-field count per lane ``(R,)`` from ``values``
    ``(R, n_fields)`` integers (one row per realization, the columns in the layout's order).  Raises
    :class:`FirmwareError` on a wrong shape or a REJECT field out of range (naming lane, field and range)."""
    kind = _kind(kind)
    v = np.asarray(values)
    nf = len(FIELDS[kind])
    if v.ndim != 2 or v.shape[1] != nf:
        raise FirmwareError(f"{KIND_NAMES[kind]} frame values must be (R, {nf}) "
                            f"({[f[0] for f in FIELDS[kind]]}), got shape {v.shape}")
    if v.dtype.kind not in "iu" and not (v.dtype == bool):
        raise FirmwareError(f"{KIND_NAMES[kind]} frame values must be integers, got dtype {v.dtype}")
    if v.dtype.kind == "u" and v.size and v.max() > np.iinfo(np.int64).max:
        raise FirmwareError("frame values exceed int64")
    frames, status = encode_lanes(np.ascontiguousarray(v, dtype=np.int64), LAYOUTS[kind], kind, LENGTHS[kind])
    bad = np.flatnonzero(status < 0)
    if bad.size:
        r = int(bad[0])
        i = int(-status[r] - 1)
        name, width, signed, _ = FIELDS[kind][i]
        lo, hi = (-(1 << (8 * width - 1)), (1 << (8 * width - 1)) - 1) if signed else (0, (1 << (8 * width)) - 1)
        raise FirmwareError(f"{KIND_NAMES[kind]} frame, lane {r}: field {name} = {int(v[r, i])} does not fit "
                            f"its {8 * width}-bit {'signed' if signed else 'unsigned'} field [{lo}, {hi}]")
    return frames, status


def decode(kind: int, frames) -> tuple[np.ndarray, np.ndarray]:
    """(values (R, n_fields) int64, valid (R,) bool) of frames ``(R, LENGTHS[kind])`` uint8; valid = the CRC
    matches and the type byte is ``kind``."""
    kind = _kind(kind)
    f = np.asarray(frames)
    if f.ndim != 2 or f.shape[1] != LENGTHS[kind] or f.dtype != np.uint8:
        raise FirmwareError(f"{KIND_NAMES[kind]} frames must be (R, {LENGTHS[kind]}) uint8, "
                            f"got shape {f.shape} dtype {f.dtype}")
    return decode_lanes(np.ascontiguousarray(f), LAYOUTS[kind], kind)
