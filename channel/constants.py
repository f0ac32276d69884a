"""Physical constants (SI, CODATA 2018 exact or recommended values) and unit helpers shared by the channel models."""

import math

C0_M_S = 299_792_458.0
"""Speed of light in vacuum [m/s] (exact)."""

MU0_H_M = 1.25663706212e-6
"""Vacuum permeability [H/m] (CODATA 2018)."""

EPS0_F_M = 1.0 / (MU0_H_M * C0_M_S**2)
"""Vacuum permittivity [F/m], from mu0 and c so that c = 1/sqrt(mu0 eps0) holds to rounding."""

ETA0_OHM = MU0_H_M * C0_M_S
"""Free-space wave impedance [ohm] (about 376.73)."""

K_BOLTZMANN_J_K = 1.380649e-23
"""Boltzmann constant [J/K] (exact)."""

T0_K = 290.0
"""Reference noise temperature [K] (IEEE standard, gives -174 dBm/Hz)."""

NP_TO_DB = 20.0 / math.log(10.0)
"""dB per neper (8.6859); the thesis eq 5.2 rounds it to 8.69."""
