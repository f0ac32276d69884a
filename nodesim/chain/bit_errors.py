"""Bit errors in a transmitted frame (``mac.bit_errors``): independent flips drawn with the hop's BER, decoded by
the receiver through :func:`firmware_model.frames.decode_frame`.

Each data try of a frame with bytes (estimate frames down the chain, survey frames up) is received as
preamble + frame, ``mac.preamble_bits + 8 x length`` bits, every bit wrong with probability BER(t) (the bit error
rate the hop's link budget gives, :func:`channel.per.link_quality`, the same number its PER comes from):

* the preamble (sync word, PHY header) must be clean, or the receiver does not see the frame at all: lost with
  probability 1 - (1 - BER)^preamble_bits (the try's data uniform, as the PER draw without bit errors);
* the frame's bits flip independently: the gaps between flipped bits are geometric,
  ``gap = floor(ln u / ln(1 - BER))`` with u uniform in (0, 1] (bit ``p`` is bit ``7 - p % 8`` of byte ``p // 8``,
  most significant first on air), so P(no flip in n bits) = (1 - BER)^n and
  P(try lost) = 1 - (1 - BER)^(preamble_bits + 8 x length) = PER, as without bit errors;
* the receiver checks the CRC-16 and the type byte (:func:`~firmware_model.frames.decode_frame`): a failure is
  dropped and counted (``crc_rejected``; no ACK, so the ARQ tries again); a corruption the CRC does not see
  (an error pattern that is itself a codeword: >= 4 flipped bits) is accepted, counted (``undetected``) and its
  corrupted payload used.

Whether the receiver accepts a corrupted frame does not depend on the payload: the CRC is affine over GF(2), so
crc(f ^ e) ^ crc_field(f ^ e) = crc(e) ^ crc(0) ^ crc_field(e) for every frame f of that type; the MAC decides with
the flips applied to the all-zero frame of the type (:func:`frame_try`), and the receiver applies the same flips
(regenerated from the try's number) to the real bytes (:func:`apply_flips`).  This lets the compiled engine resolve
the ARQ before any payload exists (its phase 1), and both engines draw the same flips.

The flips of try ``i`` (0, 1, ... per link and realization: the link's data tries in order) come from a
counter-based stream: SplitMix64 (Steele, Lea & Flood 2014, "Fast splittable pseudorandom number generators")
seeded by ``mix(key ^ mix(i + 1))``, ``key`` the link's own bit-error key per realization
(:meth:`nodesim.rng.streams.RunStreams.bit_error_keys`).  No buffer, no order dependence between links or tries.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numba import njit

from firmware_model import frames as fr

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_M1, _M2 = np.uint64(0xBF58476D1CE4E5B9), np.uint64(0x94D049BB133111EB)
_S30, _S27, _S31, _S11 = np.uint64(30), np.uint64(27), np.uint64(31), np.uint64(11)


@njit(cache=True)
def _mix(z):
    """SplitMix64's output function (a bijection of uint64)."""
    z = (z ^ (z >> _S30)) * _M1
    z = (z ^ (z >> _S27)) * _M2
    return z ^ (z >> _S31)


@njit(cache=True)
def flip_bits(key, try_index, ber, buf) -> int:
    """Flip the bits of ``buf`` (uint8) that try ``try_index`` of the lane with ``key`` gets wrong at ``ber``
    (module docstring); returns the number flipped."""
    n_bits = 8 * buf.shape[0]
    if ber <= 0.0:
        return 0
    state = _mix(np.uint64(key) ^ _mix(np.uint64(try_index + 1)))
    log_q = math.log1p(-ber) if ber < 1.0 else -math.inf
    pos, n = -1, 0
    while True:
        state = state + _GOLDEN
        u = (float(_mix(state) >> _S11) + 1.0) * 2.0 ** -53  # (0, 1]
        gap = 0 if log_q == -math.inf else int(math.floor(math.log(u) / log_q))
        pos += 1 + gap
        if pos >= n_bits or gap < 0:
            return n
        buf[pos // 8] ^= np.uint8(1 << (7 - pos % 8))
        n += 1


@njit(cache=True)
def frame_try(key, try_index, ber, base, work, layout, kind, values):
    """(flipped bits, accepted) of one try: ``work`` = the all-zero frame ``base`` with the try's flips, decoded
    by :func:`firmware_model.frames.decode_frame` (module docstring: the outcome holds for every payload)."""
    for i in range(base.shape[0]):
        work[i] = base[i]
    n = flip_bits(key, try_index, ber, work)
    if n == 0:
        return 0, True
    return n, fr.decode_frame(work, layout, kind, values)


@njit(cache=True)
def apply_flips(keys, tries, bers, frames) -> None:
    """The flips of try ``tries[r]`` at ``bers[r]`` applied to ``frames[r]`` in place, where ``tries[r] >= 0``."""
    for r in range(frames.shape[0]):
        if tries[r] >= 0:
            flip_bits(keys[r], tries[r], bers[r], frames[r])


def zero_frame(kind: int) -> np.ndarray:
    """The frame of type ``kind`` with every field 0 (the reference :func:`frame_try` corrupts)."""
    return fr.encode(kind, np.zeros((1, len(fr.FIELDS[kind])), dtype=np.int64))[0][0]


@njit(cache=True)
def frame_tries(keys, tries, bers, trying, base, layout, kind):
    """:func:`frame_try` lane by lane where ``trying``: (flipped bits (R,), accepted (R,) bool)."""
    R = keys.shape[0]
    flips, accepted = np.zeros(R, np.int64), np.ones(R, np.bool_)
    work, values = np.empty_like(base), np.zeros(layout.shape[0], np.int64)
    for r in range(R):
        if trying[r]:
            flips[r], accepted[r] = frame_try(keys[r], tries[r], bers[r], base, work, layout, kind, values)
    return flips, accepted


@dataclass
class FrameErrors:
    """The bit errors of one link's frames of type ``kind`` (SimPy engine): per realization its key."""

    kind: int
    keys: np.ndarray  # (R,) uint64
    base: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        self.base = zero_frame(self.kind)

    def tries(self, tries, bers, trying) -> tuple[np.ndarray, np.ndarray]:
        return frame_tries(self.keys, tries, bers, trying, self.base, fr.LAYOUTS[self.kind], self.kind)
