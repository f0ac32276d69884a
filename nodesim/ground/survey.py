"""Surveys: measured depth, inclination and azimuth per station, validated once at the edge.

A :class:`Survey` holds SI arrays (metres, radians, seconds).  :func:`make_survey` checks the input
(finite values, strictly increasing MD, inclination in [0, 180] deg, azimuth finite) and names the
offending row; :func:`read_survey_csv` reads the CSV form used by ``nodesim uncertainty`` (columns
``md_m,inc_deg,azi_deg`` and optionally ``time_s``, ``sigma_inc_deg``, ``sigma_azi_deg``).

The optional per-station 1-sigma angle errors are how a simulated filter (or the station fusion) feeds its
own inclination/azimuth uncertainty into the ISCWSA model: :func:`nodesim.ground.covariance.propagate`
adds them as random direct terms (codes ``SURVEY-INC`` and ``SURVEY-AZ``).
"""

from __future__ import annotations

import math

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from nodesim.io.csv_input import read_table
from nodesim.errors import NodesimError
from nodesim.units import DEG


@dataclass(frozen=True, eq=False)
class Survey:
    """Stations of one well, in station order.

    md_m: measured depth [m]; inc_rad, azi_rad: inclination and azimuth [rad] (azimuth from the
    reference north of the local frame, clockwise seen from above); time_s: time of each survey since
    the start of the run [s] (drives the time-based gyro terms, thesis eqs 2.4-2.7).
    """

    md_m: np.ndarray
    inc_rad: np.ndarray
    azi_rad: np.ndarray
    time_s: np.ndarray
    sigma_inc_rad: np.ndarray | None = None
    sigma_azi_rad: np.ndarray | None = None

    def __len__(self) -> int:
        return int(self.md_m.size)


def make_survey(
    md_m,
    inc_deg,
    azi_deg,
    time_s=None,
    seconds_per_station: float = 60.0,
    where: str = "survey",
    sigma_inc_deg=None,
    sigma_azi_deg=None,
) -> Survey:
    """Validate and convert a survey given in degrees.

    ``time_s`` defaults to ``seconds_per_station * k`` for station k (thesis 4.1.3: 60 s between stations).
    Errors name ``where`` and the 1-based station (readers of files check lines first and name them).
    """
    md = np.asarray(md_m, dtype=float).ravel()
    inc = np.asarray(inc_deg, dtype=float).ravel()
    azi = np.asarray(azi_deg, dtype=float).ravel()
    if not (md.size == inc.size == azi.size):
        raise NodesimError(f"{where}: md, inc and azi have different lengths ({md.size}, {inc.size}, {azi.size})")
    if md.size < 2:
        raise NodesimError(f"{where}: needs at least 2 stations, got {md.size}")
    if not np.isfinite(seconds_per_station) or seconds_per_station < 0:
        raise NodesimError(f"{where}: seconds per station must be finite and >= 0, got {seconds_per_station}")
    if time_s is None:
        t = seconds_per_station * np.arange(md.size, dtype=float)
    else:
        t = np.asarray(time_s, dtype=float).ravel()
        if t.size != md.size:
            raise NodesimError(f"{where}: time_s has {t.size} values for {md.size} stations")
    for name, arr in (("md_m", md), ("inc_deg", inc), ("azi_deg", azi), ("time_s", t)):
        bad = np.flatnonzero(~np.isfinite(arr))
        if bad.size:
            raise NodesimError(f"{where}: station {bad[0] + 1}: {name} is not a finite number ({arr[bad[0]]})")
    steps = np.diff(md)
    bad = np.flatnonzero(steps <= 0)
    if bad.size:
        k = bad[0] + 1
        kind = "duplicate" if steps[bad[0]] == 0 else "decreasing"
        raise NodesimError(
            f"{where}: station {k + 1}: md_m {md[k]:g} is {kind} (after {md[k - 1]:g}); MD must strictly increase"
        )
    bad = np.flatnonzero((inc < 0) | (inc > 180))
    if bad.size:
        raise NodesimError(f"{where}: station {bad[0] + 1}: inc_deg {inc[bad[0]]:g} is outside [0, 180]")
    bad = np.flatnonzero(np.diff(t) < 0)
    if bad.size:
        raise NodesimError(f"{where}: station {bad[0] + 2}: time_s decreases ({t[bad[0] + 1]:g} after {t[bad[0]]:g})")
    sigmas = []
    for name, arr in (("sigma_inc_deg", sigma_inc_deg), ("sigma_azi_deg", sigma_azi_deg)):
        if arr is None:
            sigmas.append(None)
            continue
        a = np.asarray(arr, dtype=float).ravel()
        if a.size != md.size:
            raise NodesimError(f"{where}: {name} has {a.size} values for {md.size} stations")
        bad = np.flatnonzero(~np.isfinite(a) | (a < 0))
        if bad.size:
            raise NodesimError(f"{where}: station {bad[0] + 1}: {name} {a[bad[0]]:g} must be finite and >= 0")
        sigmas.append(a * DEG)
    return Survey(md, inc * DEG, np.remainder(azi, 360.0) * DEG, t, sigmas[0], sigmas[1])


REQUIRED_COLUMNS = ("md_m", "inc_deg", "azi_deg")
OPTIONAL_COLUMNS = ("time_s", "sigma_inc_deg", "sigma_azi_deg")


