"""Survey-tool error models as data: ``nodesim/data/tools/<name>.toml``.

A tool file holds a name, a description, the source of its numbers, whether its azimuth is magnetic,
and a list of ``[[sources]]`` (code, weight, magnitude, unit, propagation, note).  The bundled tools
are the thesis sensors mapped to ISCWSA error magnitudes as in thesis 4.1.3 (tables 4.4, 4.7, 4.10,
4.13, 4.16) plus ``mpu6500_filtered`` (thesis 4.2.4: the gyro terms replaced by a 0.25 deg azimuth
term, modelled as random per station, digest section 6 / section 9 #19).
"""

from __future__ import annotations

import tomllib
from importlib import resources
from pathlib import Path

from nodesim.errors import NodesimError
from nodesim.ground.errormodel import ErrorModel, ErrorSource

_TOOL_KEYS = {"name", "description", "source", "magnetic_azimuth", "surface_tie_on", "sources"}
_SOURCE_KEYS = {"code", "weight", "magnitude", "unit", "propagation", "note"}


def _tool_dir():
    return resources.files("nodesim") / "data" / "tools"


def tool_names() -> list[str]:
    """Names of the bundled tools, sorted."""
    return sorted(p.name[: -len(".toml")] for p in _tool_dir().iterdir() if p.name.endswith(".toml"))


def load_tool(name_or_path: str | Path) -> ErrorModel:
    """A bundled tool by name, or a tool TOML file by path.  Errors name the file and key."""
    path = Path(name_or_path)
    if path.suffix == ".toml" and path.exists():
        return parse_tool(path.read_text(encoding="utf-8"), str(path))
    names = tool_names()
    if str(name_or_path) not in names:
        raise NodesimError(f"unknown tool '{name_or_path}'; allowed: {', '.join(names)} (or a path to a tool .toml)")
    ref = _tool_dir() / f"{name_or_path}.toml"
    return parse_tool(ref.read_text(encoding="utf-8"), f"tool {name_or_path}")


def parse_tool(text: str, where: str) -> ErrorModel:
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise NodesimError(f"{where}: not valid TOML ({err})") from err
    unknown = sorted(set(data) - _TOOL_KEYS)
    if unknown:
        raise NodesimError(f"{where}: unknown key(s) {unknown}; allowed: {sorted(_TOOL_KEYS)}")
    if "name" not in data or not isinstance(data.get("sources"), list):
        raise NodesimError(f"{where}: needs 'name' and a list of [[sources]]")
    sources = []
    for i, s in enumerate(data["sources"]):
        key = f"{where}: sources[{i}]"
        bad = sorted(set(s) - _SOURCE_KEYS)
        if bad:
            raise NodesimError(f"{key}: unknown key(s) {bad}; allowed: {sorted(_SOURCE_KEYS)}")
        missing = sorted({"code", "weight", "magnitude", "unit", "propagation"} - set(s))
        if missing:
            raise NodesimError(f"{key}: missing key(s) {missing}")
        if not isinstance(s["magnitude"], (int, float)) or isinstance(s["magnitude"], bool):
            raise NodesimError(f"{key}.magnitude: must be a number, got {s['magnitude']!r}")
        try:
            sources.append(
                ErrorSource(s["code"], s["weight"], float(s["magnitude"]), s["unit"], s["propagation"], s.get("note", ""))
            )
        except NodesimError as err:
            raise NodesimError(f"{key}: {err}") from None
    return ErrorModel(
        data["name"],
        tuple(sources),
        data.get("description", ""),
        magnetic_azimuth=bool(data.get("magnetic_azimuth", False)),
        surface_tie_on=bool(data.get("surface_tie_on", False)),
    )
