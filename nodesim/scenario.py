"""Scenario files: TOML in, a frozen, validated :class:`Scenario` out.

Every field has a default, so a scenario file only states what differs from the defaults.  Unknown keys,
wrong types and out-of-range values raise :class:`nodesim.errors.ScenarioError` with one message naming
the file, the key path and the allowed range.  Units are in the field names wherever they are not SI;
degrees appear only here, at the edge, and are converted by the consumers through :mod:`nodesim.units`.
"""

from __future__ import annotations

import hashlib
import tomllib
from pathlib import Path
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from nodesim.errors import ScenarioError


class _Section(BaseModel):
    """Base of every scenario section: frozen, strict about unknown keys, no silent coercion (strict types)."""

    model_config = ConfigDict(extra="forbid", frozen=True, strict=True, validate_default=True)


class SimulationSection(_Section):
    """Run length and Monte Carlo size."""

    duration_s: float = Field(620.0, gt=0.0, le=30 * 24 * 3600.0, description="simulated time")
    realizations: int = Field(1, ge=1, le=1_000_000, description="independent Monte Carlo realizations")


class ChainSection(_Section):
    """The sensor chain: number of nodes, firmware rate, simple links (a fixed delay and a loss probability)."""

    nodes: int = Field(1, ge=1, le=100_000, description="sensor nodes, one per drill tube")
    firmware_rate_hz: float = Field(1.9, gt=0.0, le=1000.0, description="node filter rate")
    link_delay_s: float = Field(0.015, ge=0.0, le=10.0, description="transfer time of one hop")
    link_loss_probability: float = Field(0.0, ge=0.0, le=1.0, description="per-transmission loss")


class MotionSection(_Section):
    """The thesis lab rotation profile (thesis 4.2.2-4.2.3): static, slow rotation, pause, fast rotation, static."""

    inclination_deg: float = Field(2.0, ge=0.0, le=180.0)
    azimuth_deg: float = Field(45.0, ge=0.0, lt=360.0)
    stationary_s: float = Field(50.0, ge=0.0, description="initial static window (bias estimation)")
    slow_rate_deg_s: float = Field(3.6, gt=0.0, le=2000.0, description="calibration rotation rate")
    slow_turns: float = Field(2.0, ge=0.0, le=1e6)
    pause_s: float = Field(10.0, ge=0.0, description="static time between slow and fast rotation")
    fast_rate_deg_s: float = Field(71.0, gt=0.0, le=2000.0)
    fast_turns: float = Field(20.0, ge=0.0, le=1e6)


class SensorSection(_Section):
    """Simple IMU and encoder stand-in (z gyro, accelerometer triad, incremental encoder)."""

    gyro_arw_deg_per_sqrt_s: float = Field(7.38e-3, ge=0.0, le=10.0, description="thesis table V.1, z axis")
    gyro_turn_on_bias_deg_s: float = Field(0.5, ge=-250.0, le=250.0, description="removed by the static window")
    gyro_residual_bias_deg_s: float = Field(
        -0.02, ge=-250.0, le=250.0, description="bias left after motion starts (thesis 4.2.3: about -0.02 deg/s)"
    )
    gyro_scale_factor_error: float = Field(
        0.003, gt=-0.5, lt=0.5, description="residual z-gyro scale-factor error after calibration (fraction)"
    )
    gyro_bias_instability_deg_s: float = Field(3.33e-3, ge=0.0, le=10.0, description="Gauss-Markov sigma")
    gyro_bias_tau_s: float = Field(500.0, gt=0.0, le=1e7, description="Gauss-Markov correlation time")
    accel_noise_ug_per_sqrt_hz: float = Field(300.0, ge=0.0, le=1e6, description="MPU6500 datasheet")
    encoder_counts_per_rev: int = Field(1024, ge=1, le=1 << 24)


class FilterSection(_Section):
    """Node yaw filter settings (thesis 4.2.2; tuning factors A and B of eq 4.14)."""

    implementation: Literal["float", "fixed"] = "float"
    tuning_a: float = Field(1.0, gt=0.0, le=1e3)
    tuning_b: float = Field(5.0, gt=0.0, le=1e3)
    bias_tau_s: float = Field(500.0, gt=0.0, le=1e7)
    moving_average_points: int = Field(32, ge=1, le=10_000)


