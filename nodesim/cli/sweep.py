"""``nodesim sweep``: campaigns (not implemented yet: arrives with sweeps and campaigns)."""

from nodesim.cli._pending import register_pending


def _args(p) -> None:
    p.add_argument("sweep", metavar="SWEEP.toml", help="base scenario plus axes")
    p.add_argument("--executor", choices=["local", "dask"], default="local", help="where the runs execute")
    p.add_argument("--scheduler", metavar="ADDR", help="Dask scheduler address")
    p.add_argument("--workers", type=int, help="number of local workers")
    p.add_argument("--resume", action="store_true", help="skip the runs already done")
    p.add_argument("--out", metavar="DIR", help="campaign directory")


def register(sub) -> None:
    register_pending(sub, "sweep", "parameter sweeps and Monte Carlo campaigns", "it arrives with sweeps and campaigns", _args)
