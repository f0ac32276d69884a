"""Link budget (thesis eq 5.1), log-normal shadowing and two-state Gilbert-Elliott burst loss.

    P_r = P_t + G_t + G_r - L_p - L_other          [dBm]     (thesis eq 5.1, L_p = L_0 + L_m by eq 5.3)
    margin = P_r - sensitivity                      [dB]

Defaults of the two hops (thesis 5.1.2 and 5.2.5):
* soil, 868 MHz: AMB8420 module with the CC1101 transceiver, P_t = 2 dBm ("typically"), sensitivity -110 dBm
  (50 Ohm); the thesis later calls -103 dBm the limit (kept as ``CC1101_THRESHOLD_DBM``); 0 dBi antennas
  (the thesis gives no gains).
* pipe, 5 GHz: "a typical wireless module", P_t = 10 dBm, sensitivity -100 dBm: a 110 dB budget.

Randomness only through a passed ``numpy.random.Generator``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from channel._validate import as_float_array, check_range
from channel.errors import ChannelError


@dataclass(frozen=True)
class LinkBudget:
    """Transmit power, antenna gains, other fixed losses and receiver sensitivity."""

    tx_power_dbm: float
    sensitivity_dbm: float
    tx_gain_dbi: float = 0.0
    rx_gain_dbi: float = 0.0
    other_losses_db: float = 0.0

    def __post_init__(self) -> None:
        for name in ("tx_power_dbm", "sensitivity_dbm", "tx_gain_dbi", "rx_gain_dbi", "other_losses_db"):
            as_float_array(name, getattr(self, name))
        check_range("other_losses_db", self.other_losses_db, 0.0, None, unit="dB")

    @property
    def max_path_loss_db(self) -> float:
        """Largest path loss that still reaches the sensitivity (zero margin)."""
        return self.tx_power_dbm + self.tx_gain_dbi + self.rx_gain_dbi - self.other_losses_db - self.sensitivity_dbm

    def received_power_dbm(self, path_loss_db):
        """Thesis eq 5.1."""
        return self.tx_power_dbm + self.tx_gain_dbi + self.rx_gain_dbi - self.other_losses_db - _loss(path_loss_db)

    def margin_db(self, path_loss_db):
        return self.received_power_dbm(path_loss_db) - self.sensitivity_dbm

    def allowed_path_loss_db(self, margin_db):
        """Path loss that leaves exactly ``margin_db`` of margin."""
        return self.max_path_loss_db - as_float_array("margin_db", margin_db)


def _loss(path_loss_db) -> np.ndarray:
    """Path loss as an array; +inf is allowed (a mode below cutoff: nothing arrives), NaN and -inf are not."""
    try:
        loss = np.asarray(path_loss_db, dtype=float)
    except (TypeError, ValueError) as err:
        raise ChannelError(f"path_loss_db must be a number (got {path_loss_db!r})") from err
    if np.any(np.isnan(loss) | (loss == -np.inf)):
        raise ChannelError("path_loss_db must be a number or +inf (got NaN or -inf)")
    return loss


CC1101_THRESHOLD_DBM = -103.0
"""The '-103 dBm limit' the thesis compares the soil RSS against (5.1.2)."""

SOIL_868_BUDGET = LinkBudget(tx_power_dbm=2.0, sensitivity_dbm=-110.0)
"""AMB8420 / CC1101 figures of thesis 5.1.2."""

PIPE_5G_BUDGET = LinkBudget(tx_power_dbm=10.0, sensitivity_dbm=-100.0)
"""The 5 GHz module figures of thesis 5.2.5 (110 dB budget)."""


def shadowed_path_loss_db(mean_path_loss_db, sigma_db: float, rng: np.random.Generator, size=None):
    """Mean path loss plus zero-mean log-normal shadowing N(0, sigma_db^2) in dB (Castalia default sigma 4 dB)."""
    sigma = float(check_range("sigma_db", sigma_db, 0.0, None, unit="dB"))
    if not isinstance(rng, np.random.Generator):
        raise ChannelError("rng must be a numpy.random.Generator (the channel package never uses global randomness)")
    mean = as_float_array("mean_path_loss_db", mean_path_loss_db)
    shape = np.broadcast_shapes(mean.shape, () if size is None else tuple(np.atleast_1d(size)))
    return mean + sigma * rng.standard_normal(shape)


@dataclass(frozen=True)
class GilbertElliott:
    """Two-state Markov burst-loss channel (Gilbert 1960, Elliott 1963).

    States good (G) and bad (B); per packet, G -> B with probability ``p_good_to_bad`` and B -> G with
    ``p_bad_to_good``; a packet is lost with probability ``loss_good`` in G and ``loss_bad`` in B.
    Stationary P(B) = p / (p + r); mean loss rate = P(G) loss_good + P(B) loss_bad; mean burst (bad-state
    sojourn) length = 1 / r packets.
    """

    p_good_to_bad: float = 0.01
    p_bad_to_good: float = 0.3
    loss_good: float = 0.0
    loss_bad: float = 1.0

    def __post_init__(self) -> None:
        check_range("p_good_to_bad", self.p_good_to_bad, 0.0, 1.0)
        check_range("p_bad_to_good", self.p_bad_to_good, 0.0, 1.0, lo_open=True)
        check_range("loss_good", self.loss_good, 0.0, 1.0)
        check_range("loss_bad", self.loss_bad, 0.0, 1.0)

    @property
    def stationary_bad(self) -> float:
        return self.p_good_to_bad / (self.p_good_to_bad + self.p_bad_to_good)

    @property
    def mean_loss_rate(self) -> float:
        pb = self.stationary_bad
        return (1.0 - pb) * self.loss_good + pb * self.loss_bad

    @property
    def mean_burst_length(self) -> float:
        return 1.0 / self.p_bad_to_good

    def simulate(self, n_packets: int, rng: np.random.Generator, batch: int = 1, start_bad=None):
        """Loss flags of shape (batch, n_packets) and the state path (True = bad), starting from the stationary law
        unless ``start_bad`` (bool or array of shape (batch,)) is given.  Vectorised over the batch axis."""
        if not isinstance(rng, np.random.Generator):
            raise ChannelError("rng must be a numpy.random.Generator")
        if int(n_packets) < 0 or int(batch) < 1:
            raise ChannelError(f"n_packets must be >= 0 and batch >= 1 (got {n_packets}, {batch})")
        n, b = int(n_packets), int(batch)
        u_state = rng.random((b, n))
        u_loss = rng.random((b, n))
        bad = np.empty((b, n), dtype=bool)
        state = rng.random(b) < self.stationary_bad if start_bad is None else np.broadcast_to(start_bad, (b,)).copy()
        for i in range(n):
            if i > 0:
                flip = np.where(state, u_state[:, i] < self.p_bad_to_good, u_state[:, i] < self.p_good_to_bad)
                state = state ^ flip
            bad[:, i] = state
        lost = u_loss < np.where(bad, self.loss_bad, self.loss_good)
        return lost, bad