class ScheduleSection(_Section):
    """Reference-update schedule (thesis 4.2.2 update modes)."""

    mode: Literal["continuous", "windowed", "single", "none"] = "continuous"
    update_s: float = Field(20.0, gt=0.0, description="windowed: length of an update window")
    timeout_s: float = Field(30.0, ge=0.0, description="windowed: length of a timeout")
    single_rate_hz: float = Field(0.2, gt=0.0, le=1000.0, description="single: update frequency")


class MetricsSection(_Section):
    """Where and how the headline metrics are measured."""

    window_start_s: float = Field(370.0, ge=0.0, description="start of the RMS error window")
    window_end_s: float = Field(570.0, gt=0.0, description="end of the RMS error window")
    bias_tolerance_deg_s: float = Field(0.002, gt=0.0, description="bias convergence band")
    bias_hold_s: float = Field(10.0, ge=0.0, description="time the bias must stay in the band")

    @model_validator(mode="after")
    def _window_ordered(self) -> "MetricsSection":
        if self.window_end_s <= self.window_start_s:
            raise ValueError(
                f"window_end_s ({self.window_end_s}) must be greater than window_start_s ({self.window_start_s})"
            )
        return self


class Scenario(_Section):
    """A whole scenario.  Built once from a file; frozen afterwards."""

    name: str = Field("scenario", min_length=1, max_length=100, pattern=r"^[A-Za-z0-9_.-]+$")
    description: str = ""
    seed: int = Field(0, ge=0, le=2**63 - 1, description="root seed of every random stream")
    simulation: SimulationSection = SimulationSection()
    chain: ChainSection = ChainSection()
    motion: MotionSection = MotionSection()
    sensor: SensorSection = SensorSection()
    filter: FilterSection = FilterSection()
    schedule: ScheduleSection = ScheduleSection()
    metrics: MetricsSection = MetricsSection()

    @model_validator(mode="after")
    def _metrics_inside_run(self) -> "Scenario":
        if self.metrics.window_end_s > self.simulation.duration_s:
            raise ValueError(
                f"metrics.window_end_s ({self.metrics.window_end_s}) must not exceed "
                f"simulation.duration_s ({self.simulation.duration_s})"
            )
        return self

    def with_overrides(self, **top_level: Any) -> "Scenario":
        """A copy with dotted-key overrides, re-validated: ``with_overrides(seed=3)`` or ``{'simulation.realizations': 4}``."""
        data = self.model_dump()
        for dotted, value in top_level.items():
            _set_dotted(data, dotted.split("."), value)
        return parse_scenario(data, source="<overrides>")


def _set_dotted(data: dict, keys: list[str], value: Any) -> None:
    for key in keys[:-1]:
        data = data.setdefault(key, {})
    data[keys[-1]] = value


def _format_error(source: str, err: ValidationError) -> str:
    """One clear line per problem: file, key path, what is allowed, what was given."""
    lines = []
    for e in err.errors():
        path = ".".join(str(p) for p in e["loc"]) or "<top level>"
        msg = e["msg"]
        if e["type"] == "extra_forbidden":
            msg = "unknown key"
        given = e.get("input")
        shown = "" if e["type"] in ("extra_forbidden", "missing") or isinstance(given, dict) else f" (got {given!r})"
        lines.append(f"{source}: {path}: {msg}{shown}")
    return "\n".join(lines)


def parse_scenario(data: dict[str, Any], source: str = "<scenario>") -> Scenario:
    """Validate a scenario given as a dict (e.g. parsed TOML)."""
    try:
        return Scenario.model_validate(data)
    except ValidationError as err:
        raise ScenarioError(_format_error(source, err)) from None


def load_scenario(path: str | Path) -> tuple[Scenario, str]:
    """Read and validate a TOML scenario.  Returns the scenario and the SHA-256 of the file bytes."""
    path = Path(path)
    try:
        raw = path.read_bytes()
    except OSError as err:
        raise ScenarioError(f"{path}: cannot read scenario file ({err.strerror})") from None
    try:
        data = tomllib.loads(raw.decode("utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as err:
        raise ScenarioError(f"{path}: not valid TOML ({err})") from None
    return parse_scenario(data, source=str(path)), hashlib.sha256(raw).hexdigest()
