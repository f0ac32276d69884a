"""The deviated-well what-if (issue 24): scenarios/whatif/deviated_*.toml run with the 2-state and the 6-state
filter; prints the markdown table of docs/deviated_wells.md and writes docs/figures/deviated_yaw_error.png.

    PYTHONPATH=. python scripts/deviated_wells.py [--out docs/figures/deviated_yaw_error.png]

Every number comes from the runs made here (seeds from the scenario files); tests/nodesim/test_whatif_deviated.py
checks the must-shows on the same files.
"""

from __future__ import annotations

import argparse
import sys
import time
from importlib import resources
from pathlib import Path

import numpy as np

from nodesim.chain.metrics import per_realization_metrics, summarize
from nodesim.chain.network import simulate_chain
from nodesim.scenario.schema import load_scenario

NAMES = ("deviated_02deg.toml", "deviated_15deg.toml", "deviated_45deg.toml", "deviated_80deg.toml")
BETWEEN_DEG = (60.0, 70.0, 82.0, 85.0)
"""Inclinations run as the 80 deg file with only ``motion.inclination_deg`` changed: where the ratio crosses 2."""
KEYS = ("rms_yaw_error_deg", "rms_azimuth_error_deg", "node1_rms_yaw_error_deg")


def run_pair(name: str, inclination_deg: float | None = None) -> tuple[float, dict, dict]:
    """(inclination [deg], 2-state summary, 6-state summary) of one what-if file (at ``inclination_deg`` instead
    of its own, if given)."""
    with resources.as_file(resources.files("scenarios") / "whatif" / name) as p:
        s, _ = load_scenario(p)
    if inclination_deg is not None:
        s = s.with_overrides(**{"motion.inclination_deg": inclination_deg})
    out = {}
    for states in (2, 6):
        x = s.with_overrides(**{"filter.states": states})
        out[states] = summarize(per_realization_metrics(simulate_chain(x), x.metrics))
    return s.motion.inclination_deg, out[2], out[6]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path("docs/figures/deviated_yaw_error.png"))
    args = ap.parse_args(argv)
    rows = []
    for name, inclination in [(n, None) for n in NAMES] + [(NAMES[-1], x) for x in BETWEEN_DEG]:
        t0 = time.perf_counter()
        rows.append(run_pair(name, inclination))
        print(f"{name} {inclination or ''}: {time.perf_counter() - t0:.1f} s", file=sys.stderr)
    rows.sort(key=lambda r: r[0])
    print("| inclination (deg) | 2-state RMS yaw error (deg) | 6-state RMS yaw error (deg) | ratio 2/6 | "
          "2-state RMS azimuth error (deg) | 6-state RMS azimuth error (deg) | 6-state singular ticks |")
    print("|---|---|---|---|---|---|---|")
    for inc, two, six in rows:
        print(f"| {inc:g} | {two['rms_yaw_error_deg']:.4f} | {six['rms_yaw_error_deg']:.4f} | "
              f"{two['rms_yaw_error_deg'] / six['rms_yaw_error_deg']:.4f} | {two['rms_azimuth_error_deg']:.4f} | "
              f"{six['rms_azimuth_error_deg']:.4f} | {six['singular_ticks']:g} |")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    inc = np.array([r[0] for r in rows])
    fig, ax = plt.subplots(figsize=(6.0, 3.8))
    for states, marker in ((2, "o"), (6, "s")):
        i = 1 if states == 2 else 2
        ax.plot(inc, [r[i]["rms_yaw_error_deg"] for r in rows], marker=marker, label=f"{states}-state: yaw")
        ax.plot(inc, [r[i]["rms_azimuth_error_deg"] for r in rows], marker=marker, ls="--",
                label=f"{states}-state: azimuth")
    ax.set_xlabel("inclination (deg)")
    ax.set_ylabel("bottom node RMS error (deg)")
    ax.set_title("3-node chain, windowed 20 s / 10 s, straight string")
    ax.set_ylim(bottom=0.0)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.out, dpi=120)
    print(f"wrote {args.out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
