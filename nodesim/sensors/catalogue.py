"""Sensor catalogue: datasheet figures, ISCWSA error-model magnitudes and simulation models per sensor.

Each sensor is a TOML file under ``nodesim/data/sensors/`` with three sections, units in the key names:

* ``[datasheet]``: figures as the sources state them (thesis tables 4.4, 4.7, 4.10, 4.13, 4.16, V.1);
* ``[iscwsa]``: the error-model magnitudes printed in those tables (what the thesis fed its ISCWSA model);
* ``[model]`` (IMUs only): the simulation error model, turned into an :class:`~nodesim.sensors.imu.ImuSpec`.

:func:`iscwsa_from_datasheet` recomputes the magnitudes from the datasheet figures with the mappings of
thesis section 4.1.3, so the printed values can be checked (``nodesim validate``, checks_sensors):

    accelerometer bias from an angle alpha:  f_xy = g sin(alpha)  (eq 4.12),  f_z = g (1 - cos alpha)  (eq 4.7)
    accelerometer bias from b (mg):          f_xy = b g,  alpha = asin(b g / g)
    gyro drift:  deg/h / 3600 = deg/s;   gyro ARW:  deg/sqrt(h) / 60 = deg/sqrt(s) = deg/s/sqrt(Hz)  (eq 3.59)
    DIP: accuracy d per L -> alpha = asin(d / L);  resolution -> scale factor;  cable stretch / length
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass
from importlib import resources

import numpy as np

from nodesim.errors import NodesimError
from nodesim.sensors.imu import ImuSpec, TriadSpec
from nodesim.units import DEG, G0_M_S2

MODEL_KEYS = {
    "sample_rate_hz",
    "gyro_arw_deg_per_sqrt_s",
    "gyro_bias_stability_deg_s",
    "gyro_turn_on_bias_deg_s",
    "gyro_gm_sigma_deg_s",
    "gyro_gm_tau_s",
    "gyro_full_scale_deg_s",
    "gyro_lsb_per_deg_s",
    "gyro_scale_factor_error",
    "gyro_misalignment_rad",
    "accel_noise_ug_per_sqrt_hz",
    "accel_bias_stability_mg",
    "accel_turn_on_bias_mg",
    "accel_full_scale_g",
    "accel_lsb_per_g",
    "accel_scale_factor_error",
    "accel_misalignment_rad",
    "adc_bits",
}
REQUIRED_MODEL_KEYS = {"sample_rate_hz", "gyro_full_scale_deg_s", "gyro_lsb_per_deg_s", "accel_full_scale_g", "accel_lsb_per_g"}
FLOOR_PER_B = 0.6643  # Allan floor of bias instability per unit coefficient B (eq V.34)


def _key(name: str) -> str:
    return "".join(ch for ch in name.lower() if ch.isalnum())


def available_sensors() -> list[str]:
    """Catalogue file stems (lower-case), sorted."""
    folder = resources.files("nodesim") / "data" / "sensors"
    return sorted(p.name[:-5] for p in folder.iterdir() if p.name.endswith(".toml"))


@dataclass(frozen=True)
class SensorEntry:
    """One catalogue entry (see module doc); dictionaries keep the file's unit-suffixed keys."""

    name: str
    kind: str
    description: str
    sources: tuple[str, ...]
    datasheet: dict
    iscwsa: dict
    model: dict

    def imu_spec(self, **model_overrides) -> ImuSpec:
        """The simulation model (SI units inside).  ``model_overrides`` replace ``[model]`` keys."""
        if self.kind != "imu":
            raise NodesimError(f"sensor {self.name!r} is a {self.kind}, not an IMU: it has no simulation model")
        m = dict(self.model)
        unknown = set(model_overrides) - MODEL_KEYS
        if unknown:
            raise NodesimError(f"sensor {self.name!r}: unknown model keys {sorted(unknown)} (allowed: {sorted(MODEL_KEYS)})")
        m.update(model_overrides)
        return build_imu_spec(self.name, m)


