"""Scenarios: the TOML schema (validated, frozen sections) and the reference-update schedules.

Modules: :mod:`~nodesim.scenario.schema` (:class:`Scenario`, its sections, loading and dotted overrides),
:mod:`~nodesim.scenario.radio_sections` (``[radio]``, ``[mac]``, ``[faults]``),
:mod:`~nodesim.scenario.section_base` and :mod:`~nodesim.scenario.schedules`.
"""

from nodesim.scenario.schema import Scenario, load_scenario, parse_scenario

__all__ = ["Scenario", "load_scenario", "parse_scenario"]
