"""Mechanics: the composite constitutive model and the reduced FE model of the uniaxial tests (docs/model.md)."""

from bayestissue.mechanics.experiment import Experiment, load_experiment
from bayestissue.mechanics.fibres import KelvinFibres
from bayestissue.mechanics.forward import ForwardModel, SimulationResult, simulate
from bayestissue.mechanics.kinematics import STRAIN_COMPONENTS
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