def _misalignment(scale_error: float, misalignment_rad: float) -> np.ndarray:
    """M = (1 + s) I + small cross-axis terms: a fixed, reproducible pattern of magnitude ``misalignment_rad``.

    The pattern (+m above, -m/2 below the diagonal) is non-orthogonal, so it is not a pure rotation.
    """
    m = (1.0 + scale_error) * np.eye(3)
    m[np.triu_indices(3, 1)] = misalignment_rad
    m[np.tril_indices(3, -1)] = -0.5 * misalignment_rad
    return m


def build_imu_spec(name: str, m: dict) -> ImuSpec:
    """Turn a ``[model]`` dict (edge units in key names) into an :class:`ImuSpec` (SI units)."""
    unknown = set(m) - MODEL_KEYS
    if unknown:
        raise NodesimError(f"sensor {name!r}: unknown model keys {sorted(unknown)} (allowed: {sorted(MODEL_KEYS)})")
    missing = REQUIRED_MODEL_KEYS - set(m)
    if missing:
        raise NodesimError(f"sensor {name!r}: model is missing {sorted(missing)}")

    def arr(key, default=0.0):
        return np.asarray(m.get(key, default), dtype=float)

    gyro = TriadSpec(
        name=f"{name} gyro",
        full_scale=float(m["gyro_full_scale_deg_s"]) * DEG,
        lsb_per_unit=float(m["gyro_lsb_per_deg_s"]) / DEG,
        white_density=arr("gyro_arw_deg_per_sqrt_s") * DEG,
        bias=arr("gyro_turn_on_bias_deg_s") * DEG,
        bias_instability=arr("gyro_bias_stability_deg_s") * DEG / FLOOR_PER_B,
        gm_sigma=arr("gyro_gm_sigma_deg_s") * DEG,
        gm_tau_s=float(m.get("gyro_gm_tau_s", 500.0)),
        misalignment=_misalignment(float(m.get("gyro_scale_factor_error", 0.0)), float(m.get("gyro_misalignment_rad", 0.0))),
        adc_bits=int(m.get("adc_bits", 16)),
    )
    accel = TriadSpec(
        name=f"{name} accel",
        full_scale=float(m["accel_full_scale_g"]) * G0_M_S2,
        lsb_per_unit=float(m["accel_lsb_per_g"]) / G0_M_S2,
        white_density=arr("accel_noise_ug_per_sqrt_hz") * 1e-6 * G0_M_S2,
        bias=arr("accel_turn_on_bias_mg") * 1e-3 * G0_M_S2,
        bias_instability=arr("accel_bias_stability_mg") * 1e-3 * G0_M_S2 / FLOOR_PER_B,
        misalignment=_misalignment(float(m.get("accel_scale_factor_error", 0.0)), float(m.get("accel_misalignment_rad", 0.0))),
        adc_bits=int(m.get("adc_bits", 16)),
    )
    return ImuSpec(name=name, gyro=gyro, accel=accel, sample_rate_hz=float(m["sample_rate_hz"]))


def load_sensor(name: str) -> SensorEntry:
    """Catalogue entry by name, case and punctuation insensitive ('MPU6500', 'vn-100t', 'iPST-RQH', 'dip')."""
    wanted = _key(name)
    for stem in available_sensors():
        if _key(stem) == wanted:
            text = (resources.files("nodesim") / "data" / "sensors" / f"{stem}.toml").read_text()
            data = tomllib.loads(text)
            if _key(data.get("name", "")) != wanted:
                raise NodesimError(f"sensor catalogue file {stem}.toml names itself {data.get('name')!r}")
            return SensorEntry(
                name=data["name"],
                kind=data["kind"],
                description=data.get("description", ""),
                sources=tuple(data.get("sources", ())),
                datasheet=dict(data.get("datasheet", {})),
                iscwsa=dict(data.get("iscwsa", {})),
                model=dict(data.get("model", {})),
            )
    raise NodesimError(f"unknown sensor {name!r} (catalogue: {', '.join(available_sensors())})")