FT_M = 0.3048  # international foot, exactly
DEPTH_COLUMNS = {"md_m": 1.0, "md_ft": FT_M}


def read_survey_las(path: Path, seconds_per_station: float = 60.0, units: str | None = None) -> Survey:
    """Read a survey from a LAS file (lasio): the index is measured depth, curves ``INC`` and ``AZI`` in
    degrees (as ``nodesim export --to las`` writes).  The depth unit is the index curve's (M or FT/F), or
    ``units`` ("m"/"ft") when the file gives none; a file that states one unit while ``units`` says another
    is an error."""
    try:
        import lasio
    except ImportError as err:
        raise NodesimError(f"{path}: reading LAS needs lasio: pip install lasio ({err})") from None
    try:
        las = lasio.read(str(path))
    except Exception as err:  # lasio raises many types on a malformed file
        raise NodesimError(f"{path}: not a readable LAS file ({type(err).__name__}: {err})") from None
    mnemonics = [c.mnemonic.upper() for c in las.curves]
    missing = [c for c in ("INC", "AZI") if c not in mnemonics]
    if missing:
        raise NodesimError(f"{path}: LAS file has no {', '.join(missing)} curve (curves: {mnemonics})")
    unit = (las.curves[0].unit or "").strip().upper()
    file_units = {"M": "m", "FT": "ft", "F": "ft"}.get(unit)
    if unit and file_units is None:
        raise NodesimError(f"{path}: depth unit {unit!r} of the index curve: allowed M, FT")
    if file_units and units and file_units != units:
        raise NodesimError(f"{path}: the file's depth unit is {unit} but --units {units} was given")
    scale = DEPTH_COLUMNS["md_ft" if (file_units or units or "m") == "ft" else "md_m"]
    curve = {c.mnemonic.upper(): np.asarray(c.data, dtype=float) for c in las.curves}
    return make_survey(np.asarray(las.index, dtype=float) * scale, curve["INC"], curve["AZI"], None,
                       seconds_per_station, where=str(path))


def read_survey_file(path: Path, seconds_per_station: float = 60.0, units: str | None = None) -> Survey:
    """A survey CSV (:func:`read_survey_csv`) or, for a ``.las`` file, LAS (:func:`read_survey_las`).
    ``units="ft"`` for a CSV whose depth column is ``md_m`` is an error (name the column ``md_ft``)."""
    path = Path(path)
    if path.suffix.lower() == ".las":
        return read_survey_las(path, seconds_per_station, units)
    if units == "ft":
        head, _, _ = read_table(path, (), "survey")
        if "md_ft" not in head:
            raise NodesimError(f"{path}: --units ft needs the depth column named md_ft (the header has {head[:3]})")
    return read_survey_csv(path, seconds_per_station)


def read_survey_csv(path: Path, seconds_per_station: float = 60.0) -> Survey:
    """Read a survey CSV (header ``md_m,inc_deg,azi_deg`` -- or ``md_ft`` for depths in feet, converted with
    1 ft = 0.3048 m -- plus optional ``time_s``, ``sigma_inc_deg``, ``sigma_azi_deg``; any other column is
    rejected); errors name the file, its line (as an editor numbers it) and the column.  Angles must lie in
    inc [0, 180] and azi [0, 360] degrees."""
    path = Path(path)
    head, _, _ = read_table(path, (), "survey")
    depth = "md_ft" if "md_ft" in head and "md_m" not in head else "md_m"
    required = (depth,) + REQUIRED_COLUMNS[1:]
    header, data, lines = read_table(path, required, "survey", OPTIONAL_COLUMNS)
    cols = {name: [] for name in header}
    for line, row in zip(lines, data):
        if len(row) != len(header):
            raise NodesimError(f"{path}, line {line}: {len(row)} fields, header has {len(header)}")
        for name, value in zip(header, row):
            try:
                cols[name].append(float(value))
            except ValueError:
                raise NodesimError(f"{path}, line {line}: column {name}: '{value.strip()}' is not a number") from None
    for name in header:
        for line, v in zip(lines, cols[name]):
            if not math.isfinite(v):
                raise NodesimError(f"{path}, line {line}: {name} is not a finite number ({v})")
    for name, lo, hi in (("inc_deg", 0.0, 180.0), ("azi_deg", 0.0, 360.0)):
        for line, v in zip(lines, cols[name]):
            if not lo <= v <= hi:
                raise NodesimError(f"{path}, line {line}: {name} {v:g} is outside [{lo:g}, {hi:g}]")
    if depth != "md_m":
        cols["md_m"] = [v * DEPTH_COLUMNS[depth] for v in cols.pop(depth)]
    if len(data) >= 2:
        md = cols["md_m"]
        for k in range(1, len(md)):
            if not md[k] > md[k - 1]:
                kind = "duplicate" if md[k] == md[k - 1] else "decreasing"
                raise NodesimError(f"{path}, line {lines[k]}: {depth} {md[k] / DEPTH_COLUMNS[depth]:g} is {kind} "
                                   f"(after {md[k - 1] / DEPTH_COLUMNS[depth]:g}); "
                                   "MD must strictly increase")
    return make_survey(
        cols["md_m"],
        cols["inc_deg"],
        cols["azi_deg"],
        cols.get("time_s"),
        seconds_per_station,
        where=str(path),
        sigma_inc_deg=cols.get("sigma_inc_deg"),
        sigma_azi_deg=cols.get("sigma_azi_deg"),
    )
