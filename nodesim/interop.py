"""Exchange with the tools drilling users already use: welleng, LAS 2.0 (lasio) and plain CSV, in m or ft.

``nodesim export RUN_DIR|SURVEY.csv --to welleng|las|csv [--units m|ft] [--tool T] -o FILE`` writes the
survey a run's ground station received (``ground_survey.csv`` of realization 0, or a survey CSV given
directly) with our minimum-curvature wellpath (N, E, TVD) and, per station, the ISCWSA position
uncertainty for tool model ``T``: the 1-sigma and 2-sigma semi-axes of the position ellipsoid
(``ellipsoid_axes``: square roots of the eigenvalues of the NEV covariance, largest first) and of the
horizontal ellipse (``horizontal_ellipse``).  Lengths are written in the chosen unit (1 ft = 0.3048 m
exactly, the international foot); angles in degrees.

- ``welleng``: CSV ``md,inc,azi`` (+ ``n,e,tvd``) in the unit named by the ``# depth_unit`` header line,
  what :func:`to_welleng` and ``welleng.survey.Survey(md, inc, azi, header=SurveyHeader(depth_unit=...))``
  take.  welleng computes the same positions from it (test: to 1e-6 m).
- ``las``: LAS 2.0 written with lasio, index ``DEPT`` (measured depth), curves INC, AZI, N, E, TVD and the
  semi-axes, units in the curve mnemonics' unit fields; ``lasio.read`` reads it back (test).
- ``csv``: the same columns as the LAS file, unit-suffixed names (``md_ft``, ``sigma1_major_ft``...).

welleng and lasio are optional (pyproject ``[test]`` extra); each is imported only when its format is asked for.
"""

from __future__ import annotations

import io
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from nodesim.errors import NodesimError

FT_M = 0.3048  # international foot, exactly
UNITS = {"m": 1.0, "ft": FT_M}
FORMATS = ("welleng", "las", "csv")
DEFAULT_TOOL = "mpu6500_filtered"
WELLENG_UNIT = {"m": "meters", "ft": "feet"}


@dataclass(frozen=True)
class ExportTable:
    """Per-station survey, wellpath and uncertainty, in metres and degrees (converted on writing)."""

    md_m: np.ndarray
    inc_deg: np.ndarray
    azi_deg: np.ndarray
    n_m: np.ndarray
    e_m: np.ndarray
    tvd_m: np.ndarray
    axes_1sigma_m: np.ndarray  # (K, 3) ellipsoid semi-axes, largest first
    horizontal_1sigma_m: np.ndarray  # (K, 2) horizontal ellipse semi-major, semi-minor
    tool: str
    source: str


def read_source(source: str | Path, seconds_per_station: float = 60.0):
    """The :class:`~nodesim.ground.survey.Survey` of a run directory (its ``ground_survey.csv``) or a survey CSV."""
    from nodesim.ground import read_survey_csv
    from nodesim.ground.survey import read_survey_file

    p = Path(source)
    if p.is_dir():
        gs = p / "ground_survey.csv"
        if not gs.is_file():
            raise NodesimError(f"{p}: no ground_survey.csv (only drilling runs have surveys to export)")
        return read_survey_csv(gs, seconds_per_station), str(gs)
    if not p.is_file():
        raise NodesimError(f"{p}: no such run directory or survey file")
    return read_survey_file(p, seconds_per_station), str(p)


def export_table(source: str | Path, tool: str = DEFAULT_TOOL, seconds_per_station: float = 60.0) -> ExportTable:
    """Wellpath (minimum curvature) and ISCWSA covariance of every station of ``source`` for ``tool``."""
    from nodesim.ground import load_tool, propagate
    from nodesim.ground.ellipsoid import ellipsoid_axes, horizontal_ellipse

    survey, where = read_source(source, seconds_per_station)
    u = propagate(survey, load_tool(tool))
    axes, _ = ellipsoid_axes(u.cov_nev_m2)
    major, minor, _ = horizontal_ellipse(u.cov_nev_m2)
    return ExportTable(
        md_m=np.asarray(survey.md_m, dtype=float), inc_deg=np.degrees(survey.inc_rad),
        azi_deg=np.degrees(survey.azi_rad), n_m=np.asarray(u.path.n_m), e_m=np.asarray(u.path.e_m),
        tvd_m=np.asarray(u.path.tvd_m), axes_1sigma_m=axes, horizontal_1sigma_m=np.stack([major, minor], axis=-1),
        tool=u.model.name, source=where,
    )


def _columns(t: ExportTable, units: str) -> dict[str, tuple[np.ndarray, str, str]]:
    """name -> (values in ``units`` or degrees, unit, description), in file order."""
    k = 1.0 / UNITS[units]
    cols = {
        "md": (t.md_m * k, units, "measured depth"),
        "inc": (t.inc_deg, "deg", "inclination"),
        "azi": (t.azi_deg, "deg", "azimuth (true north)"),
        "n": (t.n_m * k, units, "north displacement, minimum curvature"),
        "e": (t.e_m * k, units, "east displacement, minimum curvature"),
        "tvd": (t.tvd_m * k, units, "true vertical depth, minimum curvature"),
    }
    for s in (1, 2):
        for i, axis in enumerate(("major", "mid", "minor")):
            cols[f"sigma{s}_{axis}"] = (s * t.axes_1sigma_m[:, i] * k, units,
                                        f"{s}-sigma position ellipsoid semi-axis ({axis}), tool {t.tool}")
        for i, axis in enumerate(("major", "minor")):
            cols[f"sigma{s}_h{axis}"] = (s * t.horizontal_1sigma_m[:, i] * k, units,
                                         f"{s}-sigma horizontal ellipse semi-{axis} axis, tool {t.tool}")
    return cols


