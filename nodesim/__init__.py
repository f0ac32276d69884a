"""nodesim: simulator of a drill-string sensor chain.

The Python API (see README.md, "Python API"):

    import nodesim
    run = nodesim.simulate("scenarios/lab/continuous.toml", seed=7, **{"chain.nodes": 2})
    run.summary, run.timeseries, run.plot_yaw(), run.save("runs/demo")
    nodesim.load_run("runs/demo")
    study = nodesim.optimize("scenarios/optimize/lab_0p3deg.toml", out="runs/opt")  # trials, pareto DataFrames

``simulate``, ``load_run``, ``Run`` (:mod:`nodesim.api`) and ``Scenario`` (:mod:`nodesim.scenario.schema`)
are imported on first use, so ``import nodesim`` stays light (the command line's ``--help`` pays nothing for
numba, pandas or matplotlib).
"""

from nodesim.errors import NodesimError
from nodesim.io.rundir import package_version as _package_version

__version__ = _package_version()

__all__ = ["NodesimError", "Run", "Scenario", "__version__", "load_run", "optimize", "simulate"]


def __getattr__(name: str):
    if name == "optimize":
        from nodesim.optimization.driver import optimize

        return optimize
    if name in ("simulate", "load_run", "Run"):
        from nodesim import api

        return getattr(api, name)
    if name == "Scenario":
        from nodesim.scenario.schema import Scenario

        return Scenario
    raise AttributeError(f"module 'nodesim' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(__all__))
