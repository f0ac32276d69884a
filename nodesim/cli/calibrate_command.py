"""``nodesim calibrate DATA.csv [--method turntable|lsq] [--json]``: IMU calibration from test positions.

Each CSV row is one test position: ``true_x,true_y,true_z,meas_x,meas_y,meas_z`` (true applied rate or
gravity vector, averaged sensor output; any consistent units).  Output: ``bias`` (3), ``matrix`` (3x3,
row i = sensor axis i, so meas = matrix @ true + bias) and the residuals per position.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import TYPE_CHECKING

from nodesim.io.rundir import dumps_json

if TYPE_CHECKING:
    import numpy as np

COLUMNS = ("true_x", "true_y", "true_z", "meas_x", "meas_y", "meas_z")


def register(sub) -> None:
    p = sub.add_parser(
        "calibrate",
        help="IMU calibration from test positions",
        description="Estimate bias and scale/misalignment matrix (meas = matrix @ true + bias) from test positions.",
    )
    p.add_argument("data", metavar="DATA.csv", help="one row per test position: true_x,true_y,true_z,meas_x,meas_y,meas_z")
    p.add_argument("--method", choices=["turntable", "lsq"], default="lsq", help="estimator (default lsq)")
    p.add_argument("--json", action="store_true", help="print machine-readable JSON on stdout")
    p.set_defaults(func=run)


def read_positions(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """(true (N,3), meas (N,3)) from a calibration CSV; errors name the file, row and column."""
    import numpy as np

    from nodesim.errors import NodesimError
    from nodesim.io.csv_input import read_header_and_rows

    path = Path(path)
    header, data = read_header_and_rows(path, COLUMNS, "calibration data")
    idx = [header.index(c) for c in COLUMNS]
    values = np.empty((len(data), 6))
    for r, row in enumerate(data, start=2):
        if len(row) != len(header):
            raise NodesimError(f"{path}: row {r} has {len(row)} fields, the header has {len(header)}")
        for k, (i, name) in enumerate(zip(idx, COLUMNS)):
            try:
                values[r - 2, k] = float(row[i])
            except ValueError:
                raise NodesimError(f"{path}: row {r}, column {name}: {row[i]!r} is not a number") from None
            if not np.isfinite(values[r - 2, k]):
                raise NodesimError(f"{path}: row {r}, column {name}: {row[i]!r} is not finite")
    if values.shape[0] == 0:
        raise NodesimError(f"{path}: no data rows")
    return values[:, :3], values[:, 3:]


def run(args) -> int:
    import numpy as np

    from nodesim.sensors.calibration import calibrate

    true, meas = read_positions(args.data)
    cal = calibrate(true, meas, args.method)
    if args.json:
        sys.stdout.write(dumps_json(cal.as_dict()).decode())
        return 0
    print(f"method: {cal.method}   positions: {true.shape[0]}   condition number: {cal.condition_number:.4g}")
    print("bias:   " + "  ".join(f"{v:12.6g}" for v in cal.bias))
    print("matrix (meas = matrix @ true + bias):")
    for row in cal.matrix:
        print("        " + "  ".join(f"{v:12.6g}" for v in row))
    print(f"residuals: rms {cal.rms_residual:.4g}, max |.| {np.max(np.abs(cal.residuals)):.4g}")
    return 0