def accel_bias_from_angle(angle_deg: float) -> tuple[float, float]:
    """(f_xy, f_z) in m/s^2 equivalent to an inclination error ``angle_deg`` at I = 0 (eqs 4.7, 4.12)."""
    a = angle_deg * DEG
    return G0_M_S2 * math.sin(a), G0_M_S2 * (1.0 - math.cos(a))


def iscwsa_from_datasheet(entry: SensorEntry) -> dict:
    """ISCWSA magnitudes recomputed from the datasheet figures (thesis 4.1.3); keys as in ``[iscwsa]``."""
    d = entry.datasheet
    out: dict = {}
    if "system_accuracy_mm" in d:  # DIP: accuracy over a length -> angle -> accelerometer bias
        angle = math.degrees(math.asin(d["system_accuracy_mm"] * 1e-3 / d["system_accuracy_base_m"]))
        out["accel_bias_deg"] = angle
        out["accel_bias_xy_m_s2"] = accel_bias_from_angle(angle)[0]
        res = math.degrees(math.asin(d["resolution_mm"] / d["resolution_base_mm"]))
        out["scale_factor_deg"] = res
        out["scale_factor_m_s2"] = G0_M_S2 * math.sin(res * DEG)
        out["depth_stretch_m_per_m"] = d["cable_stretch_mm"] * 1e-3 / d["cable_stretch_base_m"]
    elif "accel_bias_instability_mg" in d:  # bias in mg -> f_xy, angle -> f_z
        f_xy = d["accel_bias_instability_mg"] * 1e-3 * G0_M_S2
        angle = math.degrees(math.asin(f_xy / G0_M_S2))
        out["accel_bias_xy_m_s2"] = f_xy
        out["accel_bias_z_m_s2"] = accel_bias_from_angle(angle)[1]
    elif "accuracy_pitch_roll_deg" in d:  # angle accuracy -> both biases (MPU6500: f_xy from the zero-g offset)
        out["accel_bias_xy_m_s2"], out["accel_bias_z_m_s2"] = accel_bias_from_angle(d["accuracy_pitch_roll_deg"])
        if "accel_zero_g_offset_mg" in d:
            out["accel_bias_xy_m_s2"] = d["accel_zero_g_offset_mg"] * 1e-3 * G0_M_S2
    if "scale_factor_ppm" in d:
        out["scale_factor_error"] = d["scale_factor_ppm"] * 1e-6
    if "linearity_percent_fs" in d:
        out["scale_factor_error"] = d["linearity_percent_fs"] * 1e-2
    if "accel_resolution_ug" in d:
        out["scale_factor_error"] = d["accel_resolution_ug"] * 1e-6 * G0_M_S2
    if "misalignment_mrad" in d:
        out["misalignment_deg"] = math.degrees(d["misalignment_mrad"] * 1e-3) / 100.0
    if "misalignment_deg" in d:
        out["misalignment_deg"] = d["misalignment_deg"] / 100.0
    if "gyro_bias_instability_deg_h" in d:
        out["gyro_drift_deg_s"] = d["gyro_bias_instability_deg_h"] / 3600.0
    if "gyro_bias_stability_deg_h" in d:
        out["gyro_drift_deg_s"] = d["gyro_bias_stability_deg_h"] / 3600.0
    if "gyro_bias_instability_deg_s" in d:
        out["gyro_drift_deg_s"] = d["gyro_bias_instability_deg_s"]
    if "gyro_arw_deg_per_sqrt_h" in d:
        out["gyro_arw_deg_s_per_sqrt_hz"] = d["gyro_arw_deg_per_sqrt_h"] / 60.0
    if "gyro_arw_deg_s_per_sqrt_hz" in d:
        out["gyro_arw_deg_s_per_sqrt_hz"] = d["gyro_arw_deg_s_per_sqrt_hz"]
    return out
