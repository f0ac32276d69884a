"""Start-up cost of the console script: building the parser (``nodesim --help``) imports no heavy library.

Heavy libraries are imported by each command's run function only.  Timing is not asserted (machines differ);
what is asserted is which modules building the parser pulls in, in a fresh interpreter.
"""

import json
import subprocess
import sys

HEAVY = ("numba", "pandas", "pyarrow", "dask", "matplotlib", "scipy", "simpy", "pydantic")

_PROBE = """
import argparse, importlib, json, sys
watch = set(sys.argv[1].split(","))
skip = set(filter(None, sys.argv[2].split(",")))

def loaded():
    return {m.split(".")[0] for m in sys.modules} & watch

import nodesim.cli.main as main
by = {"import nodesim.cli.main": sorted(loaded())}
if skip:  # only the other commands' parsers
    sub = argparse.ArgumentParser().add_subparsers()
    for name in main.COMMANDS:
        if name not in skip:
            before = loaded()
            importlib.import_module(f"nodesim.cli.{name}_command").register(sub)
            by[name] = sorted(loaded() - before)
else:  # the real parser, as `nodesim --help` builds it
    main.build_parser()
print(json.dumps({"loaded": sorted(loaded()), "by": {k: v for k, v in by.items() if v}}))
"""


def _probe(watch, skip=()):
    proc = subprocess.run([sys.executable, "-c", _PROBE, ",".join(watch), ",".join(skip)],
                          capture_output=True, text=True, timeout=120, check=False)
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout.strip().splitlines()[-1])


def _culprits(watch, skip=()):
    """Which step imports which watched package, one fresh interpreter per command (for the failure message)."""
    from nodesim.cli.main import COMMANDS

    found = {}
    for name in COMMANDS:
        if name in skip:
            continue
        others = [c for c in COMMANDS if c != name]
        got = _probe(watch, skip=others)["by"]
        found |= {step: pkgs for step, pkgs in got.items() if step in (name, "import nodesim.cli.main")}
    return found


def test_cli_parser_imports_no_heavy_modules():
    """``import nodesim.cli.main; build_parser()`` (what ``nodesim --help`` does) loads none of HEAVY."""
    offenders = _probe(HEAVY)["loaded"]
    assert not offenders, (
        f"building the nodesim parser imported heavy package(s) {offenders}; by step: {_culprits(HEAVY)}. "
        "Import them inside the command's run function, not at the top of nodesim/cli/<name>_command.py or of a "
        "module it imports at top level."
    )


def test_cli_parsers_other_than_link_do_not_import_numpy():
    """numpy (~0.1 s) is loaded at parser time only by ``link`` (its parameter table comes from channel)."""
    offenders = _probe(("numpy",), skip=("link",))["loaded"]
    assert not offenders, (
        f"building the parsers other than 'link' imported numpy; by step: {_culprits(('numpy',), skip=('link',))}"
    )
