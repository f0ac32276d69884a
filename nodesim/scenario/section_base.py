"""Base class of every scenario section (shared by :mod:`nodesim.scenario.schema` and :mod:`nodesim.scenario.radio_sections`)."""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict


class _Section(BaseModel):
    """Base of every scenario section: frozen, strict about unknown keys, no silent coercion (strict types)."""

    model_config = ConfigDict(extra="forbid", frozen=True, strict=True, validate_default=True)
