"""Packet error model: noise floor, SNR -> Eb/N0 -> bit error rate -> packet error rate.

Noise floor (thermal noise in the receiver bandwidth plus the receiver noise figure)::

    N = 10 log10(k T0 B / 1 mW) + NF  [dBm]  = -174 dBm/Hz + 10 log10 B + NF   at T0 = 290 K

SNR = P_r - N; Eb/N0 = SNR * B / R_b (linear).  Bit error rates (Proakis, Digital Communications, ch. 4-5),
gamma = Eb/N0:

* ``fsk_noncoherent`` (default: 2-FSK/GFSK with an envelope/discriminator receiver such as the CC1101): binary FSK
  with tone correlation rho = sin(pi h)/(pi h) for modulation index h, non-coherent detection::

      P_b = Q1(a, b) - 1/2 exp(-(a^2 + b^2)/2) I0(a b),   a, b = sqrt(gamma/2 (1 -/+ sqrt(1 - rho^2)))

  which is 1/2 exp(-gamma/2) for orthogonal tones (h = 1, the default); Gaussian pulse shaping (the G of
  GFSK) is not modelled (ISI ignored).
* ``fsk_coherent``: Q(sqrt(gamma (1 - rho)));  ``dbpsk``: 1/2 exp(-gamma);  ``bpsk``: Q(sqrt(2 gamma)).

PER for independent bit errors over a frame of n bits: 1 - (1 - P_b)^n.

Default radio (an assumption [A]; the thesis gives only P_t and sensitivity): 38.4 kbit/s 2-FSK, h = 1,
100 kHz receiver bandwidth, 8 dB noise figure.  With these, BER 1e-3 is reached at -109.2 dBm,
close to the CC1101/AMB8420 -110 dBm of thesis 5.1.2; ``sensitivity_dbm`` reports it for other settings.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from channel._validate import check_positive, check_range
from channel.constants import K_BOLTZMANN_J_K, T0_K
from channel.errors import ChannelError

# scipy (scipy.stats alone takes ~0.6 s to import) is imported inside the functions that use it, so that importing
# this module, e.g. for MODULATIONS or Radio's defaults in the ``nodesim link`` parser, stays cheap.

MODULATIONS = ("fsk_noncoherent", "fsk_coherent", "dbpsk", "bpsk")


@dataclass(frozen=True)
class Radio:
    """Receiver and modulation parameters of one hop."""

    bit_rate_bps: float = 38_400.0
    bandwidth_hz: float = 100e3
    noise_figure_db: float = 8.0
    modulation: str = "fsk_noncoherent"
    modulation_index: float = 1.0
    temperature_k: float = T0_K

    def __post_init__(self) -> None:
        check_positive("bit_rate_bps", self.bit_rate_bps, "bit/s")
        check_positive("bandwidth_hz", self.bandwidth_hz, "Hz")
        check_range("noise_figure_db", self.noise_figure_db, 0.0, None, unit="dB")
        check_positive("modulation_index", self.modulation_index)
        check_positive("temperature_k", self.temperature_k, "K")
        if self.modulation not in MODULATIONS:
            raise ChannelError(f"modulation must be one of {list(MODULATIONS)} (got {self.modulation!r})")


def noise_floor_dbm(bandwidth_hz, noise_figure_db=0.0, temperature_k=T0_K):
    """10 log10(k T B / 1 mW) + NF [dBm]."""
    b = check_positive("bandwidth_hz", bandwidth_hz, "Hz")
    t = check_positive("temperature_k", temperature_k, "K")
    nf = check_range("noise_figure_db", noise_figure_db, 0.0, None, unit="dB")
    return 10.0 * np.log10(K_BOLTZMANN_J_K * t * b / 1e-3) + nf


def _q(x):
    from scipy.special import erfc

    return 0.5 * erfc(x / np.sqrt(2.0))


def fsk_correlation(modulation_index) -> np.ndarray:
    """Correlation of two CPFSK tones over one bit: sin(pi h) / (pi h)."""
    return np.sinc(np.asarray(modulation_index, float))


def ber(ebn0_linear, modulation: str = "fsk_noncoherent", modulation_index: float = 1.0):
    """Bit error probability for Eb/N0 (linear), vectorised (module docstring)."""
    g = check_range("ebn0_linear", ebn0_linear, 0.0, None)
    if modulation == "bpsk":
        return _q(np.sqrt(2.0 * g))
    if modulation == "dbpsk":
        return 0.5 * np.exp(-g)
    rho = np.abs(fsk_correlation(modulation_index))
    if modulation == "fsk_coherent":
        return _q(np.sqrt(g * (1.0 - fsk_correlation(modulation_index))))
    if modulation == "fsk_noncoherent":
        from scipy.special import i0e
        from scipy.stats import ncx2

        s = np.sqrt(1.0 - rho**2)
        a = np.sqrt(g / 2.0 * (1.0 - s))
        b = np.sqrt(g / 2.0 * (1.0 + s))
        # Marcum Q1(a, b) = P(noncentral chi2(2, a^2) > b^2); exp(-(a^2+b^2)/2) I0(ab) = exp(-(a-b)^2/2) i0e(ab)
        q1 = ncx2.sf(b**2, 2, np.maximum(a**2, 1e-300))
        return np.clip(q1 - 0.5 * np.exp(-((a - b) ** 2) / 2.0) * i0e(a * b), 0.0, 0.5)
    raise ChannelError(f"modulation must be one of {list(MODULATIONS)} (got {modulation!r})")


def _power_dbm(name: str, value) -> np.ndarray:
    """A power or ratio in dB as an array; -inf (nothing received) is allowed, NaN and +inf are not."""
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as err:
        raise ChannelError(f"{name} must be a number (got {value!r})") from err
    if np.any(np.isnan(arr) | (arr == np.inf)):
        raise ChannelError(f"{name} must be a number or -inf (got NaN or +inf)")
    return arr


def ebn0_from_snr(snr_db, bandwidth_hz, bit_rate_bps):
    """Eb/N0 (linear) = SNR * B / R_b."""
    snr = _power_dbm("snr_db", snr_db)
    return 10.0 ** (snr / 10.0) * check_positive("bandwidth_hz", bandwidth_hz) / check_positive("bit_rate_bps", bit_rate_bps)


def per_from_ber(ber_value, frame_bits):
    """1 - (1 - BER)^n, computed as -expm1(n log1p(-BER)) for accuracy at small BER."""
    p = check_range("ber", ber_value, 0.0, 1.0)
    n = check_range("frame_bits", frame_bits, 1.0, None, unit="bits")
    with np.errstate(divide="ignore"):
        return -np.expm1(n * np.log1p(-p))


def link_quality(rx_power_dbm, frame_bits, radio: Radio = Radio()) -> dict:
    """Noise floor, SNR, BER and PER of frames received at ``rx_power_dbm`` (vectorised; -inf = nothing arrives)."""
    floor = noise_floor_dbm(radio.bandwidth_hz, radio.noise_figure_db, radio.temperature_k)
    snr = _power_dbm("rx_power_dbm", rx_power_dbm) - floor
    b = ber(ebn0_from_snr(snr, radio.bandwidth_hz, radio.bit_rate_bps), radio.modulation, radio.modulation_index)
    return {"noise_floor_dbm": floor, "snr_db": snr, "ber": b, "packet_error_rate": per_from_ber(b, frame_bits)}


def packet_error_rate(rx_power_dbm, frame_bits, radio: Radio = Radio()):
    """PER of a frame of ``frame_bits`` bits received at ``rx_power_dbm`` (vectorised)."""
    return link_quality(rx_power_dbm, frame_bits, radio)["packet_error_rate"]


def draw_packet_success(rx_power_dbm, frame_bits, rng: np.random.Generator, radio: Radio = Radio()):
    """One Bernoulli draw per transmission: True where the packet arrives."""
    if not isinstance(rng, np.random.Generator):
        raise ChannelError("rng must be a numpy.random.Generator")
    per = packet_error_rate(rx_power_dbm, frame_bits, radio)
    return rng.random(per.shape) >= per


def sensitivity_dbm(radio: Radio = Radio(), target_ber: float = 1e-3) -> float:
    """Received power at which the BER equals ``target_ber`` (for comparison with a datasheet sensitivity)."""
    from scipy.optimize import brentq

    target = float(check_range("target_ber", target_ber, 0.0, 0.5, lo_open=True, hi_open=True))
    floor = float(noise_floor_dbm(radio.bandwidth_hz, radio.noise_figure_db, radio.temperature_k))

    def f(p_dbm: float) -> float:
        g = ebn0_from_snr(p_dbm - floor, radio.bandwidth_hz, radio.bit_rate_bps)
        return float(np.log(np.maximum(ber(g, radio.modulation, radio.modulation_index), 1e-300)) - np.log(target))

    return brentq(f, floor - 60.0, floor + 80.0, xtol=1e-9)
