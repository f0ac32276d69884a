"""``nodesim report``: HTML report (not implemented yet: arrives with sweeps and reports)."""

from nodesim.cli._pending import register_pending


def _args(p) -> None:
    p.add_argument("directory", metavar="RUN_OR_CAMPAIGN_DIR", help="a run or campaign directory")


def register(sub) -> None:
    register_pending(sub, "report", "self-contained HTML report of a run or campaign", "it arrives with sweeps and reports", _args)
