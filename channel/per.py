"""Packet error model: noise floor, SNR -> Eb/N0 -> bit error rate -> packet error rate.

Noise floor (thermal noise in the receiver bandwidth plus the receiver noise figure)::

    N = 10 log10(k T0 B / 1 mW) + NF  [dBm]  = -174 dBm/Hz + 10 log10 B + NF   at T0 = 290 K

SNR = P_r - N; Eb/N0 = SNR * B / R_b (linear).  Bit error rates (Proakis, Digital Communications, ch. 4-5),
gamma = Eb/N0:

* ``fsk_noncoherent`` (default: 2-FSK/GFSK with an envelope/discriminator receiver such as the CC1101): binary FSK
  with tone correlation rho = sin(pi h)/(pi h) for modulation index h, non-coherent detection::

      P_b = Q1(a, b) - 1/2 exp(-(a^2 + b^2)/2) I0(a b),   a, b = sqrt(gamma/2 (1 -/+ sqrt(1 - rho^2)))

  (rho = |sin(pi h)/(pi h)| for the envelope receiver), which is 1/2 exp(-gamma/2) for orthogonal tones
  (h = 1, the default); evaluated as a series of positive terms, :func:`_ber_fsk_noncoherent`.  Gaussian
  pulse shaping (the G of GFSK) is not modelled (ISI ignored).
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
# this module, e.g. for MODULATIONS or Radio's defaults in the ``nodesim link`` parser, stays cheap.  scipy.stats
# is not used at all: every ``nodesim run`` with a channel link evaluates ber(), and the Marcum Q1 it needs (once
# ncx2.sf) is summed from scipy.special's scaled Bessel functions instead (_ber_fsk_noncoherent).

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
        return _ber_fsk_noncoherent(g, rho)
    raise ChannelError(f"modulation must be one of {list(MODULATIONS)} (got {modulation!r})")


_SERIES_RTOL = 1e-17  # a series element stops once its remaining terms are bounded below this fraction of its sum
_SERIES_MAX_TERMS = 100_000  # a guard; measured for Eb/N0 <= 1e6: h = 1 or 2 stops at k = 1, h in [0.5, 2] by
# k = 38 (rho <= 2/pi), h = 0.01 by k ~ 1940


def _ber_fsk_noncoherent(g, rho):
    """Non-coherent binary FSK bit error probability for Eb/N0 ``g`` (linear) and tone correlation 0 <= rho <= 1.

    P_b = Q1(a, b) - 1/2 exp(-(a^2 + b^2)/2) I0(a b) with a, b = sqrt(g/2 (1 -/+ sqrt(1 - rho^2))) (Proakis,
    Digital Communications, non-coherent detection of binary non-orthogonal FSK).  Inserting the series of the
    first-order Marcum Q function (Proakis, ibid., the Marcum Q function; Simon & Alouini, Digital Communication
    over Fading Channels, ch. 4, the Marcum Q-function)::

        Q1(a, b) = exp(-(a^2 + b^2)/2) sum_{k>=0} (a/b)^k I_k(a b)

    the I0 term cancels half of the k = 0 term and every term left is positive::

        P_b = exp(-g (1 - rho)/2) [ 1/2 ive(0, x) + sum_{k>=1} r^k ive(k, x) ],
        x = a b = g rho / 2,   r = a/b = rho / (1 + sqrt(1 - rho^2)) <= 1,   ive(k, x) = exp(-x) I_k(x)

    using (a^2 + b^2)/2 - a b = (b - a)^2/2 = g (1 - rho)/2.  No difference of nearly equal numbers is formed
    (1 - chndtr, the complement of scipy.special's noncentral chi-square CDF, loses everything below ~1e-16; the
    BERs here go down to 1e-12 and far below), and scipy.stats (ncx2.sf, ~0.6 s to import) is not needed.
    rho = 0 (orthogonal tones) gives 1/2 exp(-g/2), rho = 1 gives 1/2.

    Truncation: the term ratios t_{k+1}/t_k = r I_{k+1}(x)/I_k(x) do not increase with k (Turan-type inequality
    I_k^2 >= I_{k-1} I_{k+1}), so after term t_k with ratio q = t_k/t_{k-1} the rest is at most t_k q/(1 - q);
    each element's sum stops when that bound is below ``_SERIES_RTOL`` of its partial sum.
    """
    from scipy.special import ive

    g, rho = np.broadcast_arrays(np.asarray(g, float), np.asarray(rho, float))
    x = (g * rho / 2.0).ravel()
    r = (rho / (1.0 + np.sqrt(1.0 - rho**2))).ravel()
    term = ive(0, x)  # t_0 = r^0 ive(0, x)
    total = 0.5 * term
    live = np.arange(x.size)  # elements whose series is still being summed, and their x, r, r^k, last term
    x_l, r_l, r_k = x, r, np.ones_like(r)
    for k in range(1, _SERIES_MAX_TERMS + 1):
        if live.size == 0:
            break
        r_k = r_k * r_l
        new = r_k * ive(k, x_l)
        total[live] += new
        q = np.divide(new, term, out=np.zeros_like(new), where=term > 0.0)
        going = new * q > _SERIES_RTOL * (1.0 - q) * total[live]
        live, x_l, r_l, r_k, term = live[going], x_l[going], r_l[going], r_k[going], new[going]
    else:
        if live.size:
            raise ChannelError(f"the non-coherent FSK error series did not converge in {_SERIES_MAX_TERMS} terms "
                               f"(tone correlation {float(np.max(rho.ravel()[live])):.12g}: modulation_index too small)")
    return np.clip(np.exp(-g * (1.0 - rho) / 2.0) * total.reshape(g.shape), 0.0, 0.5)


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
