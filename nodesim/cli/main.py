"""The ``nodesim`` console script: one parser, one module per sub-command.

Each sub-command lives in ``nodesim/cli/<name>_command.py`` and exposes ``register(subparsers)``, which adds its
parser and sets ``func``.  User errors (:data:`nodesim.errors.USER_ERRORS`) print one clear message on
stderr, without a traceback, and exit with status 2.
"""

from __future__ import annotations

import argparse
import importlib
import sys

import nodesim
from nodesim.errors import USER_ERRORS

COMMANDS = ("run", "link", "uncertainty", "calibrate", "sweep", "optimize", "replay", "report", "validate", "bench", "firmware",
            "export", "scenario")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="nodesim",
        description=(
            "Simulator of a drill-string sensor chain: replay lab experiments, test reference-update and "
            "timeout schedules, and ask link-budget what-ifs end to end."
        ),
    )
    parser.add_argument("--version", action="version", version=f"nodesim {nodesim.__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name in COMMANDS:
        importlib.import_module(f"nodesim.cli.{name}_command").register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except USER_ERRORS as err:
        print(f"nodesim {args.command}: error: {err}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"nodesim {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
