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


class _LopsidedSquare:
    """Forward model ``(f(x0), ..., x1, ...)`` with ``f(x0) = x0^2`` for ``x0 >= 0`` and ``(c x0)^2`` below
    (picklable)."""

    def __init__(self, c: float):
        self.c = c

    def __call__(self, params):
        p = np.atleast_2d(np.asarray(params, dtype=float))
        x0 = np.where(p[:, 0] >= 0.0, p[:, 0], self.c * p[:, 0])
        return np.column_stack([np.repeat(x0[:, None] ** 2, 10, axis=1), np.repeat(p[:, 1:2], 10, axis=1)])


def lopsided_two_mode_problem(weight_right: float = 0.7):
    """Two separated modes with masses ``1 - weight_right`` (``x0 = -2/c``) and ``weight_right`` (``x0 = +2``):
    data ``f(x0) = 4`` and ``x1 = 0.5`` observed 10 times each with known sd 0.1, uniform priors on ``[-5, 5]``.

    With the substitution :math:`u = f(x_0)`, :math:`|df/dx_0| = 2\\sqrt{u}` on the right and :math:`2c\\sqrt{u}` on
    the left, so the left mode's mass is exactly :math:`1/c` times the right one's; :math:`c = w/(1-w)` gives
    the weights (box truncation below 1e-300)."""
    c = weight_right / (1.0 - weight_right)
    specs = tuple(ParameterSpec(n, "1", -5.0, 5.0, prior="uniform", value=0.0) for n in ("x0", "x1"))
    y = np.concatenate([np.full(10, 4.0), np.full(10, 0.5)])
    term = ExperimentTerm("lopsided", np.arange(20.0), y, _LopsidedSquare(c), GaussianNoise(sd=0.1))
    return CalibrationProblem([term], ParameterSet(specs))


class _SumProduct:
    """Forward model ``(a + b, ..., a b, ...)`` (picklable): symmetric in ``a`` and ``b``."""

    def __call__(self, params):
        p = np.atleast_2d(np.asarray(params, dtype=float))
        return np.column_stack(
            [np.repeat(p[:, :1] + p[:, 1:2], 10, axis=1), np.repeat(p[:, :1] * p[:, 1:2], 10, axis=1)]
        )


def exchangeable_problem(exchangeable=True):
    """``a + b = 3`` and ``a b = 2`` observed 10 times each (sd 0.05), uniform priors on ``[0, 4]``: two
    label-switched modes (2, 1) and (1, 2); with ``exchangeable`` the prior keeps ``a >= b``."""
    specs = tuple(ParameterSpec(n, "1", 0.0, 4.0, prior="uniform", value=2.0) for n in ("a", "b"))
    y = np.concatenate([np.full(10, 3.0), np.full(10, 2.0)])
    term = ExperimentTerm("sumprod", np.arange(20.0), y, _SumProduct(), GaussianNoise(sd=0.05))
    groups = [["a"], ["b"]] if exchangeable else None
    return CalibrationProblem([term], ParameterSet(specs), exchangeable=groups)


def stuck_step_sampler(sampler_class):
    """UltraNest's population slice sampler ``sampler_class`` in the state of its issues #166 / #177: every step
    evaluates the same point again and no walker ever finishes (``logl`` None)."""

    class Stuck(sampler_class):
        def __next__(self, region, Lmin, us, Ls, transform, loglike, **kwargs):
            loglike(transform(np.repeat(us[:1], self.popsize, axis=0)))
            return None, None, None, self.popsize

    return Stuck
