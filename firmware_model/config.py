"""One firmware build's configuration: every numeric format and constant the node firmware uses.

:class:`FirmwareConfig` is built once per run from the scenario (``nodesim.chain.estimator.firmware_config``),
gives the int64 parameter vectors the njit firmware (:mod:`firmware_model.node_firmware`,
:mod:`firmware_model.fixed_kernel`) and the C reference take, and writes them as a C header
(:meth:`FirmwareConfig.c_header`, ``nodesim firmware export-config``): what was simulated is what gets flashed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from firmware_model import cordic
from firmware_model import fixed_kernel as fk
from firmware_model import fixedpoint as fp
from firmware_model import node_firmware as nf
from firmware_model import node_survey as survey
from firmware_model.errors import FirmwareError
from firmware_model.fixed_filter import FixedFormats, FixedYawFilter, RAD_TO_DEG, const
from firmware_model.fixedpoint import Overflow, QFormat
from firmware_model.yaw_filter import YawFilterConfig

GYRO_SENS_X10 = {250: 1310, 500: 655, 1000: 328, 2000: 164}
"""MPU6500 gyro sensitivity x 10 [LSB per deg/s] by full-scale range [deg/s] (MPU-6500 product specification,
section 6.1: 131, 65.5, 32.8, 16.4)."""
SIGMA_D_FRAC = 24  # the transfer term (deg) in Q8.24


@dataclass(frozen=True)
class FirmwareConfig:
    """The numbers of one firmware build (SI units unless named)."""

    filter: YawFilterConfig
    formats: FixedFormats
    gyro_full_scale_dps: int = 250
    sigma_rate_rad_s: float = 0.0  # per-tick gyro white-noise sigma (the transfer term of R)
    offset_sigma_rad: float = 0.0  # node-to-node yaw offset sigma (R)
    encoder_counts_per_rev: int = 1024
    extrapolate_rate: bool = False
    survey_math: str = "cordic"  # "cordic" (integer CORDIC) or "fpu" (single-precision float): firmware_model.node_survey
    cordic_iterations: int = cordic.DEFAULT_ITERATIONS
    survey_points: int = 32  # the survey moving average's window N

    def __post_init__(self) -> None:
        if self.gyro_full_scale_dps not in GYRO_SENS_X10:
            raise FirmwareError(f"gyro_full_scale_dps = {self.gyro_full_scale_dps!r}: allowed {sorted(GYRO_SENS_X10)}")
        for name in ("sigma_rate_rad_s", "offset_sigma_rad"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0.0):
                raise FirmwareError(f"{name} = {v}: allowed finite values >= 0")
        if not (isinstance(self.encoder_counts_per_rev, int) and self.encoder_counts_per_rev >= 1):
            raise FirmwareError(f"encoder_counts_per_rev = {self.encoder_counts_per_rev!r}: allowed integers >= 1")
        survey.mode_of(self.survey_math)
        cordic.check_iterations(self.cordic_iterations)
        if isinstance(self.survey_points, bool) or not (isinstance(self.survey_points, int) and self.survey_points >= 1):
            raise FirmwareError(f"survey_points = {self.survey_points!r}: allowed integers >= 1")

    @property
    def survey_mode(self) -> int:
        """firmware_model.node_survey.MODE_CORDIC or MODE_FPU."""
        return survey.mode_of(self.survey_math)

    @property
    def dt_us(self) -> int:
        return int(round(self.filter.dt_s * 1e6))

    @property
    def encoder_variance_deg2(self) -> float:
        q = 360.0 / self.encoder_counts_per_rev
        return q * q / 12.0

    def _reference_filter(self) -> FixedYawFilter:
        return FixedYawFilter(self.filter, 1, formats=self.formats)

    def filter_params(self) -> np.ndarray:
        """The filter kernel's int64 parameter vector (:func:`firmware_model.fixed_kernel.kernel_params`)."""
        return fk.kernel_params(self._reference_filter())

    def params(self) -> np.ndarray:
        """The firmware's int64 parameter vector (:data:`firmware_model.node_firmware.PARAMS`)."""
        kf, f = self._reference_filter(), self.formats
        sig = const(self.sigma_rate_rad_s * RAD_TO_DEG * 1e-6, site="sigma_rate per us")
        p = np.zeros(nf.N_PARAMS, dtype=np.int64)
        p[nf.P_SENS] = GYRO_SENS_X10[self.gyro_full_scale_dps]
        p[nf.P_SIG], p[nf.P_SIG_F] = int(sig.raw), sig.fmt.frac_bits
        off = fp.from_float((self.offset_sigma_rad * RAD_TO_DEG) ** 2, f.p_yy, overflow=Overflow.SATURATE)
        enc = fp.from_float(self.encoder_variance_deg2, f.p_yy, overflow=Overflow.SATURATE)
        p[nf.P_OFF2], p[nf.P_ENC_VAR] = int(off.raw), int(enc.raw)
        p[nf.P_EXTRA] = int(self.extrapolate_rate)
        p[nf.P_DT_US] = self.dt_us
        p[nf.P_P0_YY], p[nf.P_P0_BB] = int(np.asarray(kf.p_yy.raw).reshape(-1)[0]), int(np.asarray(kf.p_bb.raw).reshape(-1)[0])
        p[nf.P_SIG_D_F] = SIGMA_D_FRAC
        if p[nf.P_SIG_F] - SIGMA_D_FRAC > 62 or p[nf.P_SIG_F] < SIGMA_D_FRAC - 62:
            raise FirmwareError(f"sigma_rate_rad_s = {self.sigma_rate_rad_s}: its constant needs a shift beyond 62 bits")
        return p

    def encoder_yaw_raw(self, yaw_rad) -> np.ndarray:
        """The encoder's reading as the binary angle its reply frame carries (exact for 2^n counts per turn)."""
        return np.asarray(fp.from_float(np.asarray(yaw_rad, float) / (2 * math.pi), self.formats.yaw,
                                        overflow=Overflow.WRAP).raw, dtype=np.int64)

    def encoder_rate_raw(self, rate_rad_s) -> np.ndarray:
        """The encoder's rate in the reply frame (the rate format, deg/s)."""
        return np.asarray(fp.from_float(np.asarray(rate_rad_s, float) * RAD_TO_DEG, self.formats.rate).raw,
                          dtype=np.int64)

    def c_header(self, name: str = "") -> str:
        """This build as a C header the reference firmware compiles against (``NF_*`` initialisers)."""
        fparams, params = self.filter_params(), self.params()
        lines = [
            "/* Node firmware configuration exported by nodesim (firmware_model.config.FirmwareConfig)."
            + (f" Scenario: {name}." if name else "") + " */",
            "#ifndef NODE_CONFIG_H", "#define NODE_CONFIG_H", "",
            f"#define NF_FIRMWARE_RATE_HZ_X1000 {int(round(1e3 / self.filter.dt_s))}",
            f"#define NF_GYRO_FULL_SCALE_DPS {self.gyro_full_scale_dps}",
            f"#define NF_ENCODER_COUNTS_PER_REV {self.encoder_counts_per_rev}",
            f"#define NF_SURVEY_MODE {self.survey_mode}  /* {self.survey_math}: SURVEY_MODE_CORDIC 0, SURVEY_MODE_FPU 1 */",
            f"#define NF_CORDIC_ITERATIONS {self.cordic_iterations}",
            f"#define NF_SURVEY_POINTS {self.survey_points}",
            f"#define NF_N_FILTER_PARAMS {fparams.size}", f"#define NF_N_PARAMS {params.size}",
            f"#define NF_N_SITES {len(nf.SITES)}", f"#define NF_STATE_SIZE {nf.STATE_SIZE}", "",
            "/* formats: word bits, fraction bits */",
        ]
        for field in fk.FORMAT_FIELDS:
            q: QFormat = getattr(self.formats, field)
            lines.append(f"#define NF_FMT_{field.upper()} {q.word_bits}, {q.frac_bits}  /* {q} */")
        lines.append("")
        t = self.filter
        lines.append(f"/* filter tuning (thesis eqs 4.14-4.15): A = {t.tuning_a:g}, B = {t.tuning_b:g}, b_tuning = {t.b_tuning} "
                     f"(Q_bb = {'B^2' if t.b_tuning == 'noise_gain' else 'B'} 2 sigma_b^2 / tau dt, quantised into q_bb) */")
        lines.append("/* the filter kernel's parameters (firmware_model.fixed_kernel.kernel_params) */")
        lines.append("#define NF_FILTER_PARAMS_INIT { " + ", ".join(f"{int(v)}LL" for v in fparams) + " }")
        lines.append("/* the firmware's parameters (firmware_model.node_firmware.PARAMS: "
                     + ", ".join(nf.PARAMS) + ") */")
        lines.append("#define NF_PARAMS_INIT { " + ", ".join(f"{int(v)}LL" for v in params) + " }")
        lines += ["", "#endif", ""]
        return "\n".join(lines)
