"""ISCWSA example wells (Rev 5.1 workbooks #1-#3) as surveys, error models and reference covariances.

The JSON layout is the one of the ISCWSA oracle extracts (header, survey, error_sources, validation).
Model-table codes map onto our weighting functions by :data:`CODE_WEIGHT`; the workbook magnitudes are
used as typed (``magnitude_converted``: deg -> rad), so nothing is tuned.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np

from nodesim.errors import NodesimError
from nodesim.ground.covariance import Site
from nodesim.ground.errormodel import ErrorModel, ErrorSource
from nodesim.ground.survey import Survey, make_survey

CODE_WEIGHT = {
    "DRFR": "DREF", "DSFS": "DSF", "DSTG": "DST",
    "ABXY-TI1S": "ABXY-TI1", "ABXY-TI2S": "ABXY-TI2", "ABZ": "ABZ",
    "ASXY-TI1S": "ASXY-TI1", "ASXY-TI2S": "ASXY-TI2", "ASXY-TI3S": "ASXY-TI3", "ASZ": "ASZ",
    "MBXY-TI1S": "MBXY-TI1", "MBXY-TI2S": "MBXY-TI2", "MBZ": "MBZ",
    "MSXY-TI1S": "MSXY-TI1", "MSXY-TI2S": "MSXY-TI2", "MSXY-TI3S": "MSXY-TI3", "MSZ": "MSZ",
    "DEC-U": "AZ", "DEC-OS": "AZ", "DEC-OH": "AZ", "DEC-OI": "AZ", "DECR": "AZ",
    "DBH-U": "DBH", "DBH-OS": "DBH", "DBH-OH": "DBH", "DBH-OI": "DBH", "DBHR": "DBH",
    "AMIL": "AMIL", "SAGE": "SAGE", "XYM1": "XYM1", "XYM2": "XYM2", "XYM3E": "XYM3E", "XYM4E": "XYM4E",
    "XCLA": "XCLA", "XCLH": "XCLH",
}  # fmt: skip

COV_KEYS = ("nn", "ee", "vv", "ne", "nv", "ev")
_IDX = {"nn": (0, 0), "ee": (1, 1), "vv": (2, 2), "ne": (0, 1), "nv": (0, 2), "ev": (1, 2)}


@dataclass(frozen=True, eq=False)
class IscwsaWell:
    name: str
    survey: Survey
    model: ErrorModel
    site: Site
    tvd_m: np.ndarray
    validation: list  # [{"md", "station_index", "sources": {code: {"diagnostic": {...}, "calculated": {...}}}}]
    mismatch: dict  # code -> MDs where the workbook's own values differ from the diagnostic data

    def reference(self, point: dict, code: str, variant: str = "diagnostic") -> np.ndarray:
        """The 3x3 reference covariance of one source at one validation point."""
        return cov6_to_matrix(point["sources"][code][variant])


def cov6_to_matrix(c: dict) -> np.ndarray:
    m = np.zeros((3, 3))
    for key, (i, j) in _IDX.items():
        m[i, j] = m[j, i] = c[key]
    return m


def load_iscwsa(path: Path) -> IscwsaWell:
    data = json.loads(Path(path).read_text())
    h = data["header"]
    unit = 1.0 if h["depth_unit"] == "m" else h["ft_to_m"]
    s = data["survey"]
    survey = make_survey(np.asarray(s["md"]) * unit, s["inc_deg"], s["azi_deg"], where=str(path))
    sources = []
    for e in data["error_sources"]:
        if e["code"] not in CODE_WEIGHT:
            raise NodesimError(f"{path}: error code '{e['code']}' has no weighting function")
        unit_name = "rad" if e["unit"] in ("deg", "deg.nT") else e["unit"]
        sources.append(
            ErrorSource(e["code"], CODE_WEIGHT[e["code"]], e["magnitude_converted"], unit_name, e["propagation"], e["description"])
        )
    consts = h.get("model_constants", {})
    tort = consts.get("xcl_tortuosity_rad_per_m") or consts.get("default_tortuosity_rad_per_m") or 0.000572614583987641
    site = Site(
        gravity_m_s2=h["G_mps2"],
        dip_deg=h["dip_deg"],
        b_total_nt=h["b_total_nT"],
        declination_deg=h["declination_deg"] + h.get("grid_convergence_deg", 0.0),
        tortuosity_rad_per_m=tort,
        min_course_m=10.0,
        vertical_limit_deg=h["vertical_inc_limit_deg"],
    )
    model = ErrorModel(h["model"], tuple(sources), h.get("well", ""), magnetic_azimuth=True, surface_tie_on=True)
    val = data["validation"]
    points = val["points"]
    return IscwsaWell(
        h.get("well", Path(path).stem), survey, model, site, np.asarray(s["tvd"]) * unit, points, val["diag_vs_calc_mismatch_mds"]
    )


def bundled_well(name: str) -> IscwsaWell:
    """One of the compact example wells shipped under ``nodesim/data/iscwsa`` (iscwsa1/2/3_rev5)."""
    ref = resources.files("nodesim") / "data" / "iscwsa" / f"{name}.json"
    with resources.as_file(ref) as p:
        if not p.exists():
            raise NodesimError(f"no bundled ISCWSA well '{name}'")
        return load_iscwsa(p)
