"""``nodesim firmware export-config SCENARIO.toml -o node_config.h``: the scenario's firmware build as a C header.

The header holds every numeric format and constant of the fixed-point firmware the scenario simulates
(:meth:`firmware_model.config.FirmwareConfig.c_header`): the C reference (``firmware_model/c``) compiles against it,
so what was simulated is what gets flashed.
"""

from __future__ import annotations

import sys
from pathlib import Path


def register(sub) -> None:
    p = sub.add_parser("firmware", help="the node firmware: export its configuration as a C header",
                       description="Node firmware tools.")
    fsub = p.add_subparsers(dest="firmware_command", metavar="ACTION", required=True)
    e = fsub.add_parser("export-config", help="write the scenario's firmware formats and constants as a C header",
                        description="Write the fixed-point firmware configuration of SCENARIO.toml as a C header "
                        "that the C reference firmware compiles against.")
    e.add_argument("scenario", metavar="SCENARIO.toml")
    e.add_argument("-o", "--output", metavar="FILE.h", help="header to write (default: stdout)")
    e.set_defaults(func=run_export)


def run_export(args) -> int:
    from nodesim.chain.estimator import firmware_config
    from nodesim.io.rundir import atomic_write_bytes
    from nodesim.scenario.schema import load_scenario

    scenario, _ = load_scenario(args.scenario)
    header = firmware_config(scenario).c_header(scenario.name)
    if args.output is None:
        sys.stdout.write(header)
        return 0
    atomic_write_bytes(Path(args.output), header.encode())
    print(f"wrote {args.output}", file=sys.stderr)
    return 0
