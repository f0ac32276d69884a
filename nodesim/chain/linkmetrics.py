"""Link and radio metrics of a chain run (per realization, and the per-hop table ``hops.csv``).

Per realization (summary keys; mean and p95 over realizations like every metric):
- ``delivery_ratio``: frames delivered / frames sent over every link (down, up and fallback);
- ``retransmissions``: attempts beyond the first, summed over links;
- ``queue_drops``: frames dropped at a full radio queue;
- ``mean_hop_latency_s``: mean time from handing a frame to the MAC to its arrival, over delivered frames;
- ``radio_energy_j``: radio energy of all nodes, E = V (I_tx t_tx + I_rx t_rx) (:mod:`nodesim.chain.mac`);
- ``fallback_frames``: frames sent over a fallback (skip) link;
- ``crc_rejected_frames``: data tries the receiver decoded with a failed CRC-16 (or type byte) and dropped
  (``mac.bit_errors``; 0 without): no ACK, so the ARQ tried again;
- ``undetected_frame_errors``: tries whose bit errors the CRC did not see, accepted with a corrupted payload;
- ``hop<h>_delivery_ratio``, ``hop<h>_retransmissions``, ``hop<h>_latency_s`` for the down link of hop h
  (h = 1: surface to the top node) and ``node<id>_radio_energy_j``.
"""

from __future__ import annotations

import warnings

import numpy as np

from nodesim.chain.records import ChainRun


def _ratio(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return np.where(b > 0, a / np.maximum(b, 1), np.nan)


def link_metrics(run: ChainRun) -> dict[str, np.ndarray]:
    """Metric arrays (R,) of the links (module docstring)."""
    if not run.down_links:
        return {}
    links = run.down_links + run.up_links + run.skip_links
    frames = sum(lk.stats.frames for lk in links)
    delivered = sum(lk.stats.delivered for lk in links)
    out = {
        "delivery_ratio": _ratio(delivered, frames),
        "retransmissions": sum(lk.stats.attempts - lk.stats.frames + lk.stats.dropped for lk in links).astype(float),
        "queue_drops": sum(lk.stats.dropped for lk in links).astype(float),
        "mean_hop_latency_s": _ratio(sum(lk.stats.latency_sum_s for lk in links), delivered),
        "radio_energy_j": run.radio_energy_j.sum(axis=0),
        "fallback_frames": sum((lk.stats.frames for lk in run.skip_links), np.zeros_like(frames)).astype(float),
        "crc_rejected_frames": sum(lk.stats.crc_rejected for lk in links).astype(float),
        "undetected_frame_errors": sum(lk.stats.undetected for lk in links).astype(float),
    }
    for h, lk in enumerate(run.down_links):
        s = lk.stats
        out[f"hop{h + 1}_delivery_ratio"] = _ratio(s.delivered, s.frames)
        out[f"hop{h + 1}_retransmissions"] = (s.attempts - s.frames + s.dropped).astype(float)
        out[f"hop{h + 1}_latency_s"] = _ratio(s.latency_sum_s, s.delivered)
    for i, e in enumerate(run.radio_energy_j):
        out[f"node{i + 1}_radio_energy_j"] = e
    return out


def hop_table(run: ChainRun) -> dict[str, np.ndarray]:
    """One row per hop: medium, mean path loss and margin, and the down/up links' means over realizations."""
    rows: dict[str, list] = {k: [] for k in (
        "hop", "kind", "mean_path_loss_db", "mean_margin_db", "per_data_mean", "down_frames", "down_delivery_ratio",
        "down_retransmissions", "down_latency_s", "down_queue_drops", "up_frames", "up_delivery_ratio",
        "node_radio_energy_j")}
    for h, (ch, down, up) in enumerate(zip(run.hops, run.down_links, run.up_links)):
        d, u = down.stats, up.stats
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            for key, value in (
                ("hop", h + 1), ("kind", ch.kind), ("mean_path_loss_db", ch.mean_path_loss_db),
                ("mean_margin_db", ch.mean_margin_db), ("per_data_mean", float(ch.per_data_table.mean())),
                ("down_frames", d.frames.mean()), ("down_delivery_ratio", np.nanmean(_ratio(d.delivered, d.frames))),
                ("down_retransmissions", (d.attempts - d.frames + d.dropped).mean()),
                ("down_latency_s", np.nanmean(_ratio(d.latency_sum_s, d.delivered))),
                ("down_queue_drops", d.dropped.mean()), ("up_frames", u.frames.mean()),
                ("up_delivery_ratio", np.nanmean(_ratio(u.delivered, u.frames))),
                ("node_radio_energy_j", run.radio_energy_j[h].mean()),
            ):
                rows[key].append(value)
    return {k: np.asarray(v) for k, v in rows.items()}
