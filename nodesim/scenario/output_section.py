"""The ``[output]`` section: which per-tick records a run directory keeps and in what format."""

from __future__ import annotations

import re
from typing import Literal

from pydantic import Field, field_validator

from nodesim.scenario.section_base import _Section

TIMESERIES_CHOICES = ("all", "bottom", "every:N", "decimate:K", "none")
_TIMESERIES = re.compile(r"^(all|bottom|none|every:[1-9][0-9]*|decimate:[1-9][0-9]*)$")


class OutputSection(_Section):
    """What ``timeseries`` (realization 0, one row per node and tick) keeps, and its file format; the surveys,
    hops, realizations tables and the summary are always written (CSV and JSON)."""

    format: Literal["parquet", "csv"] = Field(
        "parquet", description="timeseries file: 'parquet' (timeseries.parquet, zstd; pandas.read_parquet) or "
        "'csv' (timeseries.csv; nodesim run --csv)")
    timeseries: str = Field(
        "all", description="rows of the timeseries table: 'all', 'bottom' (the last node), 'every:N' (every Nth "
        "node from node 1, and the bottom node), 'decimate:K' (every Kth tick of every node), 'none'")

    @field_validator("timeseries")
    @classmethod
    def _choice(cls, value: str) -> str:
        if not _TIMESERIES.match(value):
            raise ValueError(f"{value!r}: allowed {', '.join(TIMESERIES_CHOICES)} (N, K positive integers)")
        return value

    def keeps_node(self, node_id: int, nodes: int) -> bool:
        """Whether node ``node_id`` (1 = top) of ``nodes`` has rows in the timeseries."""
        choice = self.timeseries
        if choice == "none":
            return False
        if choice == "bottom":
            return node_id == nodes
        if choice.startswith("every:"):
            return (node_id - 1) % int(choice[6:]) == 0 or node_id == nodes
        return True

    @property
    def tick_step(self) -> int:
        """Every how many ticks a kept node has a row (``decimate:K``: K, else 1)."""
        return int(self.timeseries[9:]) if self.timeseries.startswith("decimate:") else 1
