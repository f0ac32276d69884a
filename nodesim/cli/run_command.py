"""``nodesim run``: one simulation, written to a run directory."""

from __future__ import annotations

import re
import shutil
import sys
import tempfile
from pathlib import Path



def register(sub) -> None:
    p = sub.add_parser(
        "run",
        help="run one simulation and write a run directory",
        description="Run one scenario and write manifest.json, summary.json, tables and plots to a run directory.",
    )
    p.add_argument("scenario", type=Path, help="scenario TOML file")
    p.add_argument("--out", type=Path, default=None, help="run directory (default runs/<name>-<UTC timestamp>)")
    p.add_argument("--force", action="store_true", help="replace a non-empty --out directory (written aside, then swapped in)")
    p.add_argument("--seed", type=int, default=None, help="override the scenario's root seed")
    p.add_argument("--realizations", type=int, default=None, help="override simulation.realizations")
    p.add_argument("--dry-run", action="store_true", help="validate and print the resolved scenario; write nothing")
    p.add_argument("--record", type=Path, default=None, help="also write realization 0 as a replay log (.csv or .parquet; nodesim replay reads it)")
    p.add_argument("--json", action="store_true", help="print the summary as JSON on stdout")
    p.add_argument("--all", action="store_true", help="print every summary key (default: the headline keys and the bottom node)")
    p.add_argument("--csv", action="store_true", help="write timeseries.csv instead of timeseries.parquet "
                   "(as [output] format = \"csv\")")
    p.add_argument("--quiet", action="store_true", help="no progress bar (it is shown only on a terminal anyway)")
    p.set_defaults(func=run)


def run(args) -> int:
    from nodesim.api import check_unused, simulate_scenario
    from nodesim.io.rundir import default_run_dir, dumps_json
    from nodesim.scenario.schema import load_scenario

    scenario, digest = load_scenario(args.scenario)
    overrides = {}
    if args.seed is not None:
        overrides["seed"] = args.seed
    if args.realizations is not None:
        overrides["simulation.realizations"] = args.realizations
    if args.csv:
        overrides["output.format"] = "csv"
    if overrides:
        scenario = scenario.with_overrides(**overrides)
    if args.dry_run:
        sys.stdout.write(dumps_json(scenario.model_dump()).decode())
        return 0
    from nodesim.sweep.progress import SimulatedTimeProgress

    out = args.out if args.out is not None else default_run_dir(scenario.name)
    if not args.force:
        check_unused(out)  # before simulating: a used directory is refused at once
    # the timeseries is written node by node while the run simulates, into a private directory beside the run
    # directory that the save then renames it out of (--record needs every node's records: not streamed)
    stage = None if args.record is not None else stream_stage(out)
    try:
        with SimulatedTimeProgress(scenario.simulation.duration_s, quiet=args.quiet) as bar:
            result = simulate_scenario(scenario, digest, progress=bar.update if bar.enabled else None,
                                       stream_to=stage)
        out = result.save(out, force=args.force)
    finally:
        if stage is not None:
            shutil.rmtree(stage, ignore_errors=True)
    from nodesim.chain.metrics import singularity_warning

    if (warning := singularity_warning(result.summary)) is not None:
        print(f"nodesim run: {warning}", file=sys.stderr)
    if args.record is not None:
        from nodesim.replay.chain_log import record_chain_run

        record_chain_run(args.record, result.chain, scenario)
    if args.json:
        sys.stdout.write(dumps_json(result.summary).decode())
    else:
        print_summary(result.summary, out, every_key=args.all)
    return 0


def stream_stage(out: Path) -> Path:
    """A new private directory ``.<name>.stream-XXXX`` beside the run directory ``out`` (same file system: the
    streamed table is renamed into the run directory, never copied)."""
    from nodesim.errors import NodesimError

    out = Path(out)
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        return Path(tempfile.mkdtemp(prefix=f".{out.name}.stream-", dir=out.parent))
    except OSError as err:
        raise NodesimError(f"{out}: cannot write beside it in {out.parent} ({err.strerror}); give a run directory "
                           "(--out) in a writable place") from None


PER_NODE = re.compile(r"^(node|hop)(\d+)_")


def shown_keys(summary: dict, every_key: bool = False) -> list[str]:
    """The summary keys the terminal table shows: all of them with ``every_key``; else the chain-wide keys
    (headline metrics are those of the bottom node) and the bottom node's own ``node<N>_*`` keys, so a long
    chain does not print hundreds of rows (summary.json always holds every key)."""
    keys = [k for k in summary if k != "timing"]
    if every_key:
        return keys
    nodes = [int(m.group(2)) for k in keys if (m := PER_NODE.match(k)) and m.group(1) == "node"]
    bottom = max(nodes, default=None)
    return [k for k in keys if not (m := PER_NODE.match(k)) or (m.group(1) == "node" and int(m.group(2)) == bottom)]


def print_summary(summary: dict, out_dir: Path, every_key: bool = False) -> None:
    keys = shown_keys(summary, every_key)
    rows = [(k, summary[k]) for k in keys]
    width = max(len(k) for k, _ in rows)
    print(f"{'metric':<{width}}  value")
    print(f"{'-' * width}  {'-' * 12}")
    for key, value in rows:
        shown = f"{value:.4g}" if isinstance(value, float) else ("n/a" if value is None else str(value))
        print(f"{key:<{width}}  {shown}")
    hidden = len(summary) - 1 - len(keys)
    if hidden > 0:
        print(f"({hidden} per-node and per-hop keys not shown: --all prints them; every key is in summary.json)")
    timing = summary["timing"]
    print(f"run directory: {out_dir}  (wall time {timing['wall_s'] + timing.get('save_s', 0.0):.2f} s)")


__all__ = ["register", "run"]
