"""Ground-station figures: thesis 4.1.2 worked example, ISCWSA example wells, MCM and fusion examples.

Sources: thesis (drill-string navigation and telemetry) sections 4.1.2, 4.3 and tables 4.23-4.24;
covariance-method thesis (SV) appendix 8.1; ISCWSA MWD Rev 5.1 example workbooks #1-#3 (diagnostic
data, compact copies under ``nodesim/data/iscwsa``).

Every row is a ``reproduction``: our propagation, survey and fusion code run on the sources' inputs against
the figures they print (the ISCWSA final N/E against the oracle README's recomputation, as each row's note says).
"""

from __future__ import annotations

import numpy as np

from nodesim.ground.covariance import Site, propagate
from nodesim.ground.errormodel import ErrorModel, ErrorSource
from nodesim.ground.fusion import bayes_update, error_decrease_ratio, stale_increment_error
from nodesim.ground.iscwsa import COV_KEYS, bundled_well
from nodesim.ground.survey import make_survey
from nodesim.ground.wellpath import course_displacements, dogleg_rad, ratio_factor
from nodesim.units import DEG, G0_M_S2
from nodesim.validation import Check, within_abs, within_rel

THESIS = "thesis"
WORKED = f"{THESIS} 4.1.2 worked example"
THESIS_SITE = Site(gravity_m_s2=G0_M_S2, dip_deg=0.0)  # thesis 4.1.2 uses g = 9.81


def worked_example_survey(time_s=(0.0, 100.0)):
    """Thesis 4.1.2: station 1 (MD 0, I 0, A 0), station 2 (MD 3 m, I 5 deg, A 30 deg)."""
    return make_survey([0.0, 3.0], [0.0, 5.0], [0.0, 30.0], time_s=list(time_s))


def worked_example_sigmas() -> dict[str, np.ndarray]:
    """1-sigma N/E/TVD at station 2 for the three error cases of thesis 4.1.2 (signed, from e*)."""
    s = worked_example_survey()
    b_xy = G0_M_S2 * np.sin(0.01 * DEG)  # thesis: 1.712168e-3 m/s2
    cases = {
        "inclination 0.01 deg (first-principles route)": ErrorSource("INC", "INC", 0.01, "deg", "S"),
        "accelerometer x/y bias (matrix route)": ErrorSource("ABXY-TI1S", "ABXY-TI1", b_xy, "m/s2", "S"),
        "z-gyro bias 0.01 deg/s over 100 s": ErrorSource("GYRO-DRIFT", "GYRO-DRIFT", 0.01, "deg/s", "S"),
    }
    out = {}
    for name, src in cases.items():
        u = propagate(s, ErrorModel(name, (src,)), THESIS_SITE, method="balanced_tangential")
        out[name] = np.sqrt(np.diag(u.cov_nev_m2[1]))
    return out


def worked_example() -> list[Check]:
    r = worked_example_sigmas()
    inc = r["inclination 0.01 deg (first-principles route)"]
    acc = r["accelerometer x/y bias (matrix route)"]
    gyr = r["z-gyro bias 0.01 deg/s over 100 s"]
    tol = "4 printed digits: rel 2e-3"
    return [
        within_rel("worked example: N from 0.01 deg inclination error [m]", WORKED, inc[0], 2.259e-4, 2e-3, tol),
        within_rel("worked example: E from 0.01 deg inclination error [m]", WORKED, inc[1], 1.304e-4, 2e-3, tol),
        within_rel("worked example: TVD from 0.01 deg inclination error [m]", WORKED, inc[2], 2.284e-5, 2e-3, tol),
        within_rel("worked example: N from accelerometer bias, matrix route [m]", WORKED, acc[0], 2.25e-4, 2e-3),
        within_rel("worked example: E from accelerometer bias, matrix route [m]", WORKED, acc[1], 1.299e-4, 2e-3),
        within_rel("worked example: TVD from accelerometer bias, matrix route [m]", WORKED, acc[2], 2.273e-5, 2e-3),
        within_rel("worked example: |N| from gyro bias 0.01 deg/s, 100 s [m]", WORKED, gyr[0], 1.141e-3, 2e-3),
        within_rel("worked example: E from gyro bias 0.01 deg/s, 100 s [m]", WORKED, gyr[1], 1.976e-3, 2e-3),
        within_abs("worked example: TVD from gyro bias [m]", WORKED, gyr[2], 0.0, 1e-12),
    ]


