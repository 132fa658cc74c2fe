"""Mechanics: the composite constitutive model and the reduced FE model of homogeneous tests (docs/model.md).

Constitutive laws are plug-ins (:mod:`~bayestissue.mechanics.laws`), so are load cases
(:mod:`~bayestissue.mechanics.loadcases`); one time loop integrates any combination
(:mod:`~bayestissue.mechanics.solver`).
"""

from bayestissue.mechanics.experiment import Experiment, load_experiment
from bayestissue.mechanics.fibres import KelvinFibres
from bayestissue.mechanics.forward import ForwardModel, SimulationResult, simulate
from bayestissue.mechanics.kinematics import STRAIN_COMPONENTS
from bayestissue.mechanics.laws import FIBRE_LAWS, MATRIX_LAWS, fibre_law, matrix_law
from bayestissue.mechanics.loadcases import LOAD_CASES, load_case
from bayestissue.mechanics.protocols import (
    PROTOCOLS,
    CreepProtocol,
    MeasuredForceProtocol,
    RampProtocol,
)
from bayestissue.mechanics.tissue import (
    PAPER_TISSUE,
    TissueConfig,
    check_parameters,
    param_names,
    parse_parameters,
)

__all__ = [
    "Experiment",
    "load_experiment",
    "KelvinFibres",
    "STRAIN_COMPONENTS",
    "FIBRE_LAWS",
    "MATRIX_LAWS",
    "LOAD_CASES",
    "fibre_law",
    "matrix_law",
    "load_case",
    "PROTOCOLS",
    "CreepProtocol",
    "RampProtocol",
    "MeasuredForceProtocol",
    "ForwardModel",
    "SimulationResult",
    "simulate",
    "PAPER_TISSUE",
    "TissueConfig",
    "check_parameters",
    "param_names",
    "parse_parameters",
]
