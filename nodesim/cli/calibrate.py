"""``nodesim calibrate``: IMU calibration (not implemented yet: arrives with the sensor models)."""

from nodesim.cli._pending import register_pending


def _args(p) -> None:
    p.add_argument("data", metavar="DATA.csv", help="one row per test position: true_x,true_y,true_z,meas_x,meas_y,meas_z")
    p.add_argument("--method", choices=["turntable", "lsq"], default="lsq", help="estimator (default lsq)")
    p.add_argument("--json", action="store_true", help="print machine-readable JSON on stdout")


def register(sub) -> None:
    register_pending(sub, "calibrate", "IMU calibration from test positions", "it arrives with the sensor models", _args)
