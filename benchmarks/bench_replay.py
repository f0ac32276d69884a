"""Log replay throughput: a 1-hour, 65 Hz lab log (234,000 rows of raw int16 counts, encoder counts) through
read -> per-tick resampling -> firmware (float filter, continuous encoder updates, 6,840 ticks at 1.9 Hz).

- ``replay_1h_65hz_s``: the whole replay (strict read, resampling, filter, survey, comparison; no files
  written), best of 2; the issue's target is < 10 s;
- ``read_1h_65hz_s``: reading and checking the log alone (the baseline), ``replay_to_read_ratio`` the ratio;
- ``replay_speedup_vs_python_csv_loop``: a per-sample Python loop (``csv`` module, float() per cell, sum per
  tick) timed on the first 10 % of the rows, scaled to the whole log, over the full replay.
"""

from __future__ import annotations

import csv
import tempfile
from pathlib import Path

import numpy as np

from nodesim.bench import best_time_s
from nodesim.replay import logformat as lf
from nodesim.replay.reader import read_log
from nodesim.replay.recorder import NodeRecording, write_log
from nodesim.replay.session import replay

HZ = 65.0
DURATION_S = 3600.0
CONFIG = """name = "bench-replay"
[simulation]
duration_s = 3600.0
[metrics]
window_start_s = 1000.0
window_end_s = 3600.0
"""


def make_log(directory: Path) -> tuple[Path, Path]:
    rng = np.random.default_rng(11)
    t = np.arange(int(DURATION_S * HZ)) / HZ
    rate_deg_s = np.where((t > 50.0) & (t < 1800.0), 36.0, 0.0)
    angle_deg = np.cumsum(rate_deg_s) / HZ
    cols = {"t_s": t}
    for i, c in enumerate(lf.GYRO):
        cols[c] = np.round(131.0 * ((rate_deg_s if i == 2 else 0.0) + 0.3 + rng.normal(0, 0.06, t.size)))
    for i, c in enumerate(lf.ACCEL):
        cols[c] = np.round(16384.0 * ((0.999 if i == 2 else 0.03) + rng.normal(0, 0.002, t.size)))
    cols["encoder"] = np.round(angle_deg / 360.0 * 1024) % 1024
    meta = lf.LogMeta(gyro_unit="counts", accel_unit="counts", encoder_unit="counts", gyro_lsb_per_deg_s=131.0,
                      accel_lsb_per_g=16384.0, encoder_counts_per_rev=1024, description="benchmark log")
    log = write_log(directory / "lab_1h_65hz.csv", [NodeRecording(1, cols)], meta)
    cfg = directory / "firmware.toml"
    cfg.write_text(CONFIG)
    return log, cfg


def python_csv_loop(path: Path, max_rows: int) -> float:
    """Parse rows with the csv module and sum the z gyro per 1.9 Hz tick in a Python loop."""
    sums: dict[int, float] = {}
    with open(path) as fh:
        reader = csv.reader(line for line in fh if not line.startswith("#"))
        names = next(reader)
        it, iz = names.index("t_s"), names.index("gyro_z")
        for n, row in enumerate(reader):
            if n >= max_rows:
                break
            values = [float(x) if x else float("nan") for x in row]
            k = int(values[it] * 1.9)
            sums[k] = sums.get(k, 0.0) + values[iz]
    return sum(sums.values())


def replay_throughput() -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        log, cfg = make_log(Path(tmp))
        rows = int(DURATION_S * HZ)
        t_replay = best_time_s(lambda: replay(log, cfg, schedule="continuous", write=False), repeat=2)
        t_read = best_time_s(lambda: read_log(log), repeat=2)
        slice_rows = rows // 10
        t_loop = best_time_s(lambda: python_csv_loop(log, slice_rows), repeat=2) * rows / slice_rows
    return {
        "replay_1h_65hz_s": t_replay,
        "read_1h_65hz_s": t_read,
        "replay_to_read_ratio": t_replay / t_read,
        "python_csv_loop_1h_65hz_s": t_loop,
        "replay_speedup_vs_python_csv_loop": t_loop / t_replay,
    }


BENCHMARKS = [replay_throughput]
