"""Converters of public IMU recordings into the replay log format.

:func:`pololu_recording` reads ``tests/data/data_polulu.txt`` of scikit-kinematics (Thomas Haslwanter,
BSD licence; a Pololu MinIMU-9 v5 board: LSM6DS33 gyro/accelerometer, LIS3MDL magnetometer).  The file is
whitespace-separated, one sample per line: ``acc_x acc_y acc_z gyr_x gyr_y gyr_z mag_x mag_y mag_z
t_accgyr_ms t_mag_ms`` in raw int16 counts and milliseconds (about 146 Hz for acc/gyro, 25 s).  The board
lies still for ~14 s with its x axis up, then turns ~180 deg about its z axis and lies still again.

Conversion (documented choices):
  - ``t_s`` = t_accgyr / 1000; the magnetometer, sampled on its own clock, is carried as recorded;
  - counts are kept as counts; ``accel_lsb_per_g`` = 1 / 0.061e-3 (LSM6DS33 +/-2 g);
  - ``gyro_lsb_per_deg_s`` = 1 / 8.75e-3 (LSM6DS33 +/-245 deg/s).  scikit-kinematics' own reader uses
    4.375e-3 deg/s per LSB (+/-125 deg/s); with it the z gyro integrates to ~89 deg over the turn while the
    accelerometer toolface turns by ~180 deg, so the recording was made at +/-245 deg/s.  The test that
    checks this integrates the gyro against the accelerometer (``tests/nodesim/replay/test_real_log.py``);
  - no encoder (``encoder_unit = absent``): the recording has no reference, so it is replayed with the
    schedule ``none`` (free-running yaw), the z axis taken as the string axis.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from nodesim.errors import NodesimError
from nodesim.replay.logformat import LogMeta
from nodesim.replay.recorder import NodeRecording

POLOLU_COLUMNS = ("accel_x", "accel_y", "accel_z", "gyro_x", "gyro_y", "gyro_z", "mag_x", "mag_y", "mag_z", "t_ms", "t_mag_ms")
POLOLU_GYRO_DEG_S_PER_LSB = 8.75e-3
POLOLU_ACCEL_G_PER_LSB = 0.061e-3
POLOLU_SOURCE = ("scikit-kinematics 0.10.4, tests/data/data_polulu.txt (Pololu MinIMU-9 v5, LSM6DS33 + LIS3MDL); "
                 "Copyright (C) 2016 Thomas Haslwanter, BSD licence")


def pololu_recording(path) -> tuple[NodeRecording, LogMeta]:
    """The Pololu recording as one node of a log (raw counts) and its header."""
    path = Path(path)
    try:
        raw = np.loadtxt(path)
    except (OSError, ValueError) as err:
        raise NodesimError(f"{path}: not a scikit-kinematics Pololu recording ({err})") from None
    if raw.ndim != 2 or raw.shape[1] != len(POLOLU_COLUMNS):
        raise NodesimError(f"{path}: {raw.shape[-1]} columns; allowed {len(POLOLU_COLUMNS)} ({' '.join(POLOLU_COLUMNS)})")
    cols = dict(zip(POLOLU_COLUMNS, raw.T))
    columns = {"t_s": cols["t_ms"] / 1000.0}
    columns.update({k: cols[k] for k in POLOLU_COLUMNS[:9]})
    meta = LogMeta(
        gyro_unit="counts",
        accel_unit="counts",
        encoder_unit="absent",
        gyro_lsb_per_deg_s=1.0 / POLOLU_GYRO_DEG_S_PER_LSB,
        accel_lsb_per_g=1.0 / POLOLU_ACCEL_G_PER_LSB,
        mag_unit="counts (LIS3MDL, 6842 LSB/gauss)",
        source=POLOLU_SOURCE,
        description="board still ~14 s (x up), turned ~180 deg about z, still again; 25 s",
    )
    return NodeRecording(1, columns), meta


__all__ = ["pololu_recording", "POLOLU_SOURCE"]