def write_export(source: str | Path, fmt: str, out: str | Path, units: str = "m", tool: str = DEFAULT_TOOL,
                 seconds_per_station: float = 60.0) -> Path:
    """Write ``source`` (run directory or survey CSV) as ``fmt`` ("welleng", "las", "csv") to ``out``."""
    from nodesim.io.rundir import atomic_write_bytes

    if fmt not in FORMATS:
        raise NodesimError(f"--to {fmt!r}: allowed {list(FORMATS)}")
    if units not in UNITS:
        raise NodesimError(f"--units {units!r}: allowed {list(UNITS)}")
    t = export_table(source, tool, seconds_per_station)
    cols = _columns(t, units)
    if fmt == "las":
        text = _las_text(t, cols, units)
    else:
        keep = ("md", "inc", "azi", "n", "e", "tvd") if fmt == "welleng" else tuple(cols)
        lines = [f"# nodesim export of {t.source}", f"# depth_unit = {WELLENG_UNIT[units]}",
                 f"# tool = {t.tool}; angles in degrees"]
        names = list(keep) if fmt == "welleng" else [f"{n}_{cols[n][1]}" for n in keep]
        lines.append(",".join(names))
        data = np.column_stack([cols[n][0] for n in keep])
        lines.extend(",".join(repr(float(v)) for v in row) for row in data)
        text = "\n".join(lines) + "\n"
    out = Path(out)
    atomic_write_bytes(out, text.encode())
    return out


def _las_text(t: ExportTable, cols: dict, units: str) -> str:
    try:
        import lasio
    except ImportError as err:
        raise NodesimError(f"--to las needs lasio: pip install lasio ({err})") from None
    las = lasio.LASFile()
    las.well["WELL"].value = Path(t.source).parent.name if Path(t.source).name == "ground_survey.csv" else Path(t.source).stem
    las.well["STRT"].value, las.well["STOP"].value = float(cols["md"][0][0]), float(cols["md"][0][-1])
    las.well["STRT"].unit = las.well["STOP"].unit = las.well["STEP"].unit = units.upper()
    las.well["STEP"].value = 0.0  # irregular station spacing
    las.other = f"nodesim export of {t.source}; ISCWSA tool model {t.tool}; 1 ft = 0.3048 m"
    for name, (values, unit, descr) in cols.items():
        mnemonic = "DEPT" if name == "md" else name.upper()
        las.append_curve(mnemonic, values, unit=unit.upper() if unit != "deg" else "DEG", descr=descr)
    buf = io.StringIO()
    las.write(buf, version=2.0, fmt="%.10g")
    return buf.getvalue()


def read_welleng_csv(path: str | Path) -> tuple[np.ndarray, np.ndarray, np.ndarray, str]:
    """(md, inc_deg, azi_deg, welleng depth unit) of a file written with ``--to welleng``."""
    p = Path(path)
    unit = "meters"
    lines = p.read_text().splitlines()
    for line in lines:
        if line.startswith("# depth_unit = "):
            unit = line.split("=", 1)[1].strip()
    data = np.loadtxt([ln for ln in lines if ln and not ln.startswith("#")][1:], delimiter=",", ndmin=2)
    return data[:, 0], data[:, 1], data[:, 2], unit


def to_welleng(source, tool: str | None = None, units: str = "m"):
    """A ``welleng.survey.Survey`` of a run (:class:`nodesim.api.Run` of a drilling scenario), a run
    directory or a survey CSV, with depths in ``units``; welleng must be installed."""
    try:
        from welleng.survey import Survey, SurveyHeader
    except ImportError as err:
        raise NodesimError(f"to_welleng needs welleng: pip install welleng ({err})") from None
    if units not in UNITS:
        raise NodesimError(f"units {units!r}: allowed {list(UNITS)}")
    if hasattr(source, "ground_survey"):
        g = source.ground_survey
        if g is None:
            raise NodesimError("this run has no surveys (only drilling runs do)")
        md, inc, azi = (np.asarray(g[c], dtype=float) for c in ("md_m", "inc_deg", "azi_deg"))
        name = source.scenario.name
    else:
        survey, where = read_source(source)
        md, inc, azi = np.asarray(survey.md_m), np.degrees(survey.inc_rad), np.degrees(survey.azi_rad)
        name = Path(where).stem
    header = SurveyHeader(name=name, depth_unit=WELLENG_UNIT[units], surface_unit=WELLENG_UNIT[units])
    return Survey(md=md / UNITS[units], inc=inc, azi=azi, header=header, unit=WELLENG_UNIT[units])


__all__ = ["ExportTable", "FORMATS", "FT_M", "export_table", "read_welleng_csv", "to_welleng", "write_export"]
