"""``nodesim uncertainty``: wellpath and ISCWSA covariance (not implemented yet: arrives with the ground station)."""

from nodesim.cli._pending import register_pending


def _args(p) -> None:
    p.add_argument("survey", metavar="SURVEY.csv", help="survey with columns md_m,inc_deg,azi_deg")
    p.add_argument("--tool", required=True, help="tool model name (dip, vn100t, stim300, ipst_rqh, mpu6500, ...)")
    p.add_argument("--json", action="store_true", help="print machine-readable JSON on stdout")
    p.add_argument("--plot", metavar="PNG", help="write the trajectory with its ellipses")


def register(sub) -> None:
    register_pending(
        sub, "uncertainty", "wellpath and ISCWSA position uncertainty per station", "it arrives with the ground station", _args
    )
