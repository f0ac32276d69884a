"""Packets that travel along the chain, and the rule a node uses to pick its reference.

Estimate packets go down (node n -> node n+1) and carry the payload of thesis digest 2.6
{node_id, seq, t_read, psi_hat, P_psipsi, psi_dot_hat}; survey packets go up to the ground station
{station, MD, node_id, t, I, A, sigma_I, sigma_A}.  A packet is part of the shared event skeleton (one SimPy
event per hop, whatever the number of realizations R); what differs between realizations travels as arrays:
the values and ``valid``, the realizations in which the packet exists (the sender applied an update and no
hop lost it).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from firmware_model import frames as fr
from nodesim.units import G0_M_S2


@dataclass(frozen=True)
class EstimatePacket:
    """A node's estimate, forwarded to the next node down (arrays of shape (R,))."""

    sender: int  # node id
    seq: int  # per-sender sequence number, increasing
    t_read_s: float  # true time at which the estimate is valid (the sender's tick)
    yaw_rad: np.ndarray
    yaw_var_rad2: np.ndarray  # P_psipsi
    rate_rad_s: np.ndarray  # the sender's bias-corrected rate estimate
    valid: np.ndarray  # bool (R,)
    arrival_s: np.ndarray | None = None  # (R,) when it reached the receiver (None: before any use)
    frame: np.ndarray | None = None  # fixed-point firmware: the estimate frame's bytes (R, 27) uint8 (estimate_frame)

    def lost_where(self, lost: np.ndarray) -> "EstimatePacket":
        return replace(self, valid=self.valid & ~lost)


def estimate_frame(node: int, seq: int, t_read_us, yaw_raw, var_raw, rate_raw, bias_raw) -> np.ndarray:
    """The estimate frame of every realization, (R, 27) uint8, by :func:`firmware_model.frames.encode_estimates`
    (docs/firmware.md "Frames"): node, seq (the sender's tick counter, mod 2^16), t_read_us (mod 2^32), yaw (binary
    angle), P_yy, rate, bias raws in the build's formats (Q0.32, Q8.24, Q16.16, Q16.16 by default; a shorter word
    fits the same 32-bit fields)."""
    R = np.shape(yaw_raw)[0]
    frames = np.zeros((R, fr.ESTIMATE_BYTES), dtype=np.uint8)
    values = np.zeros((R, len(fr.FIELDS[fr.ESTIMATE])), dtype=np.int64)
    words = [np.ascontiguousarray(np.broadcast_to(w, (R,)), dtype=np.int64)
             for w in (yaw_raw, var_raw, rate_raw, bias_raw)]
    if fr.encode_estimates(node, seq, int(t_read_us), *words, frames, values) < 0:
        v = np.column_stack([np.full(R, node), np.full(R, seq), np.full(R, int(t_read_us)), *words])
        fr.encode(fr.ESTIMATE, v)  # raises the FirmwareError naming the lane and field
    return frames


@dataclass(frozen=True)
class SurveyPacket:
    """A survey sent up to the ground station.  The values are those of the node's firmware at tick
    ``tick`` (causal moving average), filled into the survey table from the node's records after the run."""

    station: int  # 1 = first station
    md_m: float
    node_id: int
    tick: int
    t_s: float
    valid: np.ndarray  # bool (R,)

    def lost_where(self, lost: np.ndarray) -> "SurveyPacket":
        return replace(self, valid=self.valid & ~lost)


def survey_sigmas_rad(accel_sigma_m_s2: float, points: int, true_inclination_rad: float, yaw_var_rad2):
    """(sigma_I, sigma_A) of a survey: sigma_I^2 = sigma_f^2 / (M g^2), sigma_A^2 = P_psipsi + sigma_f^2 /
    (M (g sin I)^2), sigma_f the per-tick accelerometer noise, M the moving-average length."""
    var_f = accel_sigma_m_s2**2 / points
    horizontal = G0_M_S2 * np.sin(true_inclination_rad)
    return np.sqrt(var_f) / G0_M_S2, np.sqrt(yaw_var_rad2 + var_f / max(horizontal, 1e-12) ** 2)


