"""Helpers of the inference tests: small problems with known answers (imported by the tests)."""

import numpy as np

from bayestissue.inference import (
    CalibrationProblem,
    ExperimentTerm,
    GaussianNoise,
    ParameterSet,
    ParameterSpec,
)


class _Zero:
    def __call__(self, params):
        return np.zeros((np.atleast_2d(params).shape[0], 5))


def prior_only_problem(specs):
    """A problem whose likelihood is constant: its posterior is the prior."""
    term = ExperimentTerm("flat", np.arange(5.0), np.zeros(5), _Zero(), GaussianNoise(sd=1.0))
    return CalibrationProblem([term], ParameterSet(tuple(specs)))


#: Box priors covering every prior/scale combination, including the mismatched ones whose
#: log-Jacobian carries the log x term.
PRIOR_SPECS = (
    ParameterSpec("a", "kPa", 1e-3, 1e3, prior="loguniform"),
    ParameterSpec("b", "1", 0.1, 0.95, prior="uniform"),
    ParameterSpec("c", "kPa", 1e-3, 10.0, prior="uniform", scale="log"),
    ParameterSpec("d", "1/s", 1e-2, 1e2, prior="loguniform", scale="linear"),
)


class _Square:
    """Forward model ``(x0^2, ..., x0^2, x1, ..., x1)`` (picklable): ``x0`` and ``-x0`` fit alike."""

    def __call__(self, params):
        p = np.atleast_2d(np.asarray(params, dtype=float))
        return np.column_stack([np.repeat(p[:, :1] ** 2, 10, axis=1), np.repeat(p[:, 1:2], 10, axis=1)])


def two_mode_problem():
    """A posterior with two equal, well separated modes at ``x0 = +2`` and ``x0 = -2`` (``x1 ~ 0.5``):
    data ``x0^2 = 4`` and ``x1 = 0.5`` observed 10 times each with known sd 0.1, uniform priors on
    ``[-5, 5]``. Each mode has half of the mass; the modes are about 450 posterior sd apart in the
    sampler's coordinates, so no move between walkers of one mode reaches the other."""
    specs = tuple(ParameterSpec(n, "1", -5.0, 5.0, prior="uniform", value=0.0) for n in ("x0", "x1"))
    y = np.concatenate([np.full(10, 4.0), np.full(10, 0.5)])
    term = ExperimentTerm("square", np.arange(20.0), y, _Square(), GaussianNoise(sd=0.1))
    return CalibrationProblem([term], ParameterSet(specs))
