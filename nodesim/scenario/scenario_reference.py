"""The scenario reference, generated from the pydantic schema: ``docs/scenario-reference.md`` and JSON Schema.

Every key of :class:`nodesim.scenario.schema.Scenario`, section by section, with its type, default, allowed
range (the ``ge``/``gt``/``le``/``lt`` bounds of its ``Field``), unit and meaning (the ``Field``
description).  The unit comes from the key's suffix, the project's naming rule (``_s`` seconds, ``_hz``,
``_deg``, ``_m``, ``_deg_s``, ``_ppm``...); keys without a unit suffix are dimensionless or counts.
``nodesim scenario --reference`` prints the Markdown (tests/test_scenario_reference.py fails when the
committed file differs); ``nodesim scenario --schema`` prints the JSON Schema for editors.
"""

from __future__ import annotations

import json
import typing

from pydantic import BaseModel
from pydantic_core import PydanticUndefined

# longest suffix first: "_deg_s" before "_s"
UNIT_SUFFIXES = (
    ("_deg_per_sqrt_s", "deg/sqrt(s)"), ("_ug_per_sqrt_hz", "ug/sqrt(Hz)"), ("_m_s2", "m/s^2"),
    ("_deg_s", "deg/s"), ("_m_s", "m/s"), ("_rad2", "rad^2"), ("_dbm", "dBm"), ("_db", "dB"), ("_dbi", "dBi"),
    ("_ppm", "ppm"), ("_hz", "Hz"), ("_khz", "kHz"), ("_mhz", "MHz"), ("_ghz", "GHz"), ("_deg", "deg"),
    ("_rad", "rad"), ("_ms", "ms"), ("_us", "us"), ("_s", "s"), ("_mm", "mm"), ("_cm", "cm"), ("_km", "km"),
    ("_m", "m"), ("_nt", "nT"), ("_bits", "bit"), ("_bytes", "byte"), ("_w", "W"), ("_mw", "mW"), ("_c", "degC"),
    ("_probability", "probability"), ("_fraction", "fraction"), ("_pct", "%"),
)


def unit_of(key: str) -> str:
    for suffix, unit in sorted(UNIT_SUFFIXES, key=lambda su: -len(su[0])):
        if key.endswith(suffix):
            return unit
    return ""


def _type_name(annotation) -> str:
    origin = typing.get_origin(annotation)
    if origin is typing.Literal:
        return " \\| ".join(json.dumps(a) for a in typing.get_args(annotation))
    if origin in (typing.Union, getattr(__import__("types"), "UnionType", None)):
        return " \\| ".join(_type_name(a) for a in typing.get_args(annotation))
    if origin in (list, tuple, dict):
        return f"{origin.__name__}[{', '.join(_type_name(a) for a in typing.get_args(annotation))}]"
    if annotation is type(None):
        return "none"
    return getattr(annotation, "__name__", str(annotation))


def _num(v) -> str:
    return str(v) if isinstance(v, int) else f"{v:.10g}"


def _range(field) -> str:
    lo = hi = ""
    for m in field.metadata:
        for attr, sym in (("ge", "["), ("gt", "(")):
            if getattr(m, attr, None) is not None:
                lo = f"{sym}{_num(getattr(m, attr))}"
        for attr, sym in (("le", "]"), ("lt", ")")):
            if getattr(m, attr, None) is not None:
                hi = f"{_num(getattr(m, attr))}{sym}"
    if not lo and not hi:
        return ""
    return f"{lo or '(-inf'}, {hi or 'inf)'}"


def _default(field) -> str:
    if field.default is PydanticUndefined and field.default_factory is None:
        return "required"
    value = field.default_factory() if field.default_factory is not None else field.default
    if isinstance(value, BaseModel):
        return "(section)"
    return f"`{json.dumps(value, default=str)}`"


def _model_of(annotation):
    """The section model behind a field (a model, or a list of models), else None."""
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return annotation, False
    if typing.get_origin(annotation) is list:
        (arg,) = typing.get_args(annotation) or (None,)
        if isinstance(arg, type) and issubclass(arg, BaseModel):
            return arg, True
    return None, False


def _rows(model: type[BaseModel], prefix: str, out: list[tuple[str, list]]) -> None:
    rows = []
    subsections = []
    for name, field in model.model_fields.items():
        sub, is_list = _model_of(field.annotation)
        if sub is not None:
            subsections.append((f"{prefix}{name}" + ("[]" if is_list else ""), sub, field))
            continue
        desc = (field.description or "").replace("|", "\\|").replace("\n", " ")
        rows.append((name, _type_name(field.annotation), _default(field), _range(field), unit_of(name), desc))
    out.append((prefix.rstrip(".") or "(top level)", rows, model))
    for key, sub, _ in subsections:
        _rows(sub, key + ".", out)


def reference_markdown() -> str:
    """The Markdown of docs/scenario-reference.md."""
    from nodesim.scenario.schema import Scenario

    sections: list = []
    _rows(Scenario, "", sections)
    lines = [
        "# Scenario reference",
        "",
        "Generated from the pydantic schema (`nodesim scenario --reference > docs/scenario-reference.md`; "
        "tests/test_scenario_reference.py fails when this file is out of date). Every key of a scenario TOML, "
        "section by section: type, default, allowed range (`[` `]` inclusive, `(` `)` exclusive), unit (from the "
        "key's suffix) and meaning. Unknown keys are rejected. `nodesim scenario --schema` prints the JSON Schema "
        "for editors; `nodesim run SCENARIO --dry-run` prints a scenario with every default filled in.",
        "",
    ]
    for key, rows, model in sections:
        if not rows:
            continue
        title = "Top-level keys" if key == "(top level)" else f"`[{key}]`"
        lines += [f"## {title}", ""]
        doc = " ".join((model.__doc__ or "").strip().split("\n\n")[0].split())
        if doc and model.__doc__ is not BaseModel.__doc__:
            lines += [doc, ""]
        lines += ["| key | type | default | range | unit | meaning |", "| --- | --- | --- | --- | --- | --- |"]
        lines += [f"| `{r[0]}` | {r[1]} | {r[2]} | {r[3]} | {r[4]} | {r[5]} |" for r in rows]
        lines.append("")
    return "\n".join(lines)


def json_schema() -> dict:
    """JSON Schema of a scenario (pydantic's, validation mode)."""
    from nodesim.scenario.schema import Scenario

    return Scenario.model_json_schema()


__all__ = ["json_schema", "reference_markdown", "unit_of"]
