"""``nodesim link``: link-budget what-ifs (not implemented yet: arrives with the radio channel models)."""

from nodesim.cli._pending import register_pending


def _args(p) -> None:
    p.add_argument("medium", choices=["soil", "pipe"], help="868 MHz through soil or 5 GHz inside the drill pipe")
    p.add_argument("--sweep", metavar="KEY=START:STOP:N", help="sweep one parameter over a range")
    p.add_argument("--plot", metavar="PNG", help="write a plot of the sweep")
    p.add_argument("--json", action="store_true", help="print machine-readable JSON on stdout")


def register(sub) -> None:
    register_pending(sub, "link", "link-budget what-ifs for one radio hop", "it arrives with the radio channel models", _args)
