"""Error sources as data: code, weighting function, magnitude, unit and propagation mode.

Propagation modes (Williamson SPE-67616; thesis eq I.18):
R random (independent from station to station), S systematic (same error at every station of a
survey leg), W per well and G global (correlated across legs/wells; identical to S for a single
survey leg, which is what the ground station computes).

Magnitudes are given at the edges in the units of the ISCWSA model tables and converted once to the
units the weighting functions expect (radians for angles, rad/s for gyro drift, rad/sqrt(s) for angle
random walk, m/s^2 for accelerometer biases, nT for magnetometer terms).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from nodesim.errors import NodesimError
from nodesim.ground.weighting import MAGNETIC_WEIGHTS, WEIGHTING

PROPAGATION_MODES = ("R", "S", "W", "G")

UNIT_FACTORS = {
    "m": 1.0,
    "-": 1.0,
    "1/m": 1.0,
    "m/s2": 1.0,
    "nT": 1.0,
    "deg": math.pi / 180.0,
    "rad": 1.0,
    "deg.nT": math.pi / 180.0,
    "deg/s": math.pi / 180.0,
    "deg/h": math.pi / 180.0 / 3600.0,
    "rad/s": 1.0,
    "deg/sqrt(s)": math.pi / 180.0,  # == deg/s/sqrt(Hz)
    "deg/s/sqrt(Hz)": math.pi / 180.0,
    "deg/sqrt(h)": math.pi / 180.0 / 60.0,
}
"""Multiply a magnitude in the key unit by the factor to get the internal unit."""


@dataclass(frozen=True)
class ErrorSource:
    """One error term: ``magnitude`` is 1 sigma in ``unit``; ``value`` is the converted magnitude."""

    code: str
    weight: str
    magnitude: float
    unit: str
    propagation: str
    description: str = ""

    def __post_init__(self):
        if self.weight not in WEIGHTING:
            raise NodesimError(
                f"error source {self.code}: unknown weighting function '{self.weight}'; "
                f"allowed: {', '.join(sorted(WEIGHTING))}"
            )
        if self.propagation not in PROPAGATION_MODES:
            raise NodesimError(
                f"error source {self.code}: propagation '{self.propagation}' unknown; allowed: {', '.join(PROPAGATION_MODES)}"
            )
        if self.unit not in UNIT_FACTORS:
            raise NodesimError(f"error source {self.code}: unit '{self.unit}' unknown; allowed: {', '.join(UNIT_FACTORS)}")
        if not math.isfinite(self.magnitude) or self.magnitude < 0:
            raise NodesimError(f"error source {self.code}: magnitude must be finite and >= 0, got {self.magnitude}")

    @property
    def value(self) -> float:
        return self.magnitude * UNIT_FACTORS[self.unit]

    @property
    def random(self) -> bool:
        return self.propagation == "R"

    @property
    def magnetic(self) -> bool:
        return self.weight in MAGNETIC_WEIGHTS or self.code.startswith(("DEC", "DBH"))

    def as_dict(self) -> dict:
        return {
            "code": self.code,
            "weight": self.weight,
            "magnitude": self.magnitude,
            "unit": self.unit,
            "propagation": self.propagation,
            "description": self.description,
        }


@dataclass(frozen=True)
class ErrorModel:
    """A named list of error sources plus the site/tool constants of the weighting functions."""

    name: str
    sources: tuple[ErrorSource, ...]
    description: str = ""
    magnetic_azimuth: bool = False
    surface_tie_on: bool = False

    def __post_init__(self):
        codes = [s.code for s in self.sources]
        dup = sorted({c for c in codes if codes.count(c) > 1})
        if dup:
            raise NodesimError(f"error model {self.name}: duplicate source code(s) {dup}")

    def source(self, code: str) -> ErrorSource:
        for s in self.sources:
            if s.code == code:
                return s
        raise NodesimError(f"error model {self.name}: no source '{code}'; has: {', '.join(s.code for s in self.sources)}")

    def without(self, *codes: str) -> ErrorModel:
        for c in codes:
            self.source(c)
        keep = tuple(s for s in self.sources if s.code not in codes)
        return ErrorModel(self.name, keep, self.description, self.magnetic_azimuth, self.surface_tie_on)

    def with_sources(self, *extra: ErrorSource) -> ErrorModel:
        return ErrorModel(self.name, self.sources + tuple(extra), self.description, self.magnetic_azimuth, self.surface_tie_on)
