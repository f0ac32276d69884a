"""``nodesim replay LOG --firmware CONFIG.toml``: a recorded log through the firmware model.

The log format is documented in :mod:`nodesim.replay.logformat`; CONFIG.toml is a scenario file whose
``[filter]``, ``[schedule]``, ``chain.firmware_rate_hz``, ``motion.stationary_s`` (static bias window),
``sensor.gyro_*`` (noise) and ``sensor.encoder_counts_per_rev`` describe the firmware.
"""

from __future__ import annotations

import sys
from pathlib import Path

from nodesim.io.rundir import dumps_json


def _tolerance(text: str) -> tuple[str, float]:
    from nodesim.errors import NodesimError
    from nodesim.replay.session import TOLERANCE_KEYS

    key, _, value = text.partition("=")
    try:
        tol = float(value)
    except ValueError:
        tol = -1.0
    if key not in TOLERANCE_KEYS or not tol >= 0:
        raise NodesimError(f"--tolerance {text!r}: allowed QUANTITY=VALUE >= 0 with QUANTITY in {list(TOLERANCE_KEYS)} "
                           "(deg, deg^2 for fw_yaw_var, deg/s for fw_bias)")
    return key, tol


def register(sub) -> None:
    p = sub.add_parser(
        "replay",
        help="replay a recorded lab log through the firmware model",
        description="Feed a recorded log (CSV or Parquet, nodesim-log format) to the firmware model at its recorded "
        "times, under its recorded or an imposed reference-update schedule; write a run directory and, when the log "
        "holds the firmware's own outputs, the per-tick difference and the first divergence.",
    )
    p.add_argument("log", metavar="LOG", type=Path, help="recorded log (.csv or .parquet)")
    p.add_argument("--firmware", metavar="CONFIG.toml", type=Path, required=True, help="firmware configuration (a scenario file)")
    p.add_argument("--schedule", default=None,
                   help="recorded | config | continuous | none | windowed:UPDATE_S:TIMEOUT_S | single:RATE_HZ "
                        "(default: recorded if the log records its updates, else config)")
    p.add_argument("--out", metavar="DIR", type=Path, default=None, help="run directory (default runs/replay-<log>-<UTC timestamp>)")
    p.add_argument("--repair", action="store_true", help="apply the documented repairs instead of stopping at the first problem")
    p.add_argument("--max-gap", type=float, default=1.0, metavar="S", help="longest allowed gap between samples (default 1 s)")
    p.add_argument("--noise", choices=["config", "allan"], default="config",
                   help="gyro noise of the filter: from the configuration or from the log's Allan deviation")
    p.add_argument("--allan-slope-tolerance", type=float, default=0.05, metavar="D",
                   help="with --noise allan: points within D of slope -1/2 form the ARW line (default 0.05)")
    p.add_argument("--tolerance", action="append", default=[], metavar="QUANTITY=VALUE",
                   help="divergence threshold per recorded output (default 0: bit-identical), e.g. fw_yaw=1e-3")
    p.add_argument("--no-plots", action="store_true", help="skip yaw_error.png")
    p.add_argument("--json", action="store_true", help="print the summary as JSON on stdout")
    p.set_defaults(func=run)


def run(args) -> int:
    from nodesim.replay.session import replay

    tolerances = dict(_tolerance(t) for t in args.tolerance)
    outcome = replay(args.log, args.firmware, args.schedule, args.out, repair=args.repair, max_gap_s=args.max_gap,
                     noise=args.noise, allan_slope_tolerance=args.allan_slope_tolerance, tolerances=tolerances, plots=not args.no_plots)
    s = outcome.summary
    if args.json:
        sys.stdout.write(dumps_json(s).decode())
        return 0
    print(f"replayed {s['log']}: {s['nodes']} node(s), schedule {s['schedule']}, {s['implementation']} filter")
    for m in s["per_node"]:
        rms = "n/a" if m["rms_yaw_error_deg"] is None else f"{m['rms_yaw_error_deg']:.4g} deg"
        print(f"  node {m['node']}: {m['ticks']} ticks, updates {m['update_fraction']:.3f}, RMS yaw error {rms} "
              f"(vs {m['yaw_error_reference']}), held ticks {m['held_ticks']}")
    if s["repairs"]:
        print(f"  repairs: {s['repairs']}")
    if "comparison" in s:
        first = s["first_divergence"]
        verdict = "bit-identical" if s["bit_identical"] else (
            f"first divergence: node {first['node']} {first['quantity']} at t = {first['t_s']:.6g} s (tick {first['tick']})"
            if first else "within tolerance")
        print(f"  model vs recorded firmware: {verdict}")
    print(f"run directory: {outcome.out_dir}")
    return 0


__all__ = ["register", "run"]
