"""Deterministic warm start: the paper's bounded nonlinear least squares, multi-start, Wald
intervals.

The paper (Section 2.7, eq. 10-11) minimises

.. math:: F(\\alpha) = \\tfrac12 \\sum_{i} (\\varphi_i(\\alpha) - \\bar\\varphi_i)^2

over the box with Matlab's trust-region interior-reflective method, scaling each parameter by its
initial guess (Section 2.7.1: :math:`s_i = \\alpha^0_i`). :func:`fit_least_squares` is the same
method, :func:`bayestissue.inference.optimize.least_squares_trf` (scipy's trust-region reflective with
``x_scale=s`` and a batched forward-difference Jacobian, steps :math:`\\sqrt{\\epsilon}\\max(|x_i|, s_i)`).
At the optimum it reports the Gauss-Newton covariance and Wald intervals

.. math::

    \\hat\\Sigma = s^2 (J^T J)^{-1}, \\quad s^2 = \\frac{2 F(\\hat\\alpha)}{n - p}, \\qquad
    \\hat\\alpha_i \\pm z_{(1+c)/2} \\sqrt{\\hat\\Sigma_{ii}}
    \\quad\\text{(in } \\log\\alpha_i \\text{ for parameters whose box lies above 0)},

which are only meaningful for parameters away from the bounds and directions the data inform
(singular values of :math:`J` below ``rcond`` times the largest are clipped, giving huge but finite
variances).

:func:`fit_multistart` repeats the fit from a Latin hypercube of starts in the scaled box (the
sampler's :math:`u`-space) and clusters the optima by their cost. A start from which the fit cannot move
(no iteration: the gradient :math:`J^T r` vanishes there, as when a recruitment stretch lies beyond the
test's largest stretch so that no fibre carries load, or every forward solve near it fails) is replaced
by a uniform draw in the same box, at most ``max_redraws`` times per start; the result counts them.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy.stats import norm

from bayestissue._validation import ValidationError, check_interval
from bayestissue.inference.optimize import least_squares_trf
from bayestissue.inference.problem import CalibrationProblem

__all__ = [
    "LeastSquaresResult",
    "MultistartResult",
    "fit_least_squares",
    "wald_interval",
    "fit_multistart",
    "cluster_optima",
    "latin_hypercube",
]


@dataclass(frozen=True)
class LeastSquaresResult:
    """Outcome of one bounded least-squares fit of the sampled material parameters.

    Attributes
    ----------
    names : parameter names; x : estimate (natural units); x0 : start; x_scale : scaling used.
    cost : :math:`F = \\tfrac12 \\sum r^2` (scaled residuals); s2 : :math:`2F/(n-p)`.
    jac : (n_obs, p) Jacobian of the scaled residuals at ``x``; cov : Gauss-Newton covariance.
    wald_lower, wald_upper : Wald interval at ``level`` (of the logarithm, mapped back, for parameters whose box
    lies above 0: :func:`wald_interval`); active : (p,) int, -1 lower / +1 upper bound active.
    rank, cond : numerical rank and condition number of ``jac``.
    nit, nfev, njev, time_s, status, message : solver bookkeeping.
    history_scaled : (nit + 1, p) parameters divided by ``x_scale`` per iteration (paper Figs. 9,
    11);
    history_cost : (nit + 1,) cost per iteration.
    """

    names: tuple[str, ...]
    x: np.ndarray
    x0: np.ndarray
    x_scale: np.ndarray
    cost: float
    s2: float
    jac: np.ndarray
    cov: np.ndarray
    level: float
    wald_lower: np.ndarray
    wald_upper: np.ndarray
    active: np.ndarray
    rank: int
    cond: float
    nit: int
    nfev: int
    njev: int
    time_s: float
    status: int
    message: str
    history_scaled: np.ndarray
    history_cost: np.ndarray

    @property
    def sd(self) -> np.ndarray:
        """Wald standard errors :math:`\\sqrt{\\hat\\Sigma_{ii}}`."""
        return np.sqrt(np.clip(np.diag(self.cov), 0.0, None))

    def active_names(self) -> list[str]:
        """Parameters whose bound is active, as ``name (lower|upper)``."""
        return [
            f"{n} ({'lower' if a < 0 else 'upper'})" for n, a in zip(self.names, self.active, strict=False) if a != 0
        ]


def _dx_du(mat, u):
    """Derivative of the natural parameters with respect to the scaled box coordinates."""
    is_log = np.array([sp.scale == "log" for sp in mat.sampled])
    lo, hi = mat.lower, mat.upper
    x = mat.from_unit(u[None, :])[0]
    span = np.where(is_log, np.log(hi / np.where(is_log, lo, 1.0)), hi - lo)
    return span * np.where(is_log, x, 1.0)


def _covariance(jac, s2, rcond):
    _, s, vt = np.linalg.svd(jac, full_matrices=False)
    smax = s[0] if s.size else 0.0
    rank = int(np.count_nonzero(s > rcond * smax))
    cond = float(smax / s[-1]) if s.size and s[-1] > 0 else np.inf
    s_eff = np.maximum(s, rcond * smax if smax > 0 else 1.0)
    cov = s2 * (vt.T / s_eff**2) @ vt
    return cov, rank, cond


def wald_interval(x_hat, sd, z: float, *, positive) -> tuple[np.ndarray, np.ndarray]:
    r"""Wald intervals :math:`\hat\alpha_i \pm z\,\mathrm{sd}_i`; for a parameter whose box lies above 0
    (``positive``), the Wald interval of :math:`\log\alpha_i` mapped back (delta method,
    :math:`\mathrm{sd}(\log\alpha) = \mathrm{sd}(\alpha)/\hat\alpha`):
    :math:`\hat\alpha_i \exp(\pm z\,\mathrm{sd}_i/\hat\alpha_i)`, which stays positive (a linear interval gave
    mu in [-348, 348] kPa for an estimate at the lower bound 0.001)."""
    x_hat, sd = np.asarray(x_hat, dtype=float), np.asarray(sd, dtype=float)
    with np.errstate(over="ignore"):  # an unidentified parameter: the interval runs to 0 and inf
        factor = np.exp(z * sd / np.abs(x_hat))
        lower = np.where(positive, x_hat / factor, x_hat - z * sd)
        upper = np.where(positive, x_hat * factor, x_hat + z * sd)
    return lower, upper


def fit_least_squares(
    problem: CalibrationProblem,
    x0=None,
    *,
    x_scale="initial",
    level: float = 0.90,
    max_nfev: int | None = 2000,
    ftol: float = 1e-10,
    xtol: float = 1e-10,
    gtol: float = 1e-10,
    rcond: float = 1e-10,
    space: str = "natural",
    jacobian: str = "differences",
) -> LeastSquaresResult:
    """Fit the sampled material parameters by bounded trust-region-reflective least squares.

    Parameters
    ----------
    problem : CalibrationProblem
    x0 : (n_material,) array, optional
        Start (natural units); default the material parameters' initial values (the paper's guess).
    x_scale : "initial", "jac" or array
        ``"initial"``: :math:`s_i = |x^0_i|` (:math:`1` where :math:`|x^0_i| \\le \\epsilon`) as in
        paper Section 2.7.1; ``"jac"``: scipy's Jacobian-based scaling.
    level : coverage of the Wald intervals.
    max_nfev, ftol, xtol, gtol : passed to :func:`scipy.optimize.least_squares`.
    rcond : relative singular-value cut-off for the covariance.
    space : ``"natural"`` fits the parameters in their units with bounds (the paper's method);
        ``"unit"`` fits the scaled box coordinates :math:`u \\in [0, 1]` (log-scaled for the scale
        parameters, the sampler's scaling), which copes better with parameters spanning decades. The
        Jacobian, covariance and history are reported in natural units either way.
    jacobian : ``"differences"`` (batched forward differences, the default) or ``"exact"`` (the forward models'
        sensitivities, :meth:`CalibrationProblem.residual_jacobian`; chained to the scaled box for
        ``space="unit"``).

    Raises
    ------
    ValidationError
        If ``x0`` has the wrong length or lies outside the box.
    """
    level = check_interval("level", level, 0.0, 1.0, closed=(False, False))
    mat = problem.material
    names = mat.sampled_names
    lb, ub = mat.lower, mat.upper
    x0 = mat.initial if x0 is None else np.asarray(x0, dtype=float).ravel()
    if x0.shape != (len(names),):
        raise ValidationError("x0", f"shape {x0.shape}", f"shape ({len(names)},) for {names}")
    out = np.flatnonzero((x0 < lb) | (x0 > ub) | ~np.isfinite(x0))
    if out.size:
        i = out[0]
        raise ValidationError(f"initial guess {names[i]}", float(x0[i]), f"a value inside the box [{lb[i]}, {ub[i]}]")
    if space not in ("natural", "unit"):
        raise ValidationError("space", space, "'natural' (the paper) or 'unit' (scaled box)")
    if jacobian not in ("differences", "exact"):
        raise ValidationError("jacobian", jacobian, "'differences' or 'exact'")
    if jacobian == "exact" and not problem.has_sensitivities:
        raise ValidationError("jacobian", jacobian, "'differences' (some experiment has no exact sensitivities)")
    eps = np.finfo(float).eps
    paper_scale = np.where(np.abs(x0) > eps, np.abs(x0), 1.0)
    if isinstance(x_scale, str) and x_scale == "initial":
        scale = paper_scale if space == "natural" else np.ones_like(x0)
    elif isinstance(x_scale, str) and x_scale == "jac":
        scale = "jac"
    else:
        scale = np.asarray(x_scale, dtype=float)
        if scale.shape != x0.shape or np.any(~(scale > 0)):
            raise ValidationError("x_scale", x_scale, f"'initial', 'jac' or {len(names)} positive values")
    if space == "natural":
        to_x, v0, vlb, vub = (lambda v: v), x0, lb, ub
    else:
        to_x, v0 = mat.from_unit, mat.to_unit(x0)
        vlb, vub = np.zeros_like(x0), np.ones_like(x0)
    step = scale if not isinstance(scale, str) else np.ones_like(x0)

    def batch(v):
        return problem.residuals(to_x(v))

    def exact(v):
        x = to_x(v[None, :])
        jac_x = problem.residual_jacobian(x)[1][0]
        return jac_x if space == "natural" else jac_x * _dx_du(mat, v)[None, :]

    history, costs = [x0 / paper_scale], [0.5 * float(np.sum(batch(v0[None, :])[0] ** 2))]

    def callback(intermediate_result):
        history.append(to_x(np.asarray(intermediate_result.x)[None, :])[0] / paper_scale)
        costs.append(float(intermediate_result.cost))

    t0 = time.perf_counter()
    res = least_squares_trf(
        batch,
        v0,
        vlb,
        vub,
        rel_step=np.sqrt(np.finfo(float).eps),
        step_floor=step if space == "natural" else 1e-3 * step,
        x_scale=scale,
        jacobian=exact if jacobian == "exact" else None,
        max_nfev=max_nfev,
        ftol=ftol,
        xtol=xtol,
        gtol=gtol,
        callback=callback,
    )
    elapsed = time.perf_counter() - t0
    x_hat = to_x(res.x[None, :])[0]
    jac_x = res.jac
    if space == "unit":  # chain rule to natural units: J_x = J_v / (dx/dv)
        dxdv = _dx_du(mat, res.x)
        jac_x = res.jac / dxdv[None, :]
    n, p = res.fun.size, res.x.size
    s2 = 2.0 * float(res.cost) / max(n - p, 1)
    cov, rank, cond = _covariance(jac_x, s2, rcond)
    z = norm.ppf(0.5 + level / 2.0)
    sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    wald_lower, wald_upper = wald_interval(x_hat, sd, z, positive=lb > 0)
    return LeastSquaresResult(
        names=names,
        x=x_hat,
        x0=x0,
        x_scale=paper_scale,
        cost=float(res.cost),
        s2=s2,
        jac=jac_x,
        cov=cov,
        level=level,
        wald_lower=wald_lower,
        wald_upper=wald_upper,
        active=np.asarray(res.active_mask, dtype=int),
        rank=rank,
        cond=cond,
        nit=len(history) - 1,
        nfev=int(res.nfev),
        njev=int(res.njev or 0),
        time_s=elapsed,
        status=int(res.status),
        message=str(res.message),
        history_scaled=np.array(history),
        history_cost=np.array(costs),
    )


def latin_hypercube(n: int, d: int, *, rng=None) -> np.ndarray:
    """``n`` points of a Latin hypercube in :math:`[0, 1]^d` (one point per stratum in each
    dimension)."""
    rng = np.random.default_rng(rng)
    strata = np.column_stack([rng.permutation(n) for _ in range(d)])
    return (strata + rng.random((n, d))) / n


def cluster_optima(costs, *, cost_rtol: float = 1e-3) -> np.ndarray:
    """Label optima with the same cost (within ``cost_rtol`` relative) as one cluster, 0 = lowest
    cost.

    Costs must be sorted ascending. Optima of one cluster may still differ in parameters the data do
    not inform; :class:`MultistartResult` reports the spread within the best cluster.
    """
    costs = np.asarray(costs, dtype=float)
    labels = np.zeros(costs.size, dtype=int)
    ref, lab = costs[0] if costs.size else 0.0, 0
    for i, c in enumerate(costs):
        if abs(c - ref) > cost_rtol * max(abs(ref), 1e-300):
            lab += 1
            ref = c
        labels[i] = lab
    return labels


@dataclass(frozen=True)
class MultistartResult:
    """Fits from many starts, sorted by cost (``results[0]`` is the best)."""

    results: list[LeastSquaresResult]
    labels: np.ndarray
    time_s: float
    n_failed: int = 0
    names: tuple[str, ...] = field(default=())
    n_redrawn: int = 0

    @property
    def best(self) -> LeastSquaresResult:
        return self.results[0]

    @property
    def costs(self) -> np.ndarray:
        return np.array([r.cost for r in self.results])

    def best_cluster_spread(self, problem: CalibrationProblem) -> np.ndarray:
        """Range (max - min) of each parameter within the best cluster, in scaled-box units
        :math:`u`."""
        xs = np.array([r.x for r, lab in zip(self.results, self.labels, strict=False) if lab == 0])
        u = problem.material.to_unit(xs)
        return u.max(axis=0) - u.min(axis=0)


def fit_multistart(
    problem: CalibrationProblem,
    *,
    n_starts: int = 10,
    include_initial: bool = True,
    cost_rtol: float = 1e-3,
    rng=None,
    max_redraws: int = 30,
    progress: Callable[[int, int, LeastSquaresResult], None] | None = None,
    **options,
) -> MultistartResult:
    """Least squares from a Latin hypercube of starts in the scaled box, plus the paper's start.

    Parameters
    ----------
    n_starts : number of random starts (Latin hypercube in :math:`u`-space, the sampler's scaled
    box).
    include_initial : also start from the parameters' initial values (the paper's
    :math:`\\alpha^0`).
    cost_rtol : relative cost tolerance for :func:`cluster_optima`.
    rng : seed or Generator.
    max_redraws : random starts from which the fit made no iteration are replaced by uniform draws in the
        same box, at most this many times per start (the last such fit is kept); the paper's start is
        never replaced.
    progress : ``progress(k, n, result)`` after start ``k`` of ``n`` (from 1), for the kept fit.
    **options : passed to :func:`fit_least_squares` (``x_scale`` defaults to each start, as in the
    paper).
    """
    rng = np.random.default_rng(rng)
    if int(n_starts) < 0:
        raise ValidationError("n_starts", n_starts, "an integer >= 0")
    if int(max_redraws) < 0:
        raise ValidationError("max_redraws", max_redraws, "an integer >= 0")
    mat = problem.material
    u = latin_hypercube(int(n_starts), mat.n_sampled, rng=rng)
    u = 0.02 + 0.96 * u  # keep starts off the bounds
    starts = [(x, True) for x in mat.from_unit(u)] if n_starts else []
    if include_initial:
        starts.insert(0, (mat.initial, False))
    if not starts:
        raise ValidationError("n_starts", n_starts, "at least one start (or include_initial=True)")
    t0 = time.perf_counter()
    results, n_redrawn = [], 0
    for x0, random_start in starts:
        fit = fit_least_squares(problem, x0, **options)
        for _ in range(int(max_redraws) if random_start else 0):
            if fit.nit > 0:
                break
            n_redrawn += 1
            fit = fit_least_squares(problem, mat.from_unit(0.02 + 0.96 * rng.random((1, mat.n_sampled)))[0], **options)
        results.append(fit)
        if progress is not None:
            progress(len(results), len(starts), fit)
    results.sort(key=lambda r: r.cost)
    labels = cluster_optima([r.cost for r in results], cost_rtol=cost_rtol)
    return MultistartResult(
        results, labels, time.perf_counter() - t0, problem.n_failed, mat.sampled_names, n_redrawn=n_redrawn
    )
