"""A linear-Gaussian stand-in for the forward model, with a closed-form posterior.

Used to test the whole inference path (priors, transforms, likelihood, least squares, sampler,
diagnostics, outputs) against exact answers, independently of the mechanics. The model is

.. math:: y = A x + \\varepsilon, \\qquad \\varepsilon \\sim N(0, \\sigma^2 I),

with uniform priors on a box much wider than the likelihood. Inside such a box the posterior is
Gaussian,

.. math::

    x \\mid y \\sim N\\left((A^T A)^{-1} A^T y,\\; \\sigma^2 (A^T A)^{-1}\\right)

(the box truncation is negligible when the box edges lie many posterior sd away).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bayestissue.inference.likelihood import GaussianNoise, NoiseModel
from bayestissue.inference.parameters import ParameterSet, ParameterSpec
from bayestissue.inference.problem import CalibrationProblem, ExperimentTerm

__all__ = ["LinearForward", "linear_gaussian_problem", "linear_gaussian_posterior"]


@dataclass(frozen=True)
class LinearForward:
    """Picklable forward model ``params @ design.T``; rows with ``params[:, 0] > fail_above`` give
    NaN."""

    design: np.ndarray
    fail_above: float = np.inf

    def __call__(self, params):
        params = np.atleast_2d(np.asarray(params, dtype=float))
        out = params @ np.asarray(self.design).T
        out[params[:, 0] > self.fail_above] = np.nan
        return out


def linear_gaussian_problem(
    n_obs: int = 40,
    n_params: int = 3,
    *,
    sd: float = 0.1,
    noise: NoiseModel | None = None,
    box: float = 20.0,
    n_experiments: int = 1,
    fail_above: float = np.inf,
    rng=None,
) -> tuple[CalibrationProblem, np.ndarray]:
    """A random linear-Gaussian calibration problem and its generating parameters.

    Parameters
    ----------
    n_obs, n_params : observations per experiment and parameters.
    sd : noise sd used to simulate the data (and the known sd of the default noise model).
    noise : noise model for the likelihood (default ``GaussianNoise(sd=sd)``, known sd).
    box : uniform priors on ``[-box, box]`` for every parameter.
    n_experiments : experiments sharing the parameters (each with its own design and data).
    fail_above : the forward model fails (NaN) when the first parameter exceeds this.
    rng : seed or Generator.

    Returns
    -------
    problem : CalibrationProblem
    truth : (n_params,) ndarray
    """
    rng = np.random.default_rng(rng)
    truth = rng.normal(0.0, 1.0, n_params)
    t = np.linspace(0.0, 1.0, n_obs)
    specs = tuple(ParameterSpec(f"x{i}", "1", -box, box, prior="uniform", value=0.0) for i in range(n_params))
    material = ParameterSet(specs, {"model": "linear-Gaussian stand-in"})
    terms = []
    for k in range(n_experiments):
        design = np.column_stack([np.ones(n_obs)] + [np.cos((i + 1) * np.pi * t + k) for i in range(n_params - 1)])
        fwd = LinearForward(design, fail_above)
        y = design @ truth + sd * rng.standard_normal(n_obs)
        terms.append(ExperimentTerm(f"E{k + 1}", t, y, fwd, noise or GaussianNoise(sd=sd), {"synthetic": True}))
    return CalibrationProblem(terms, material), truth


def linear_gaussian_posterior(problem: CalibrationProblem) -> tuple[np.ndarray, np.ndarray]:
    """Exact posterior mean and covariance of a :func:`linear_gaussian_problem` with known sd.

    .. math:: \\Sigma^{-1} = \\sum_e A_e^T A_e / \\sigma_e^2, \\qquad
              m = \\Sigma \\sum_e A_e^T y_e / \\sigma_e^2
    """
    prec = 0.0
    rhs = 0.0
    for e in problem.experiments:
        a = np.asarray(e.forward.design)
        s2 = e.noise.sd**2
        prec = prec + a.T @ a / s2
        rhs = rhs + a.T @ e.observed / s2
    cov = np.linalg.inv(prec)
    return cov @ rhs, cov