def iscwsa_cell_ok(got: float, ref: float, rtol: float = 1e-3, atol: float = 5e-5) -> bool:
    """ISCWSA oracle rule: abs_err <= atol or rel_err <= rtol."""
    err = abs(got - ref)
    return err <= atol or (ref != 0 and err / abs(ref) <= rtol)


_PAIRS = {"nn": (0, 0), "ee": (1, 1), "vv": (2, 2), "ne": (0, 1), "nv": (0, 2), "ev": (1, 2)}


def compare_well(name: str) -> dict:
    """Per-source comparison with the diagnostic data (cells listed as workbook mismatches are compared
    with the workbook's own values, as the oracle README recommends).  Returns counts per class."""
    well = bundled_well(name)
    u = propagate(well.survey, well.model, well.site, per_source=True)
    res = {"nonmag_cells": 0, "nonmag_fail": [], "mag_cells": 0, "mag_fail": [], "path": u.path, "well": well}
    for point in well.validation:
        k = point["station_index"]
        for i, src in enumerate(well.model.sources):
            variant = "calculated" if point["md"] in well.mismatch.get(src.code, []) else "diagnostic"
            # XCLA in #2/#3: the workbook's calculated column carries a fork's edit; the diagnostic data are the reference
            if src.code == "XCLA":
                variant = "diagnostic"
            ref = point["sources"][src.code][variant]
            got = u.per_source_m2[i, k]
            cls = "mag" if src.magnetic else "nonmag"
            for key in COV_KEYS:
                res[f"{cls}_cells"] += 1
                a, b = _PAIRS[key]
                if not iscwsa_cell_ok(got[a, b], ref[key]):
                    res[f"{cls}_fail"].append((src.code, point["md"], key, float(got[a, b]), ref[key]))
    return res


# final minimum-curvature positions recomputed from md/inc/azi (oracle README, "Survey sanity checks")
ISCWSA_FINAL_NE = {"iscwsa1_rev5": (1530.727, 5712.749), "iscwsa2_rev5": (-1692.692 * 0.3048, -1026.136 * 0.3048), "iscwsa3_rev5": (721.338, -791.284)}


def iscwsa_wells() -> list[Check]:
    checks = []
    for name in ("iscwsa1_rev5", "iscwsa2_rev5", "iscwsa3_rev5"):
        r = compare_well(name)
        src = f"ISCWSA MWD Rev 5.1 example well {name[6]} (validation sheet, diagnostic data)"
        n_ok = r["nonmag_cells"] - len(r["nonmag_fail"])
        checks.append(
            Check(
                f"ISCWSA well {name[6]}: non-magnetic source covariance cells within rule",
                src,
                float(n_ok),
                float(r["nonmag_cells"]),
                "all cells: abs 5e-5 m2 or rel 1e-3",
                not r["nonmag_fail"],
                "; ".join(f"{c} {md} {k}: {g:.5g} vs {v:.5g}" for c, md, k, g, v in r["nonmag_fail"][:3]),
            )
        )
        m_ok = r["mag_cells"] - len(r["mag_fail"])
        checks.append(
            Check(
                f"ISCWSA well {name[6]}: magnetic source covariance cells within rule",
                src,
                float(m_ok),
                float(r["mag_cells"]),
                "all cells: abs 5e-5 m2 or rel 1e-3",
                not r["mag_fail"],
                "DEC-OH compared with the workbook's values (diagnostic data used 0.20 deg, model 0.21 deg)",
            )
        )
        path, well = r["path"], r["well"]
        n_ref, e_ref = ISCWSA_FINAL_NE[name]
        ne_note = ("reference: the oracle README's own minimum-curvature recomputation from md/inc/azi (the workbook "
                   "has no N/E columns), an independent implementation rather than a published figure")
        checks.append(within_abs(f"ISCWSA well {name[6]}: final north [m]", src, path.n_m[-1], n_ref, 2e-3, ne_note))
        checks.append(within_abs(f"ISCWSA well {name[6]}: final east [m]", src, path.e_m[-1], e_ref, 2e-3, ne_note))
        checks.append(
            within_abs(
                f"ISCWSA well {name[6]}: max |TVD - workbook TVD| [m]",
                src,
                float(np.max(np.abs(path.tvd_m - well.tvd_m))),
                0.0,
                0.04,
                "workbook TVD typed to 2 dp; #2/#3 also type I/A to 2 dp (oracle README: 0.0049/0.010/0.036 m)",
            )
        )
    return checks


