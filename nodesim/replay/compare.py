"""Model versus MCU: per-tick differences between the replayed firmware and the outputs the log recorded.

For each recorded output (``fw_yaw``, ``fw_yaw_var``, ``fw_bias``, ``fw_inclination``, ``fw_azimuth``) the
recorded value at a tick is the last one among the rows in (t_{k-1}, t_k] (the same rule as the replay's
per-tick inputs).  Differences: model - recorded, angles wrapped into [-pi, pi).  The first divergence is the
first tick where |difference| > tolerance (tolerance 0: the first tick that is not bit-identical), given
with its time and the log line/row it came from.  The estimate frames (``frame``, fixed firmware) are compared byte
for byte: the difference is the number of bytes that differ.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nodesim.replay.reader import NodeLog
from nodesim.replay.replayer import NodeReplay, recorded_frames
from nodesim.units import rad_to_deg, wrap_pi

QUANTITIES = {  # log column -> (NodeReplay attribute, is an angle, unit of the report, factor from SI)
    "fw_yaw": ("yaw_rad", True, "deg", rad_to_deg(1.0)),
    "fw_yaw_var": ("yaw_var_rad2", False, "deg^2", rad_to_deg(1.0) ** 2),
    "fw_bias": ("bias_rad_s", False, "deg/s", rad_to_deg(1.0)),
    "fw_inclination": ("inclination_rad", True, "deg", rad_to_deg(1.0)),
    "fw_azimuth": ("azimuth_rad", True, "deg", rad_to_deg(1.0)),
}


@dataclass(frozen=True)
class QuantityDiff:
    name: str
    unit: str
    tick: np.ndarray  # ticks compared
    diff: np.ndarray  # model - recorded, report unit
    first_divergence: dict | None

    def summary(self) -> dict:
        d = np.abs(self.diff)
        return {
            "unit": self.unit,
            "compared_ticks": int(self.tick.size),
            "identical_ticks": int(np.count_nonzero(self.diff == 0.0)),
            "max_abs_diff": float(d.max()) if d.size else None,
            "rms_diff": float(np.sqrt(np.mean(self.diff**2))) if d.size else None,
            "first_divergence": self.first_divergence,
        }


def recorded_at_ticks(node: NodeLog, ticks: np.ndarray, name: str) -> tuple[np.ndarray, np.ndarray]:
    """(recorded value per tick, source row per tick); NaN / -1 where the log has none."""
    out, src = np.full(ticks.size, np.nan), np.full(ticks.size, -1, dtype=np.int64)
    v = node.extra[name]
    ok = np.flatnonzero(np.isfinite(v))
    k = np.searchsorted(ticks, node.t_s[ok], side="left")
    inside = k < ticks.size
    out[k[inside]] = v[ok[inside]]
    src[k[inside]] = node.rows[ok[inside]]
    return out, src


def compare_node(node: NodeLog, rep: NodeReplay, tolerances: dict[str, float], row_kind: str = "line") -> dict[str, QuantityDiff]:
    """Differences for every recorded firmware output of ``node``; ``tolerances`` in report units."""
    out = {}
    for name, (attr, is_angle, unit, factor) in QUANTITIES.items():
        if not node.has(name):
            continue
        rec, src = recorded_at_ticks(node, rep.t_s, name)
        model = getattr(rep, attr)
        both = np.flatnonzero(np.isfinite(rec) & np.isfinite(model))
        raw = model[both] - rec[both]
        diff = (wrap_pi(raw) if is_angle else raw) * factor
        tol = tolerances.get(name, 0.0)
        bad = np.flatnonzero(np.abs(diff) > tol)
        first = None
        if bad.size:
            j, k = int(bad[0]), int(both[bad[0]])
            first = {"tick": k, "t_s": float(rep.t_s[k]), row_kind: int(src[k]), "model": float(model[k] * factor),
                     "recorded": float(rec[k] * factor), "diff": float(diff[j]), "tolerance": tol}
        missing = np.flatnonzero(np.isfinite(rec) & ~np.isfinite(model))
        if missing.size and first is None:
            k = int(missing[0])
            first = {"tick": k, "t_s": float(rep.t_s[k]), row_kind: int(src[k]), "model": None,
                     "recorded": float(rec[k] * factor), "diff": None, "tolerance": tol}
        out[name] = QuantityDiff(name, unit, both, diff, first)
    if node.has("frame") and rep.frames is not None:
        out["frame"] = _compare_frames(node, rep, row_kind)
    return out


def _compare_frames(node: NodeLog, rep: NodeReplay, row_kind: str) -> QuantityDiff:
    """The estimate frames: per tick where the log records one, the number of bytes the replay's frame differs
    in (0: bit-identical); the first divergence gives both frames in hex."""
    rec, src = recorded_frames(node, rep.t_s)
    ticks = np.flatnonzero(src >= 0)
    diff = (rec[ticks] != rep.frames[ticks]).sum(axis=1).astype(float)
    bad = np.flatnonzero(diff > 0)
    first = None
    if bad.size:
        k = int(ticks[bad[0]])
        first = {"tick": k, "t_s": float(rep.t_s[k]), row_kind: int(node.rows[src[k]]),
                 "model": rep.frames[k].tobytes().hex(), "recorded": rec[k].tobytes().hex(),
                 "diff": float(diff[bad[0]]), "tolerance": 0.0}
    return QuantityDiff("frame", "bytes", ticks, diff, first)


__all__ = ["QUANTITIES", "QuantityDiff", "compare_node", "recorded_at_ticks"]
