"""``nodesim replay``: recorded logs through the firmware (not implemented yet: arrives with log replay)."""

from nodesim.cli._pending import register_pending


def _args(p) -> None:
    p.add_argument("log", metavar="LOG", help="recorded lab log (CSV or Parquet)")
    p.add_argument("--firmware", metavar="CONFIG.toml", required=True, help="firmware configuration")
    p.add_argument("--schedule", help="reference-update schedule to impose")
    p.add_argument("--out", metavar="DIR", help="run directory")


def register(sub) -> None:
    register_pending(sub, "replay", "replay a recorded lab log through the firmware model", "it arrives with log replay", _args)