SV = "covariance-method thesis (SV) appendix 8.1 MCM example"


def mcm_example() -> list[Check]:
    ft = 0.3048
    s = make_survey([3500 * ft, 3600 * ft], [15.0, 25.0], [20.0, 45.0])
    d = course_displacements(s, "minimum_curvature")[0] / ft
    dl = float(dogleg_rad(s.inc_rad[0], s.azi_rad[0], s.inc_rad[1], s.azi_rad[1]))
    return [
        within_abs("MCM example: dN [ft]", SV, d[0], 27.22, 0.005),
        within_abs("MCM example: dE [ft]", SV, d[1], 19.45, 0.005),
        within_abs("MCM example: dogleg [rad]", SV, dl, 0.22605, 5e-6),
        within_abs("MCM example: dTVD [ft]", SV, d[2], 93.01, 0.005, "SV prints 93.01; recomputed 94.012 (digest msa 7: typo)"),
        within_abs("MCM example: ratio factor", SV, float(ratio_factor(dl)), 1.00408, 5e-6, "SV prints 1.00408; 1.004280 (typo)"),
    ]


SEC43 = f"{THESIS} 4.3 (fig 4.35, tables 4.26-4.29)"


def fusion_examples() -> list[Check]:
    old = make_survey([0, 2, 4, 6, 8], [0, 1, 1, 1, 1], [0, 120, 120, 120, 120])
    new = make_survey([0, 2, 4, 6, 8], [0, 1, 3, 1, 1], [0, 120, 120, 120, 120])
    err = np.abs(stale_increment_error(old, new, [0, 4, 3, 2, 1], "equal")) * 100.0
    checks = [
        within_rel("fusion: SS2 N error, I 1->3 deg, equal weights [cm]", SEC43, err[2, 0], 1.18, 0.05, "value read from a figure (~)"),
        within_rel("fusion: SS3 N error [cm]", SEC43, err[3, 0], 0.85, 0.05, "value read from a figure (~)"),
        within_rel("fusion: SS2 E error [cm]", SEC43, err[2, 1], 2.0, 0.05, "value read from a figure (~)"),
        within_rel("fusion: SS2 TVD error [cm]", SEC43, err[2, 2], 0.08, 0.05, "value read from a figure (~)"),
        within_rel("fusion: SS3 TVD error [cm]", SEC43, err[3, 2], 0.06, 0.05, "value read from a figure (~)"),
        within_abs("fusion: linear/equal error ratio at SS2", SEC43, error_decrease_ratio("linear", 3), 0.75, 0.01),
        within_abs("fusion: linear/equal error ratio at SS3", SEC43, error_decrease_ratio("linear", 2), 0.67, 0.01),
        within_abs("fusion: quadratic/equal error ratio at SS2", SEC43, error_decrease_ratio("quadratic", 3), 0.53, 0.01),
        within_abs("fusion: quadratic/equal error ratio at SS3", SEC43, error_decrease_ratio("quadratic", 2), 0.40, 0.01),
    ]
    t423 = f"{THESIS} tables 4.23-4.24 (eqs 4.9-4.10)"
    m1, v1 = bayes_update(1.126, 0.0422**2, 0.168, 0.0051**2)
    m2, v2 = bayes_update(0.1, 0.0001**2, m1, v1)
    checks += [
        within_abs("Bayes: MPU6500 + VN-100T mean [%]", t423, float(m1), 0.182, 5e-4),
        within_abs("Bayes: MPU6500 + VN-100T sigma [deg]", t423, float(np.sqrt(v1)), 5.06e-3, 5e-6),
        within_abs("Bayes: + sensor C mean [%]", t423, float(m2), 0.100032, 5e-7),
        within_abs("Bayes: + sensor C sigma [deg]", t423, float(np.sqrt(v2)), 9.998e-5, 5e-8),
    ]
    return checks


CHECKS = [worked_example, iscwsa_wells, mcm_example, fusion_examples]
