"""Mechanics: the composite constitutive model and the reduced FE model of the uniaxial tests (MODEL.md)."""

from bayestissue.mechanics.experiment import Experiment, load_experiment
from bayestissue.mechanics.fibres import KelvinFibres
from bayestissue.mechanics.kinematics import STRAIN_COMPONENTS
from bayestissue.mechanics.protocols import (
    PROTOCOLS,
    CreepProtocol,
    MeasuredForceProtocol,
    RampProtocol,
)
from bayestissue.mechanics.simulate import SimulationResult, simulate
from bayestissue.mechanics.tissue import (
    PAPER_BOUNDS,
    PAPER_DIRECTIONS,
    PAPER_PARAMETERS,
    PAPER_TISSUE,
    PARAM_UNITS,
    TissueConfig,
    check_parameters,
    param_names,
    param_unit,
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
    "SimulationResult",
    "simulate",
    "PAPER_BOUNDS",
    "PAPER_DIRECTIONS",
    "PAPER_PARAMETERS",
    "PAPER_TISSUE",
    "PARAM_UNITS",
    "TissueConfig",
    "check_parameters",
    "param_names",
    "param_unit",
    "parse_parameters",
]
