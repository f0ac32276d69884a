"""Ground station: surveys, station fusion, wellpath and ISCWSA position uncertainty (pure numpy/scipy).

Modules: ``survey`` (validated input), ``wellpath`` (minimum curvature, balanced tangential,
interpolation, vertical section, A/B axes), ``fusion`` (recursive Bayes, cluster weighting, two-sigma
rule), ``derivatives`` + ``weighting`` + ``errormodel`` + ``covariance`` (ISCWSA engine with running
sums), ``ellipsoid`` (HLA, axes, confidence), ``tools`` (tool models as data), ``iscwsa`` (example wells).
Magnetic survey baseline: ``magnetic_survey`` (triads <-> survey), ``msa`` (Multi-Station Analysis),
``msa_montecarlo``, ``msa_surveys`` (HV/SV test trajectories), ``wls`` (probabilistic estimate, covariance
method), ``magnetic_tool`` (a magnetic MWD tool for simulation runs).
"""

from nodesim.ground.covariance import Site, Uncertainty, propagate
from nodesim.ground.errormodel import ErrorModel, ErrorSource
from nodesim.ground.survey import Survey, make_survey, read_survey_csv
from nodesim.ground.tools import load_tool, tool_names
from nodesim.ground.wellpath import Wellpath, wellpath

__all__ = [
    "ErrorModel",
    "ErrorSource",
    "Site",
    "Survey",
    "Uncertainty",
    "Wellpath",
    "load_tool",
    "make_survey",
    "propagate",
    "read_survey_csv",
    "tool_names",
    "wellpath",
]
