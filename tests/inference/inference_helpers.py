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
