"""Ground station: surveys, station fusion, wellpath and ISCWSA position uncertainty (pure numpy/scipy).

Modules: ``survey`` (validated input), ``wellpath`` (minimum curvature, balanced tangential,
interpolation, vertical section, A/B axes), ``fusion`` (recursive Bayes, cluster weighting, two-sigma
rule), ``derivatives`` + ``weighting`` + ``errormodel`` + ``covariance`` (ISCWSA engine with running
sums), ``thesis_propagation`` (the thesis-replica propagation of its wellbore tables, beside ISCWSA),
``ellipsoid`` (HLA, axes, confidence), ``tools`` (tool models as data), ``iscwsa`` (example wells).
Magnetic survey baseline: ``magnetic_survey`` (triads <-> survey), ``msa`` (Multi-Station Analysis),
``msa_montecarlo``, ``msa_surveys`` (HV/SV test trajectories), ``wls`` (probabilistic estimate, covariance
method), ``magnetic_tool`` (a magnetic MWD tool for simulation runs).
"""

from nodesim.ground.covariance import Site, Uncertainty, propagate
from nodesim.ground.errormodel import ErrorModel, ErrorSource
from nodesim.ground.survey import Survey, make_survey, read_survey_csv
from nodesim.ground.thesis_propagation import PROPAGATIONS, ThesisUncertainty, position_uncertainty, propagate_thesis
from nodesim.ground.tools import load_tool, tool_names
from nodesim.ground.wellpath import Wellpath, wellpath

__all__ = [
    "ErrorModel",
    "ErrorSource",
    "PROPAGATIONS",
    "Site",
    "Survey",
    "ThesisUncertainty",
    "Uncertainty",
    "Wellpath",
    "load_tool",
    "make_survey",
    "position_uncertainty",
    "propagate",
    "propagate_thesis",
    "read_survey_csv",
    "tool_names",
    "wellpath",
]
