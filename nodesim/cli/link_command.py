"""``nodesim link soil|pipe``: link-budget what-ifs for one radio hop (868 MHz through soil, 5 GHz in the pipe).

Every physical parameter is an option (defaults: thesis chapter 5 figures, see ``--help``); ``--sweep
KEY=START:STOP:N`` evaluates one parameter over a range in one vectorised call; ``--plot FILE.png`` draws the
sweep (or, without a sweep, received power against distance / pipe length); ``--json`` prints only JSON.
The keys are listed in :mod:`nodesim.chain.link_whatif` and the README.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import TYPE_CHECKING

from nodesim.io.rundir import dumps_json

if TYPE_CHECKING:
    from matplotlib.figure import Figure

SOIL_TABLE = ("eps_real", "eps_imag", "alpha_np_per_m", "beta_rad_per_m", "free_space_loss_db", "path_loss_db",
              "rss_dbm", "margin_db", "max_distance_m", "exceeds_porosity", "snr_db", "packet_error_rate")
PIPE_TABLE = ("resistivity_ohm_m", "attenuation_db_per_m", "loss_db", "rx_power_dbm", "margin_db", "max_length_m",
              "snr_db", "packet_error_rate")


def _option(key: str) -> str:
    return "--" + key.replace("_", "-")


def register(sub) -> None:
    from channel.per import MODULATIONS
    from nodesim.chain.link_whatif import FILLINGS, PIPE_PARAMS, SOIL_PARAMS

    p = sub.add_parser(
        "link",
        help="link-budget what-ifs for one radio hop",
        description=(
            "Link budget of one hop: 868 MHz through soil (Peplinski dielectric model, thesis eqs 5.1-5.3) or "
            "5 GHz inside the steel pipe (circular waveguide, thesis eqs 5.4-5.8). Prints a table, or JSON with "
            "--json; --sweep evaluates one parameter over a range; the max distance/length answers 'how far apart "
            "for --target-margin-db'. Options apply to the medium that has them."
        ),
    )
    p.add_argument("medium", choices=["soil", "pipe"], help="868 MHz through soil or 5 GHz inside the drill pipe")
    p.add_argument("--sweep", metavar="KEY=START:STOP:N", help="sweep one numeric parameter, e.g. vwc=0.01:0.8:20")
    p.add_argument("--plot", metavar="PNG", type=Path, help="write a plot (of the sweep, or against distance/length)")
    p.add_argument("--json", action="store_true", help="print machine-readable JSON on stdout")
    seen = set()
    for title, params in (("soil", SOIL_PARAMS), ("pipe", PIPE_PARAMS)):
        group = p.add_argument_group("soil and shared parameters (defaults: soil, then pipe where they differ)"
                                     if title == "soil" else "pipe parameters")
        for prm in params:
            if prm.key in seen:
                continue
            seen.add(prm.key)
            other = PIPE_PARAMS if title == "soil" else SOIL_PARAMS
            other_default = {q.key: q.default for q in other}.get(prm.key)
            default_txt = f"{prm.default:g}" + (f" soil, {other_default:g} pipe" if other_default not in (None, prm.default)
                                                 and title == "soil" else "")
            group.add_argument(_option(prm.key), dest=prm.key, type=float, default=None, metavar="X",
                               help=f"{prm.help} (default {default_txt})".replace("%", "%%"))
    p.add_argument("--modulation", choices=MODULATIONS, default="fsk_noncoherent",
                   help="modulation for the BER/PER (default fsk_noncoherent: 2-FSK/GFSK, CC1101-like)")
    pipe = p.add_argument_group("pipe options")
    pipe.add_argument("--filling", choices=FILLINGS, default="air", help="what fills the bore (default air)")
    pipe.add_argument("--mode", default="TE11", help="mode whose attenuation is reported (default the dominant TE11)")
    pipe.add_argument("--grade", default=None, help="API 5L grade of thesis Table 5.1 (sets --carbon-wt-pct), e.g. 'X60 SMLS'")
    pipe.add_argument("--resistivity-ohm-m", type=float, default=None, metavar="X",
                      help="wall resistivity [Ohm*m]; overrides the carbon/temperature model")
    p.set_defaults(func=run)


def _values(args, medium: str) -> dict:
    from channel.steel import grade_carbon_wt_pct
    from nodesim.errors import NodesimError
    from nodesim.chain.link_whatif import PARAMS

    keys = {q.key for q in PARAMS[medium]}
    other = {q.key for q in PARAMS["pipe" if medium == "soil" else "soil"]} - keys
    given = [k for k in other if getattr(args, k) is not None]
    if given:
        raise NodesimError(f"option(s) {', '.join(_option(k) for k in sorted(given))} do not apply to 'link {medium}'")
    values = {q.key: (q.default if getattr(args, q.key) is None else getattr(args, q.key)) for q in PARAMS[medium]}
    if medium == "pipe" and args.grade is not None:
        values["carbon_wt_pct"] = grade_carbon_wt_pct(args.grade)
    return values


def run(args) -> int:
    from nodesim.chain.link_whatif import evaluate, parse_sweep

    medium = args.medium
    values = _values(args, medium)
    sweep = parse_sweep(medium, args.sweep) if args.sweep else None
    opts = {"modulation": args.modulation}
    if medium == "pipe":
        opts |= {"filling": args.filling, "mode": args.mode, "resistivity_ohm_m": args.resistivity_ohm_m}
    out = evaluate(medium, values, sweep, **opts)
    if args.plot is not None:
        _plot(medium, values, sweep, out, opts, args.plot)
    if args.json:
        sys.stdout.write(dumps_json(out).decode())
        return 0
    print(format_result(medium, out))
    return 0


def _fmt(v) -> str:
    import numpy as np

    if isinstance(v, (bool, np.bool_)):
        return "yes" if v else "no"
    v = float(v)
    return "cut off" if not np.isfinite(v) else f"{v:.4g}"


def format_result(medium: str, out: dict) -> str:
    import numpy as np

    cols = SOIL_TABLE if medium == "soil" else PIPE_TABLE
    lines = []
    if medium == "pipe":
        lines.append("cutoff: " + ", ".join(f"{k} {float(np.ravel(v)[0]) / 1e9:.4g} GHz" if np.size(v) == 1
                                            else f"{k} (swept)" for k, v in out["cutoff_hz"].items()))
        if out["propagating_modes"] is not None:
            lines.append(f"propagating at this frequency: {', '.join(out['propagating_modes'])}  "
                         f"(reported mode {out['mode']}, filling {out['filling']})")
    if "sweep" in out:
        key = out["sweep"]["key"]
        header = (key, *cols)
        rows = [(f"{x:.4g}", *(_fmt(out[c][i]) for c in cols)) for i, x in enumerate(out["sweep"]["values"])]
    else:
        header = ("quantity", "value")
        rows = [(c, _fmt(out[c])) for c in cols]
    widths = [max(len(str(r[i])) for r in [header, *rows]) for i in range(len(header))]
    lines.append("  ".join(h.ljust(w) for h, w in zip(header, widths)))
    lines.append("  ".join("-" * w for w in widths))
    lines += ["  ".join(str(v).ljust(w) for v, w in zip(r, widths)).rstrip() for r in rows]
    target = out["inputs"]["target_margin_db"]
    what = "max_distance_m" if medium == "soil" else "max_length_m"
    if "sweep" not in out:
        lines.append(f"{what}: how far apart two nodes can be while keeping {target:g} dB of margin")
    return "\n".join(lines)


def link_figure(medium: str, values: dict, sweep, out: dict, opts: dict) -> Figure:
    """Received power and path loss against the swept parameter (without a sweep: distance / pipe length)."""
    import numpy as np
    from matplotlib.figure import Figure  # lazy: `nodesim --help` and table/JSON output do not load matplotlib

    from nodesim.chain.link_whatif import evaluate

    power = "rss_dbm" if medium == "soil" else "rx_power_dbm"
    loss = "path_loss_db" if medium == "soil" else "loss_db"
    if sweep is None:
        key = "distance_m" if medium == "soil" else "length_m"
        far = float(out["max_distance_m" if medium == "soil" else "max_length_m"])
        top = 1.5 * far if np.isfinite(far) and far > 0 else 2.0 * float(values[key]) + 1.0
        xs = np.linspace(top / 200.0, top, 200)
        out = evaluate(medium, values, (key, xs), **opts)
    key, xs = out["sweep"]["key"], out["sweep"]["values"]
    fig = Figure(figsize=(7, 6))
    ax1, ax2 = fig.subplots(2, 1, sharex=True)
    ax1.plot(xs, out[power], label="received power")
    ax1.axhline(values["sensitivity_dbm"], color="tab:red", ls="--", lw=0.8, label="sensitivity")
    ax1.set_ylabel("received power [dBm]")
    ax1.legend(loc="best")
    ax2.plot(xs, out[loss], color="tab:green")
    ax2.set_ylabel("path loss [dB]")
    ax2.set_xlabel(key)
    for ax in (ax1, ax2):
        ax.grid(True, lw=0.3)
    fig.suptitle(f"nodesim link {medium}")
    fig.tight_layout()
    return fig


def _plot(medium: str, values: dict, sweep, out: dict, opts: dict, path: Path) -> None:
    """Write :func:`link_figure` to ``path`` as PNG, atomically."""
    from nodesim.io.rundir import write_png

    fig = link_figure(medium, values, sweep, out, opts)
    write_png(path, fig, dpi=100)
