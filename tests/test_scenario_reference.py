"""docs/scenario-reference.md is the schema's reference as generated now, and the JSON Schema covers every key."""

from pathlib import Path

from nodesim.scenario.scenario_reference import json_schema, reference_markdown, unit_of
from nodesim.scenario.schema import Scenario

REPO = Path(__file__).resolve().parents[1]


def test_scenario_reference_is_up_to_date():
    committed = (REPO / "docs" / "scenario-reference.md").read_text()
    assert committed == reference_markdown(), (
        "docs/scenario-reference.md is out of date: nodesim scenario --reference > docs/scenario-reference.md")


def test_reference_lists_every_key_of_every_section():
    text = reference_markdown()
    for name, field in Scenario.model_fields.items():
        assert f"`{name}`" in text or f"`[{name}]`" in text, name
    for section in ("chain", "motion", "sensor", "simulation"):
        model = Scenario.model_fields[section].annotation
        for key in model.model_fields:
            assert f"| `{key}` |" in text, f"{section}.{key}"


def test_json_schema_names_the_sections_and_forbids_unknown_keys():
    schema = json_schema()
    assert {"chain", "motion", "simulation"} <= set(schema["properties"])
    assert schema.get("additionalProperties") is False or any(
        d.get("additionalProperties") is False for d in schema.get("$defs", {}).values())


def test_units_come_from_the_suffix():
    assert unit_of("duration_s") == "s" and unit_of("slow_rate_deg_s") == "deg/s"
    assert unit_of("gyro_arw_deg_per_sqrt_s") == "deg/sqrt(s)" and unit_of("nodes") == ""
