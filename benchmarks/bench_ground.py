"""Ground station: ISCWSA covariance cost for long wells (running sums, linear in the stations).

Figures:
* ``iscwsa_10k_stations_s``: covariance of a 10,000-station well with 20 error sources (goal < 0.1 s);
* ``iscwsa_10k_over_1k``: time for 10,000 stations / time for 1,000 (goal < 12: linear cost);
* ``iscwsa_speedup_vs_pairwise_300``: the explicit station-pair O(n^2) sums / ours, 300 stations.
"""

import numpy as np

from nodesim.bench import best_time_s
from nodesim.ground.covariance import propagate
from nodesim.ground.errormodel import ErrorModel
from nodesim.ground.reference import propagate_pairwise
from nodesim.ground.survey import make_survey
from nodesim.ground.tools import load_tool

SOURCES_20 = (
    "ABXY-TI1S", "ABXY-TI2S", "ABZ", "ASXY-TI1S", "ASXY-TI2S", "ASXY-TI3S", "ASZ", "XYM1", "XYM2", "XYM3", "XYM4",
    "GYRO-DRIFT", "GYRO-ARW",
)  # fmt: skip


def _model() -> ErrorModel:
    """20 sources: the VN-100T set (13) plus depth, sag, XYM3E/4E, XCL and a random azimuth term."""
    from nodesim.ground.errormodel import ErrorSource

    base = load_tool("vn100t")
    extra = (
        ErrorSource("DRFR", "DREF", 0.35, "m", "R"),
        ErrorSource("DSFS", "DSF", 5.6e-4, "-", "S"),
        ErrorSource("DSTG", "DST", 2.5e-7, "1/m", "G"),
        ErrorSource("SAGE", "SAGE", 0.2, "deg", "S"),
        ErrorSource("XYM3E", "XYM3E", 0.3, "deg", "R"),
        ErrorSource("XCLA", "XCLA", 0.167, "-", "R"),
        ErrorSource("AZR", "AZ", 0.1, "deg", "R"),
    )
    model = ErrorModel("bench20", tuple(base.source(c) for c in SOURCES_20) + extra)
    assert len(model.sources) == 20
    return model


def _well(n: int):
    """A build-and-turn well of n stations, 1 m apart."""
    md = np.arange(n, dtype=float)
    inc = np.clip(md / n * 90.0, 0.0, 89.0)
    azi = (md / n * 120.0) % 360.0
    return make_survey(md, inc, azi, seconds_per_station=10.0)


def iscwsa_linear_cost() -> dict:
    model = _model()
    w1k, w10k = _well(1_000), _well(10_000)
    t1k = best_time_s(lambda: propagate(w1k, model), repeat=5)
    t10k = best_time_s(lambda: propagate(w10k, model), repeat=5)
    w300 = _well(300)
    t300 = best_time_s(lambda: propagate(w300, model), repeat=5)
    t_pair = best_time_s(lambda: propagate_pairwise(w300, model), repeat=1)
    return {
        "iscwsa_10k_stations_s": t10k,
        "iscwsa_1k_stations_s": t1k,
        "iscwsa_10k_over_1k": t10k / t1k,
        "iscwsa_pairwise_300_stations_s": t_pair,
        "iscwsa_speedup_vs_pairwise_300": t_pair / t300,
    }


BENCHMARKS = [iscwsa_linear_cost]
