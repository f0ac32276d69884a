"""Test trajectories of the MSA theses (HV surveys 1-7, SV tests 1-4), as (MD m, toolface, inc, azi deg).

Transcribed from the OCR'd tables (digest section 12); reconstructed rows are flagged there (HV S5 toolface
at 3100/3200 follows the 25/115/205/295 cycle; HV S7 rows 1200 and 3000 follow the printed pattern).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nodesim.errors import NodesimError

CYCLE = (25.0, 115.0, 205.0, 295.0)


@dataclass(frozen=True, eq=False)
class Trajectory:
    name: str
    md_m: np.ndarray
    toolface_deg: np.ndarray
    inc_deg: np.ndarray
    azi_deg: np.ndarray

    def __len__(self) -> int:
        return int(self.md_m.size)


def _cycle(n: int, first: int = 0) -> np.ndarray:
    return np.array([CYCLE[(first + k) % 4] for k in range(n)])


def _make(name, md, inc, azi, tf=None) -> Trajectory:
    md = np.asarray(md, dtype=float)
    n = md.size
    inc = np.broadcast_to(np.asarray(inc, dtype=float), (n,)).copy()
    azi = np.broadcast_to(np.asarray(azi, dtype=float), (n,)).copy()
    tf = _cycle(n) if tf is None else np.asarray(tf, dtype=float)
    return Trajectory(name, md, tf, inc, azi)


def _rows(rows):
    md, inc, azi = zip(*rows)
    return list(md), list(inc), list(azi)


def hv_survey_1(azi=85.0, name="HV S1"):
    md = [0.0] + list(range(1000, 3001, 100))
    inc = [0.0, 0.0] + [3.0 * k for k in range(1, 21)]
    return _make(name, md, inc, azi)


def hv_survey_3():
    md = list(range(900, 3001, 100))
    return _make("HV S3", md, [77.5 + 0.5 * k for k in range(len(md))], 85.0)


def hv_survey_4():
    md = list(range(0, 8001, 100))
    build = [6.67, 13.33, 20.0, 26.67, 33.33, 40.0, 46.67, 53.33, 60.0]
    inc = []
    for m in md:
        if m <= 1200:
            inc.append(0.0)
        elif m <= 2100:
            inc.append(build[(m - 1300) // 100])
        elif m <= 5100:
            inc.append(60.0)
        else:
            inc.append({5200: 70.0, 5300: 80.0}.get(m, 90.0))
    azi = [0.0 if m <= 1100 else 75.0 for m in md]
    return _make("HV S4", md, inc, azi)


def hv_survey_5():
    rows = [(float(m), 0.0, 0.0) for m in range(0, 601, 100)] + [(609.6, 0.0, 0.0)]
    rows += [(700, 5.93, 2), (800, 12.49, 2), (900, 19.06, 2), (1000, 25.62, 2), (1097.28, 32, 2)]
    rows += [(m, 32, 2) for m in (1100, 1200, 1300, 1400, 1500, 1524)]
    rows += [(1600, 31.12, 16.22), (1684.18, 32, 32), (1700, 31.69, 34.89), (1800, 31.29, 53.78),
             (1844.37, 32, 62), (1900, 31.20, 72.35), (2000, 31.90, 91.17), (2004.55, 32, 92),
             (2100, 31.15, 109.92), (2164.74, 32, 122), (2200, 30.78, 128.24), (2300, 29.16, 147.75),
             (2400, 30.49, 167.44), (2500, 34.43, 184.32), (2600, 40.21, 197.50), (2700, 47.16, 207.64),
             (2800, 54.81, 215.62), (2864.66, 60, 220)]  # fmt: skip
    rows += [(float(m), 60, 220) for m in range(2900, 3801, 100)] + [(3810, 60, 220)]
    return _make("HV S5", *_rows(rows))


def hv_survey_6():
    rows = [(float(m), 0.0, 0.0) for m in range(0, 501, 100)]
    rows += [(600, 8.33, 0), (700, 16.67, 0), (800, 25, 0), (900, 33.33, 0), (1000, 41.67, 0)]
    rows += [(float(m), 50, 0) for m in range(1100, 1701, 100)]
    rows += [(1800, 43.33, 0), (1900, 36.67, 0), (2000, 30, 0), (2100, 23.33, 0), (2200, 16.67, 0),
             (2300, 10, 0), (2400, 3.33, 0)]  # fmt: skip
    rows += [(m, 0, 0) for m in (2450, 2500, 2600, 2700, 2800, 2850)]
    rows += [(2900, 25, 283), (3000, 75, 283)] + [(m, 90, 283) for m in (3030, 3100, 3200, 3300, 3400, 3430)]
    rows += [(3500, 97.04, 263.16), (3600, 105.41, 233.75), (3700, 109.74, 202.57)]
    rows += [(m, 110, 193) for m in (3730, 3800, 3900, 4000, 4030)]
    return _make("HV S6", *_rows(rows))


def hv_survey_7():
    md = [float(m) for m in range(0, 2401, 100)] + [2450, 2500, 2600, 2700, 2800, 2850, 2900, 3000]
    tfi = [25.0 + m / 100.0 for m in range(0, 2401, 100)]
    tf = tfi + [50, 51, 52, 53, 50, 51, 52, 53]
    inc = tfi + [50, 51, 52, 53, 54, 55, 56, 57]
    return _make("HV S7", md, inc, 45.0, tf)


def sv_test_2():
    md = [0.0, 1000.0, 1500.0] + [1500.0 + 50.0 * k for k in range(1, 31)]
    inc = [0.0, 0.0, 0.0] + [2.0 * k for k in range(1, 31)]
    tf = [25.0, 25.0, 115.0] + list(_cycle(30, first=2))
    return _make("SV T2", md, inc, 85.0, tf)


def sv_test_3():
    s = hv_survey_1()
    return Trajectory("SV T3", s.md_m, s.toolface_deg, s.inc_deg, 2.0 + 3.0 * np.arange(len(s)))


SURVEYS = {
    "hv1": hv_survey_1,
    "hv2": lambda: hv_survey_1(5.0, "HV S2"),
    "hv3": hv_survey_3,
    "hv4": hv_survey_4,
    "hv5": hv_survey_5,
    "hv6": hv_survey_6,
    "hv7": hv_survey_7,
    "sv2": sv_test_2,
    "sv3": sv_test_3,
}


def trajectory(name: str) -> Trajectory:
    try:
        return SURVEYS[name]()
    except KeyError:
        raise NodesimError(f"unknown MSA test survey '{name}'; allowed: {', '.join(SURVEYS)}") from None
