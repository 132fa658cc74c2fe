"""Bayesian calibration: parameters and box priors, likelihoods, the calibration problem,
least-squares warm start, emcee ensemble sampling or nested sampling with the evidence, diagnostics and
summaries.

The stages share one :class:`CalibrationProblem` (experiments with forward callables + a
:class:`ParameterSet` + noise models); nothing here depends on the mechanics internals.
"""

from bayestissue.inference.diagnostics import ConvergenceReport, assess_convergence
from bayestissue.inference.evidence import NestedReport, assess_nested
from bayestissue.inference.likelihood import (
    NOISE_MODELS,
    AR1Noise,
    GaussianNoise,
    NoiseModel,
    StudentTNoise,
    make_noise,
)
from bayestissue.inference.parameters import ParameterSet, ParameterSpec
from bayestissue.inference.priors import PRIORS, LogUniformPrior, UniformPrior
from bayestissue.inference.problem import CalibrationProblem, ExperimentTerm
from bayestissue.inference.sampling import (
    MOVES,
    NestedOptions,
    NestedSample,
    PosteriorSample,
    SamplerOptions,
    initial_walkers,
    run_ensemble,
    sample_nested,
    sample_posterior,
)
from bayestissue.inference.warmstart import (
    LeastSquaresResult,
    MultistartResult,
    fit_least_squares,
    fit_multistart,
)

__all__ = [
    "AR1Noise",
    "CalibrationProblem",
    "ConvergenceReport",
    "ExperimentTerm",
    "GaussianNoise",
    "LeastSquaresResult",
    "LogUniformPrior",
    "MOVES",
    "MultistartResult",
    "NestedOptions",
    "NestedReport",
    "NestedSample",
    "NOISE_MODELS",
    "NoiseModel",
    "PRIORS",
    "ParameterSet",
    "ParameterSpec",
    "PosteriorSample",
    "SamplerOptions",
    "StudentTNoise",
    "UniformPrior",
    "assess_convergence",
    "assess_nested",
    "fit_least_squares",
    "fit_multistart",
    "initial_walkers",
    "make_noise",
    "run_ensemble",
    "sample_nested",
    "sample_posterior",
]
