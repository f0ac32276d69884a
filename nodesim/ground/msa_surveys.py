"""Test trajectories of the MSA theses (HV surveys 1-7, SV tests 1-4), as (MD m, toolface, inc, azi deg).

Transcribed from the OCR'd tables (digest section 12); reconstructed rows are flagged there (HV S5 toolface
at 3100/3200 follows the 25/115/205/295 cycle; HV S7 rows 1200 and 3000 follow the printed pattern).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from importlib import resources

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


SV_TEST_4 = (
    (1602.25, 57.47, 37.09, 26.65), (1641.19, 157.34, 38.52, 26.89), (1683.90, 334.17, 40.23, 28.09),
    (1725.06, 278.49, 42.49, 28.32), (1766.64, 53.12, 44.77, 27.58), (1807.38, 87.39, 47.28, 27.40),
    (1848.90, 201.18, 49.3, 27.58), (1891.08, 289.05, 51.52, 28.13), (1932.16, 55.01, 53.88, 27.41),
    (1972.99, 288.32, 55.3, 27.56), (2014.02, 122.17, 55.52, 26.99), (2055.03, 242.83, 55.47, 27.10),
    (2095.73, 135.84, 55.11, 26.54), (2137.24, 84.44, 55.38, 26.26), (2177.30, 245.98, 55.58, 26.22),
    (2219.06, 141.63, 55.55, 24.97), (2259.79, 177.01, 55.33, 25.66), (2301.06, 67.73, 55.37, 26.31),
    (2342.25, 310.48, 55.93, 27.58), (2383.66, 58.27, 56.1, 27.10), (2423.75, 317.02, 56.17, 27.91),
    (2468.07, 268.62, 55.87, 28.34), (2508.95, 280.56, 55.88, 29.03), (2550.01, 187.08, 56.02, 29.82),
    (2591.14, 293.47, 55.78, 29.42), (2631.93, 196.99, 55.22, 30.14), (2673.35, 134.46, 55.2, 29.53),
    (2714.18, 31.71, 55.17, 27.12), (2755.74, 141.39, 54.2, 27.96), (2797.20, 83.97, 52.87, 27.74),
    (2837.85, 282.26, 50.41, 27.64), (2879.04, 209.04, 48.11, 28.17), (2920.34, 40.39, 46.37, 26.20),
    (2961.35, 154.3, 43.94, 27.35), (3000.38, 161.35, 42.85, 27.88), (3033.51, 87.36, 40.5, 28.51),
    (3075.63, 211.01, 37.22, 28.80), (3113.23, 175.54, 34.82, 29.16), (3156.61, 133.09, 32.44, 29.49),
    (3197.55, 134.01, 30.63, 30.45), (3237.99, 21.85, 28.85, 31.20), (3280.17, 29.48, 27.38, 31.60),
    (3321.07, 200.05, 25.97, 28.84), (3362.05, 74.79, 23.51, 26.80), (3403.11, 243.22, 20.75, 28.92),
    (3444.14, 170.14, 19.05, 29.12), (3485.36, 259.13, 17.4, 27.04), (3526.42, 49.5, 15.63, 24.82),
    (3567.26, 317.62, 13.87, 22.57), (3608.15, 274.28, 11.19, 25.91), (3648.77, 274.96, 9.97, 24.67),
    (3690.49, 352.47, 8.77, 18.74), (3703.58, 15.08, 7.72, 17.65),
)  # fmt: skip
"""SV Test 4 (real data, 53 stations): MD m, toolface, inclination, azimuth deg (SV appendix)."""


def sv_test_1():
    md = [0.0, 20.0, 40.0] + [100.0 * k for k in range(1, 31)]
    tf = [25, 115, 205, 295, 25, 115, 205, 295, 25, 25, 115, 25, 115] + list(_cycle(20, first=2))
    inc = [75.5 + 0.5 * k for k in range(9)] + [77.5, 78.0, 77.5, 78.0] + [78.0 + 0.5 * k for k in range(1, 21)]
    return _make("SV T1", md, inc, 75.0, tf)


def sv_test_4():
    md, tf, inc, azi = (np.array(c) for c in zip(*SV_TEST_4))
    return Trajectory("SV T4", md, tf, inc, azi)


SURVEYS = {
    "hv1": hv_survey_1,
    "hv2": lambda: hv_survey_1(5.0, "HV S2"),
    "hv3": hv_survey_3,
    "hv4": hv_survey_4,
    "hv5": hv_survey_5,
    "hv6": hv_survey_6,
    "hv7": hv_survey_7,
    "sv1": sv_test_1,
    "sv2": sv_test_2,
    "sv3": sv_test_3,
    "sv4": sv_test_4,
}


def trajectory(name: str) -> Trajectory:
    try:
        return SURVEYS[name]()
    except KeyError:
        raise NodesimError(f"unknown MSA test survey '{name}'; allowed: {', '.join(SURVEYS)}") from None


def published_numbers() -> dict:
    """Published HV/SV figures shipped under ``nodesim/data/magnetic/published.json`` (copied numbers)."""
    ref = resources.files("nodesim") / "data" / "magnetic" / "published.json"
    return json.loads(ref.read_text())


def hv_spreadsheet2() -> Trajectory:
    """HV Spreadsheet 2 (Fig 8-1): MD 0, 1000..3000; T cycle; I = 5 + 2k; A = 45 + 2k (digest 13.1)."""
    md = [0.0] + [float(m) for m in range(1000, 3001, 100)]
    k = np.arange(len(md))
    return _make("HV spreadsheet 2", md, 5.0 + 2.0 * k, 45.0 + 2.0 * k)


def hv_mcm_sheet() -> Trajectory:
    """HV MCM sheet (Fig 8-3): MD 0..6700; I 0 to 500 m, 3..15 at 600..1000, then 15; A = 5; T 50/140/230/320."""
    md = np.arange(0.0, 6701.0, 100.0)
    inc = np.clip((md - 500.0) / 100.0 * 3.0, 0.0, 15.0)
    tf = np.array([(50.0, 140.0, 230.0, 320.0)[k % 4] for k in range(md.size)])
    return Trajectory("HV MCM sheet", md, tf, inc, np.full(md.size, 5.0))
