"""The replay log format (version 1): one table of sensor samples, CSV or Parquet, plus a small header.

A log holds what a lab drill-string experiment records, one row per sensor sample of one node:

required columns
    ``t_s``                      sample time, seconds (any origin; strictly increasing per node)
    ``gyro_x``, ``gyro_y``, ``gyro_z``      angular rate, unit ``gyro_unit``
    ``accel_x``, ``accel_y``, ``accel_z``   specific force, unit ``accel_unit``
    ``encoder``                  top-of-string encoder reading at ``t_s``, unit ``encoder_unit`` (the column
                                 may be empty on the rows of nodes below the top; it is left out entirely
                                 only when the header says ``encoder_unit = absent``)
optional columns
    ``node``                     node id (1 = top); a log without it is a single-node log (node 1)
    ``temperature_c``            sensor temperature (read, not used by the yaw filter)
    ``mag_x``, ``mag_y``, ``mag_z``          magnetometer, unit ``mag_unit`` (read, not used by the yaw filter)
    ``tick``                     1 on the rows where the recorded firmware ticked (its tick times); without it
                                 the replay ticks at the configured firmware rate from the node's first sample
    ``static``                   1 on the ticks of the firmware's static bias window (without it: the ticks before
                                 t_log + the configured window, t_log the log's first time)
    ``hold``                     1 on the ticks where the node holds its state (powered-down link during a tube
                                 insertion: no time update, no reference)
    ``ref_update``               1 where the firmware applied a reference update at that tick (recorded schedule)
    ``ref_yaw``, ``ref_var``     the reference yaw (``angle_unit``) and its variance (``angle_unit``^2) the
                                 firmware used at that update (delay-compensated, thesis eq 3.29)
    ``seq``                      reference-update sequence number (copied to the replay's timeseries.csv)
    ``fw_yaw``, ``fw_yaw_var``, ``fw_bias``, ``fw_inclination``, ``fw_azimuth``
                                 what the real firmware computed at its ticks (``angle_unit``, ``angle_unit``^2,
                                 ``angle_unit``/s; inclination and azimuth moving-averaged as transmitted);
                                 empty on rows without an output
    ``true_yaw``, ``true_inclination``, ``true_azimuth``
                                 the truth, where known (simulated logs; ``angle_unit``)
    ``gyro_sum_*``, ``accel_sum_*``, ``samples``
                                 on ``tick`` rows: the integer sums of the int16 ADC counts the firmware read
                                 since its previous tick and their number (``gyro_lsb_per_deg_s`` and
                                 ``accel_lsb_per_g`` in the header give their scale); the fixed-point replay
                                 feeds them to the firmware as they are.  Without them it sums the samples'
                                 counts itself (raw counts, or SI values requantised to the configured ADC)
    ``frame``                    on ``tick`` rows where the node sent an estimate frame: its 27 bytes as 54
                                 hex digits (``firmware_model.frames``, docs/firmware.md "Frames"), empty
                                 elsewhere; the fixed-point replay encodes its own frame at those ticks and
                                 compares the bytes
    ``x_*``                      free user columns, ignored

header (CSV: ``# key = value`` lines before the column names, the first being ``# nodesim-log 1``;
Parquet: the JSON object under the schema metadata key ``nodesim-log``; either may instead come from a
sidecar ``<log>.meta.json``)
    ``gyro_unit``      counts | rad/s | deg/s      (counts need ``gyro_lsb_per_deg_s``)
    ``accel_unit``     counts | m/s^2 | g          (counts need ``accel_lsb_per_g``)
    ``encoder_unit``   counts | rad | deg | absent (counts need ``encoder_counts_per_rev``)
    ``angle_unit``     rad | deg                   (default rad)
    ``mag_unit``       free text                   (default "")
    ``adc_bits``       16 (default) or 32: the range raw counts must lie in
    ``source``, ``description``: free text
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, fields

from nodesim.errors import NodesimError
from nodesim.units import G0_M_S2

FORMAT_NAME = "nodesim-log"
FORMAT_VERSION = 1
REQUIRED = ("t_s", "gyro_x", "gyro_y", "gyro_z", "accel_x", "accel_y", "accel_z", "encoder")
GYRO = ("gyro_x", "gyro_y", "gyro_z")
ACCEL = ("accel_x", "accel_y", "accel_z")
FIRMWARE_OUTPUTS = ("fw_yaw", "fw_yaw_var", "fw_bias", "fw_inclination", "fw_azimuth")
TRUTH = ("true_yaw", "true_inclination", "true_azimuth")
OPTIONAL = (
    "node", "temperature_c", "mag_x", "mag_y", "mag_z", "tick", "static", "hold", "ref_update", "ref_yaw", "ref_var",
    "seq",
    *FIRMWARE_OUTPUTS, *TRUTH,
)
TICK_SUMS = ("gyro_sum_x", "gyro_sum_y", "gyro_sum_z", "accel_sum_x", "accel_sum_y", "accel_sum_z", "samples")
TEXT = ("frame",)  # text columns (every other column is numeric)
OPTIONAL = OPTIONAL + TICK_SUMS + TEXT
FLAGS = ("tick", "static", "hold", "ref_update")
USER_PREFIX = "x_"

UNITS = {
    "gyro_unit": ("counts", "rad/s", "deg/s"),
    "accel_unit": ("counts", "m/s^2", "g"),
    "encoder_unit": ("counts", "rad", "deg", "absent"),
    "angle_unit": ("rad", "deg"),
}
ADC_RANGES = {16: (-32768, 32767), 32: (-(2**31), 2**31 - 1)}


@dataclass(frozen=True)
class LogMeta:
    """The header of a log: units of the columns and where the data came from."""

    gyro_unit: str = "rad/s"
    accel_unit: str = "m/s^2"
    encoder_unit: str = "rad"
    angle_unit: str = "rad"
    gyro_lsb_per_deg_s: float | None = None
    accel_lsb_per_g: float | None = None
    encoder_counts_per_rev: int | None = None
    mag_unit: str = ""
    adc_bits: int = 16
    source: str = ""
    description: str = ""

    def __post_init__(self) -> None:
        for key, allowed in UNITS.items():
            if getattr(self, key) not in allowed:
                raise NodesimError(f"log header: {key} = {getattr(self, key)!r} is not a known unit; allowed {list(allowed)}")
        needs = (("gyro_unit", "gyro_lsb_per_deg_s"), ("accel_unit", "accel_lsb_per_g"), ("encoder_unit", "encoder_counts_per_rev"))
        for unit_key, scale_key in needs:
            scale = getattr(self, scale_key)
            if getattr(self, unit_key) == "counts" and not (scale is not None and math.isfinite(scale) and scale > 0):
                raise NodesimError(f"log header: {unit_key} = counts needs {scale_key} > 0 (got {scale!r})")
        if self.adc_bits not in ADC_RANGES:
            raise NodesimError(f"log header: adc_bits = {self.adc_bits!r}; allowed {sorted(ADC_RANGES)}")

    @property
    def has_encoder(self) -> bool:
        return self.encoder_unit != "absent"

    # --- conversion factors to SI (multiplications by exactly 1.0 keep SI logs bit-exact) ---
    @property
    def gyro_to_rad_s(self) -> float:
        return {"rad/s": 1.0, "deg/s": math.pi / 180.0}.get(self.gyro_unit) or math.pi / 180.0 / self.gyro_lsb_per_deg_s

    @property
    def accel_to_m_s2(self) -> float:
        return {"m/s^2": 1.0, "g": G0_M_S2}.get(self.accel_unit) or G0_M_S2 / self.accel_lsb_per_g

    @property
    def encoder_to_rad(self) -> float:
        return {"rad": 1.0, "deg": math.pi / 180.0, "absent": 1.0}.get(self.encoder_unit) or 2.0 * math.pi / self.encoder_counts_per_rev

    @property
    def angle_to_rad(self) -> float:
        return 1.0 if self.angle_unit == "rad" else math.pi / 180.0

    def counts_columns(self) -> tuple[str, ...]:
        """Columns holding raw ADC counts (integers within the ``adc_bits`` range)."""
        return (GYRO if self.gyro_unit == "counts" else ()) + (ACCEL if self.accel_unit == "counts" else ())

    def to_dict(self) -> dict:
        return {k: v for k, v in asdict(self).items() if v is not None and v != ""}


_META_TYPES = {f.name: f.type for f in fields(LogMeta)}


def meta_from_dict(raw: dict, where: str) -> LogMeta:
    """Build a :class:`LogMeta` from header strings/values; unknown keys and bad numbers name ``where``."""
    values: dict = {}
    for key, value in raw.items():
        if key not in _META_TYPES:
            raise NodesimError(f"{where}: unknown header key {key!r}; allowed {sorted(_META_TYPES)}")
        kind = _META_TYPES[key]
        try:
            if "int" in kind:
                values[key] = int(value)
            elif "float" in kind:
                values[key] = float(value)
            else:
                values[key] = str(value)
        except (TypeError, ValueError):
            raise NodesimError(f"{where}: header {key} = {value!r} is not a valid {kind.split(' ')[0]}") from None
    try:
        return LogMeta(**values)
    except NodesimError as err:
        raise NodesimError(f"{where}: {err}") from None


def parse_csv_header(lines: list[str], where: str) -> LogMeta:
    """The ``# key = value`` lines (without the leading ``# nodesim-log 1``)."""
    raw = {}
    for i, line in enumerate(lines, start=2):
        body = line.lstrip("#").strip()
        if not body:
            continue
        if "=" not in body:
            raise NodesimError(f"{where}, line {i}: header line {line.strip()!r} is not 'key = value'")
        key, value = (s.strip() for s in body.split("=", 1))
        raw[key] = value
    return meta_from_dict(raw, where)


def format_csv_header(meta: LogMeta) -> str:
    lines = [f"# {FORMAT_NAME} {FORMAT_VERSION}"]
    lines += [f"# {k} = {v}" for k, v in meta.to_dict().items()]
    return "\n".join(lines) + "\n"


def parquet_metadata(meta: LogMeta) -> dict[bytes, bytes]:
    return {FORMAT_NAME.encode(): json.dumps({"version": FORMAT_VERSION, **meta.to_dict()}).encode()}


__all__ = [
    "FORMAT_NAME", "FORMAT_VERSION", "REQUIRED", "OPTIONAL", "TICK_SUMS", "GYRO", "ACCEL", "FIRMWARE_OUTPUTS", "TRUTH", "FLAGS",
    "LogMeta", "meta_from_dict", "parse_csv_header", "format_csv_header", "parquet_metadata",
]
