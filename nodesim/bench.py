"""Benchmark runner (``nodesim bench``, ``make bench``).

Benchmarks live in ``benchmarks/bench_<topic>.py`` at the repository root.  Each such file defines
``BENCHMARKS``: a list of zero-argument callables returning a flat dict of figures under stable snake_case
keys.  A figure compares our code against a baseline measured in the same run (a ratio, e.g.
``*_speedup_vs_*``); raw times go under keys ending in ``_s``.  The runner merges every dict into one JSON
object and adds ``host`` information.  No benchmark asserts a time: the figures are reported, not judged.
"""

from __future__ import annotations

import importlib.util
import time
from pathlib import Path
from typing import Callable

from nodesim.errors import NodesimError
from nodesim.io.rundir import host_info


def default_bench_dir() -> Path:
    """``./benchmarks`` when it exists, else the ``benchmarks`` folder of the source checkout."""
    here = Path.cwd() / "benchmarks"
    if here.is_dir():
        return here
    return Path(__file__).resolve().parents[1] / "benchmarks"


def discover(bench_dir: Path) -> list[tuple[str, Callable[[], dict]]]:
    """(module:function, callable) for every benchmark in ``bench_dir``, in file then list order."""
    if not bench_dir.is_dir():
        raise NodesimError(
            f"benchmark folder {bench_dir} not found: the benchmarks (benchmarks/bench_*.py) belong to a source "
            "checkout and are not part of an installed wheel; run `nodesim bench` from the repository root "
            "(or pass --dir BENCHMARKS_FOLDER) with the bench extra installed: pip install -e '.[bench]'"
        )
    found = []
    for path in sorted(bench_dir.glob("bench_*.py")):
        spec = importlib.util.spec_from_file_location(f"nodesim_bench_{path.stem}", path)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        found.extend((f"{path.stem}:{fn.__name__}", fn) for fn in getattr(module, "BENCHMARKS", []))
    return found


def best_time_s(fn: Callable[[], object], repeat: int = 5, number: int = 1) -> float:
    """Best-of-``repeat`` wall time of ``number`` calls, divided by ``number`` (timeit's recommendation)."""
    return best_times_s([fn], repeat, number)[0]


def best_times_s(fns: list[Callable[[], object]], repeat: int = 5, number: int = 1) -> list[float]:
    """Best-of-``repeat`` wall time of ``number`` calls of each of ``fns``, divided by ``number``, their rounds
    interleaved (fns[0], fns[1], ..., then again): every side is timed over the same stretch of the run, so that a
    host whose speed drifts over minutes (a shared VM: the same call here varies up to 1.6x from one minute to the
    next) gives each side the same conditions, rather than one side a fast minute and the other a slow one."""
    best = [float("inf")] * len(fns)
    for _ in range(repeat):
        for i, fn in enumerate(fns):
            t0 = time.perf_counter()
            for _ in range(number):
                fn()
            best[i] = min(best[i], (time.perf_counter() - t0) / number)
    return best


def chain_batched_vs_loop(base, realizations: int, prefix: str, repeat_loop: int = 2, repeat_batch: int = 3) -> dict:
    """Time ``realizations`` single-realization chain runs of scenario ``base`` (seeds base.seed + i) against
    one run with that many realizations: ``<prefix>_batched_speedup_vs_loop`` plus both raw times."""
    from nodesim.chain.network import simulate_chain

    single = [base.with_overrides(seed=base.seed + i, **{"simulation.realizations": 1}) for i in range(realizations)]
    batched = base.with_overrides(**{"simulation.realizations": realizations})
    t_loop = best_time_s(lambda: [simulate_chain(s) for s in single], repeat=repeat_loop)
    t_batch = best_time_s(lambda: simulate_chain(batched), repeat=repeat_batch)
    return {
        f"{prefix}_batched_speedup_vs_loop": t_loop / t_batch,
        f"{prefix}_loop_{realizations}_runs_s": t_loop,
        f"{prefix}_batched_{realizations}_realizations_s": t_batch,
    }


def run_benchmarks(bench_dir: Path, only: str | None = None) -> dict:
    """Run the benchmarks (optionally those whose name contains ``only``) and merge their figures."""
    figures: dict = {}
    selected = [(name, fn) for name, fn in discover(bench_dir) if not only or only in name]
    if not selected:
        raise NodesimError(f"no benchmark in {bench_dir} has a name containing {only!r} (names are file:function)")
    for name, fn in selected:
        result = fn()
        clash = set(result) & set(figures)
        if clash:
            raise NodesimError(f"benchmark {name} reuses figure keys {sorted(clash)}")
        figures.update(result)
    figures["host"] = host_info()
    return figures
