"""The nested engine's peak reference: the runs' log-likelihood climbed from the least-squares optima.

:func:`~bayestissue.inference.evidence.assess_nested` checks that every run came within :math:`d/2` of the
likelihood's peak (a run whose bounds lost the peak region can end with a consistent-looking but wrong evidence).
Its reference must be the peak of the likelihood the runs sample, :func:`~bayestissue.inference.sampling.nested.
nested_target`'s, with each test's noise sd integrated out, whose per-test term is

.. math:: \\ln L_i = -\\tfrac{n_i}{2} \\ln \\mathrm{SSR}_i + \\text{const},

whereas least squares minimises :math:`\\sum_i \\mathrm{SSR}_i` over all tests in their own units. On one test the two
optima coincide (T1 mirror model: to 1e-8 nats). On several they do not: on T1 + T2 the mirror model's
least-squares optimum has log-likelihood 428.79 and a local search from it reaches 943.60 (2026-11-29), so a reference
taken at the optimum lay 515 nats low and the check could not fail. :func:`peak_reference` therefore climbs the
runs' likelihood from each least-squares optimum (Nelder-Mead, then Powell within the box, in the prior's box
coordinates) and takes the largest value met.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize

from bayestissue.inference.problem import CalibrationProblem
from bayestissue.inference.sampling.nested import NestedOptions, nested_target

__all__ = ["CLIMB_EVALUATIONS", "PeakReference", "climb_log_likelihood", "peak_log_likelihood", "peak_reference"]

#: Likelihood evaluations of each of :func:`climb_log_likelihood`'s two local searches.
CLIMB_EVALUATIONS = 4000


def peak_log_likelihood(problem: CalibrationProblem, options: NestedOptions, theta) -> float:
    """The runs' log-likelihood at a full ``theta`` (e.g. a least-squares optimum with its plug-in noise)."""
    return _at(nested_target(problem, options), theta)


def climb_log_likelihood(problem: CalibrationProblem, options: NestedOptions, theta) -> float:
    """The runs' log-likelihood climbed from ``theta`` by a local search in box coordinates :math:`u \\in [0, 1]^d`
    (0 at a parameter's lower bound, 1 at its upper, log scale where its prior is log-uniform): Nelder-Mead
    (adaptive, points clipped to the box), then Powell bounded by the box, :data:`CLIMB_EVALUATIONS` evaluations
    each; the value Powell ends at. The search runs over what the runs sample: the material parameters where the
    noise sds are integrated out, all of them (sds included) otherwise."""
    return _climb(problem, nested_target(problem, options), theta)


def _at(target, theta) -> float:
    """``target``'s (:func:`nested_target`'s) log-likelihood at a full ``theta``."""
    n_dim, _, log_l, _ = target
    return float(log_l(np.asarray(theta, dtype=float)[None, :n_dim])[0])


def _climb(problem: CalibrationProblem, target, theta) -> float:
    """:func:`climb_log_likelihood` on ``target`` (:func:`nested_target`'s)."""
    n, _, log_l, _ = target
    box = problem.material if n == problem.n_material else problem.parameters

    def minus_log_l(u):
        return -float(log_l(box.from_unit(np.clip(u, 0.0, 1.0))[None, :])[0])

    u = box.to_unit(np.asarray(theta, dtype=float)[:n])
    r = minimize(minus_log_l, u, method="Nelder-Mead",
                 options={"maxfev": CLIMB_EVALUATIONS, "xatol": 1e-8, "fatol": 1e-6, "adaptive": True})  # fmt: skip
    # A failed solve is -inf here. Powell's bounded line search (Brent) then fits its parabola through an infinite
    # value: the arithmetic gives NaN, every test against it is False and the search takes a golden-section step,
    # which is the right fallback; only numpy's warning about that NaN is silenced (filterwarnings = error in tests).
    with np.errstate(invalid="ignore"):
        r = minimize(minus_log_l, np.clip(r.x, 0.0, 1.0), method="Powell", bounds=[(0.0, 1.0)] * n,
                     options={"maxfev": CLIMB_EVALUATIONS, "xtol": 1e-8, "ftol": 1e-10})  # fmt: skip
    return -float(r.fun)


@dataclass(frozen=True)
class PeakReference:
    """The runs' log-likelihood at each least-squares optimum (``at_optima``) and climbed from it (``climbed``);
    ``value`` is the largest of them all, the peak check's reference."""

    at_optima: list[float]
    climbed: list[float]

    @property
    def value(self) -> float:
        return max(self.at_optima + self.climbed)

    def text(self) -> str:
        return (
            f"log-likelihood at the least-squares optima {', '.join(f'{v:.2f}' for v in self.at_optima)}, climbed to "
            f"{', '.join(f'{v:.2f}' for v in self.climbed)}: the peak check's reference {self.value:.2f}"
        )


def peak_reference(problem: CalibrationProblem, options: NestedOptions, thetas) -> PeakReference:
    """:class:`PeakReference` of the least-squares optima ``thetas`` (full parameter vectors, each with its plug-in
    noise sds: :meth:`~bayestissue.inference.problem.CalibrationProblem.nuisance_estimate`)."""
    thetas = list(thetas)
    target = nested_target(problem, options)  # one target for all: it is built afresh on each call
    return PeakReference(
        at_optima=[_at(target, t) for t in thetas],
        climbed=[_climb(problem, target, t) for t in thetas],
    )