def survey_frame(station: int, node: int, t_us: int, inc_raw, azi_raw, sigma_i_rad, sigma_a_rad) -> np.ndarray:
    """The survey frames of every realization, (R, 25) uint8 (:mod:`firmware_model.frames`): station, node,
    cluster 0 (one sensor cluster per tube here), t_us (mod 2^32), the I and A binary angles (Q0.32, mod one turn)
    and the sigmas as unsigned 2^-20-turn words (rounded; above 22.5 deg saturated, ``SATURATE``)."""
    R = np.shape(inc_raw)[0]
    lsb = 2.0 * np.pi / 2**20
    v = np.column_stack([np.full(R, station), np.full(R, node), np.zeros(R, np.int64), np.full(R, t_us),
                         np.asarray(inc_raw, np.int64), np.asarray(azi_raw, np.int64),
                         np.broadcast_to(np.rint(np.asarray(sigma_i_rad) / lsb), (R,)).astype(np.int64),
                         np.rint(np.asarray(sigma_a_rad) / lsb).astype(np.int64)])
    return fr.encode(fr.SURVEY, v)[0]


def decode_survey(frames: np.ndarray) -> dict[str, np.ndarray]:
    """The ground station's reading of survey frames (R, 25): ``valid`` (CRC and type byte), the I and A words
    back in [0, 2^32) (one turn) and the sigmas in radians."""
    values, ok = fr.decode(fr.SURVEY, frames)
    col = {name: values[:, i] for i, (name, *_) in enumerate(fr.FIELDS[fr.SURVEY])}
    lsb = 2.0 * np.pi / 2**20
    return {"valid": ok, "inc_raw": col["I"] & 0xFFFFFFFF, "azi_raw": col["A"] & 0xFFFFFFFF,
            "sigma_i_rad": col["sigma_I"] * lsb, "sigma_a_rad": col["sigma_A"] * lsb}


@dataclass(frozen=True)
class Selection:
    """What a node takes from its inbox at one tick (arrays of shape (R,))."""

    have: np.ndarray  # bool: a fresh packet was chosen
    yaw_rad: np.ndarray
    yaw_var_rad2: np.ndarray
    t_read_s: np.ndarray  # NaN where none
    seq: np.ndarray  # int, -1 where none
    stale: np.ndarray  # int counts of newer-than-used but too old packets
    duplicate: np.ndarray  # int counts of packets with seq <= the last one used
    yaw_raw: np.ndarray | None = None  # the chosen frames' decoded yaw and P_yy words (fixed firmware), 0 where none
    var_raw: np.ndarray | None = None
    crc_rejected: np.ndarray | None = None  # int counts of received frames whose CRC (or type byte) failed


def select_reference(
    inbox: list[EstimatePacket], last_seq: np.ndarray, t_use_s: float, max_age_s: float
) -> Selection:
    """Per realization, the newest packet with ``seq > last_seq`` and age ``t_use - t_read <= max_age``.

    Packets with ``seq <= last_seq`` are duplicates; packets newer than the last used but older than
    ``max_age`` are stale; both are ignored and counted (thesis digest 2.6: sequence number and age)."""
    R = last_seq.shape[0]
    have = np.zeros(R, dtype=bool)
    yaw = np.zeros(R)
    var = np.zeros(R)
    t_read = np.full(R, np.nan)
    seq = np.full(R, -1, dtype=np.int64)
    stale = np.zeros(R, dtype=np.int64)
    dup = np.zeros(R, dtype=np.int64)
    raws = any(p.frame is not None for p in inbox)
    yaw_raw, var_raw = (np.zeros(R, dtype=np.int64), np.zeros(R, dtype=np.int64)) if raws else (None, None)
    rejected = np.zeros(R, dtype=np.int64) if raws else None
    for pkt in sorted(inbox, key=lambda p: p.seq, reverse=True):  # newest first
        valid = pkt.valid
        if raws:  # the receiver decodes the bytes: a frame failing its CRC is dropped and counted
            words, ok = fr.decode_lanes(pkt.frame, fr.ESTIMATE_LAYOUT, fr.ESTIMATE)
            rejected += valid & ~ok
            valid = valid & ok
        newer = valid & (pkt.seq > last_seq)
        dup += valid & ~newer
        if t_use_s - pkt.t_read_s > max_age_s:
            stale += newer & ~have
            continue
        take = newer & ~have
        yaw = np.where(take, pkt.yaw_rad, yaw)
        var = np.where(take, pkt.yaw_var_rad2, var)
        t_read = np.where(take, pkt.t_read_s, t_read)
        seq = np.where(take, pkt.seq, seq)
        if raws:
            yaw_raw = np.where(take, words[:, fr.EST_YAW], yaw_raw)
            var_raw = np.where(take, words[:, fr.EST_PYY], var_raw)
        have |= take
    return Selection(have, yaw, var, t_read, seq, stale, dup, yaw_raw, var_raw, rejected)
