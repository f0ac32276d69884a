"""``nodesim calibrate DATA.csv [--method turntable|lsq] [--json]``: IMU calibration from test positions.

Each CSV row is one test position: ``true_x,true_y,true_z,meas_x,meas_y,meas_z`` (true applied rate or
gravity vector, averaged sensor output; any consistent units).  Output: ``bias`` (3), ``matrix`` (3x3,
row i = sensor axis i, so meas = matrix @ true + bias) and the residuals per position.
"""

from __future__ import annotations

import sys

from nodesim.io.rundir import dumps_json


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


def run(args) -> int:
    import numpy as np

    from nodesim.sensors.calibration import calibrate, read_positions

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
