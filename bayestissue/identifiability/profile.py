"""Profile likelihood (Raue et al. 2009) with re-optimisation, and a bounded least-squares fit to
start from.

For scaled residuals :math:`r(\\theta) = (y_{obs} - y(\\theta))/\\sigma`, :math:`-2\\log L =
\\chi^2(\\theta) + c` with :math:`\\chi^2 = \\lVert r \\rVert^2`. The profile of parameter :math:`i`
is

.. math::

    \\mathrm{PL}_i(t) = \\min_{\\theta:\\ \\theta_i = t} \\chi^2(\\theta) - \\chi^2(\\hat\\theta),

computed by stepping :math:`t` away from the optimum in both directions (in log space for positive
parameters) and re-optimising the other parameters with the trust-region-reflective method (the
method the paper used; :func:`bayestissue.inference.optimize.least_squares_trf`, the warm start's
routine), warm-started from the previous step. The likelihood-based confidence interval is
:math:`\\{t: \\mathrm{PL}_i(t) < \\Delta\\}` with :math:`\\Delta = \\chi^2_{1,0.95} = 3.84` (pointwise,
Raue et al. 2009, doi:10.1093/bioinformatics/btp358).

Classification (Raue et al. 2009):

* identifiable: the profile exceeds :math:`\\Delta` on both sides within the bounds;
* practically non-identifiable: it stays below :math:`\\Delta` on one or both sides up to the bound
  (open);
* structurally non-identifiable: it is flat, :math:`\\max_t \\mathrm{PL}_i(t) <` ``flat_tol`` over
  the whole range explored (a redundant parametrisation, or no influence on the data at all).

A profile is only meaningful relative to the *global* optimum: a profile point with
:math:`\\mathrm{PL}_i(t) < 0` is a better optimum the starting fit had missed. :func:`profile_all`
therefore profiles every parameter, and while any point lies more than ``improvement_tol`` below
the reference it re-optimises all parameters from the lowest such point (TRF), makes that the new
reference and recomputes every profile (at most ``max_restarts`` times); the number of restarts
and the decrease of :math:`\\chi^2` are returned with the profiles.

A simulation that fails (NaN) gives residuals of ``nan_residual`` each, so the optimiser backs off.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from bayestissue._validation import ValidationError, check_positive
from bayestissue.inference.optimize import least_squares_trf

__all__ = [
    "ProfileOptions",
    "ProfileResult",
    "fit_residuals",
    "profile_likelihood",
    "classify_profile",
    "CHI2_1_95",
]

#: :math:`\chi^2_1` 95 % quantile, the profile threshold of Raue et al. (2009).
CHI2_1_95 = 3.841458820694124


@dataclass(frozen=True)
class ProfileOptions:
    """Options of :func:`profile_likelihood` (steps are in the transformed space: log for
    ``log=True``).

    ``improvement_tol`` (in :math:`\\chi^2 = -2\\log L` units): a profile point more than this below
    the reference optimum counts as a better optimum (``ProfileResult.improved``; a restart in
    :func:`profile_all`). The default 1e-3 is 1/3800 of the 3.84 threshold, so a smaller dip cannot
    move a confidence limit or a classification noticeably, and it is far above the rounding error
    of :math:`\\chi^2` (about :math:`10^{-16}\\chi^2`, < 1e-10 for the :math:`\\chi^2 < 10^5` here).
    """

    threshold: float = CHI2_1_95
    step0: float = 0.05
    min_step: float = 1e-3
    max_step: float = 1.0
    max_steps: int = 40
    stop_factor: float = 1.5
    flat_tol: float = 0.05
    nan_residual: float = 1e3
    ftol: float = 1e-10
    max_nfev: int = 400
    improvement_tol: float = 1e-3

    def __post_init__(self):
        for f in (
            "improvement_tol",
            "threshold",
            "step0",
            "min_step",
            "max_step",
            "stop_factor",
            "flat_tol",
            "nan_residual",
        ):
            check_positive(f, getattr(self, f))
        if not self.min_step <= self.step0 <= self.max_step:
            raise ValidationError(
                "step0",
                self.step0,
                f"min_step <= step0 <= max_step ({self.min_step}, {self.max_step})",
            )
        if int(self.max_steps) < 1:
            raise ValidationError("max_steps", self.max_steps, "an integer >= 1")


@dataclass(frozen=True)
class ProfileResult:
    """A profile: ``values`` of the parameter (natural units, ascending), ``delta_chi2`` and the
    other parameters.

    ``ci`` is the 95 % likelihood interval (NaN on an open side); ``classification`` one of
    ``"identifiable"``, ``"practically non-identifiable"``, ``"structurally non-identifiable"``;
    ``open_sides`` a pair of bools (lower, upper); ``chi2_min`` the optimum's chi-square;
    ``improved`` True if the profile found a chi-square more than ``options.improvement_tol``
    below the optimum it started from (the reference was not the global optimum).
    """

    name: str
    index: int
    values: np.ndarray
    delta_chi2: np.ndarray
    thetas: np.ndarray = field(repr=False)
    theta_hat: float = float("nan")
    chi2_min: float = float("nan")
    ci: tuple[float, float] = (float("nan"), float("nan"))
    open_sides: tuple[bool, bool] = (True, True)
    classification: str = ""
    improved: bool = False


def _as_bool_mask(log, n):
    m = np.broadcast_to(np.asarray(log, dtype=bool), (n,)).copy()
    return m


class _Problem:
    """Residuals in the transformed space z (log for masked parameters); :meth:`fit` minimises over
    some coordinates with :func:`~bayestissue.inference.optimize.least_squares_trf` (difference step
    :math:`10^{-6}\\max(1, |z_k|)`)."""

    def __init__(self, residuals, lower, upper, log, batched, nan_residual):
        self.residuals, self.batched, self.nan = residuals, batched, nan_residual
        self.log = log
        self.lo = self.to_z(lower)
        self.hi = self.to_z(upper)

    def to_theta(self, z):
        z = np.asarray(z, dtype=float)
        return np.where(self.log, np.exp(np.where(self.log, z, 0.0)), z)

    def to_z(self, theta):
        theta = np.asarray(theta, dtype=float)
        return np.where(self.log, np.log(np.where(self.log, theta, 1.0)), theta)

    def _clean(self, r):
        r = np.asarray(r, dtype=float)
        return np.where(np.isfinite(r), r, self.nan)

    def res(self, z):
        return self._clean(self.residuals(self.to_theta(z)))

    def res_many(self, Z):
        if self.batched:
            return self._clean(self.residuals(self.to_theta(Z)))
        return np.stack([self.res(z) for z in Z])

    def fit(self, z0, free, *, ftol, max_nfev):
        """Minimise over the ``free`` coordinates of z, the others fixed at z0."""
        z0 = np.asarray(z0, dtype=float)
        if not np.any(free):
            r = self.res(z0)
            return z0, float(r @ r)
        idx = np.flatnonzero(free)
        lo, hi = self.lo[idx], self.hi[idx]
        start = np.clip(z0[idx], lo + 1e-12 * (hi - lo), hi - 1e-12 * (hi - lo))

        def batch(X):
            Z = np.repeat(z0[None, :], X.shape[0], axis=0)
            Z[:, idx] = X
            return self.res_many(Z)

        sol = least_squares_trf(
            batch, start, lo, hi, rel_step=1e-6, step_floor=1.0, ftol=ftol, xtol=ftol, gtol=ftol, max_nfev=max_nfev
        )
        z = z0.copy()
        z[idx] = sol.x
        return z, float(2 * sol.cost)


def _validate(theta, lower, upper, log):
    theta = np.asarray(theta, dtype=float)
    lower = np.broadcast_to(np.asarray(lower, dtype=float), theta.shape)
    upper = np.broadcast_to(np.asarray(upper, dtype=float), theta.shape)
    if theta.ndim != 1 or not np.all(np.isfinite(theta)):
        raise ValidationError("theta", theta.tolist(), "a 1-D array of finite parameters")
    if np.any(lower >= upper) or np.any(theta < lower) or np.any(theta > upper):
        raise ValidationError(
            "theta",
            theta.tolist(),
            "values inside lower < upper bounds",
            f"lower={lower.tolist()}, upper={upper.tolist()}",
        )
    log = _as_bool_mask(log, theta.size)
    if np.any(log & (lower <= 0)):
        raise ValidationError("lower", lower.tolist(), "positive lower bounds for log-transformed parameters")
    return theta, lower, upper, log


def fit_residuals(
    residuals: Callable[[np.ndarray], np.ndarray],
    theta0: Sequence[float] | np.ndarray,
    *,
    lower: Sequence[float],
    upper: Sequence[float],
    log: bool | Sequence[bool] = True,
    batched: bool = False,
    fixed: Sequence[bool] | None = None,
    ftol: float = 1e-10,
    max_nfev: int = 1000,
) -> tuple[np.ndarray, float]:
    """Bounded least squares (trust-region reflective) from one or several starts; the best is
    returned.

    Parameters
    ----------
    residuals : ``residuals(theta) -> (n_obs,)`` scaled residuals; with ``batched`` it also takes
        ``(n_sets, n_par) -> (n_sets, n_obs)`` (used for the finite-difference Jacobian in one
        call).
    theta0 : (n_par,) or (n_starts, n_par) starting points.
    lower, upper : bounds; log : which parameters are optimised in log space.
    fixed : parameters kept at their start value.

    Returns
    -------
    theta : (n_par,) best optimum; chi2 : its :math:`\\lVert r \\rVert^2`.
    """
    starts = np.atleast_2d(np.asarray(theta0, dtype=float))
    best = (None, np.inf)
    for t0 in starts:
        t0, lo, hi, lg = _validate(t0, lower, upper, log)
        prob = _Problem(residuals, lo, hi, lg, batched, 1e3)
        free = np.ones(t0.size, bool) if fixed is None else ~np.asarray(fixed, dtype=bool)
        z, c2 = prob.fit(prob.to_z(t0), free, ftol=ftol, max_nfev=max_nfev)
        if c2 < best[1]:
            best = (prob.to_theta(z), c2)
    return best


def classify_profile(
    delta_chi2_lower, delta_chi2_upper, *, threshold: float = CHI2_1_95, flat_tol: float = 0.05
) -> tuple[str, tuple[bool, bool]]:
    """Classify a profile from its lower-side and upper-side values (relative to the optimum).

    Returns the classification and ``open_sides`` = (lower side never exceeds threshold, upper side
    never does).
    """
    lo = np.asarray(delta_chi2_lower, dtype=float)
    hi = np.asarray(delta_chi2_upper, dtype=float)
    open_lo = not (lo.size and np.nanmax(lo) > threshold)
    open_hi = not (hi.size and np.nanmax(hi) > threshold)
    allv = np.concatenate([lo, hi])
    if allv.size == 0 or np.nanmax(np.abs(allv)) < flat_tol:
        return "structurally non-identifiable", (True, True)
    if not open_lo and not open_hi:
        return "identifiable", (False, False)
    return "practically non-identifiable", (open_lo, open_hi)


def _crossing(t, d, thr):
    """First t (moving away from the optimum) where the piecewise-linear profile d crosses thr."""
    for k in range(1, len(t)):
        if d[k] > thr >= d[k - 1]:
            w = (thr - d[k - 1]) / (d[k] - d[k - 1])
            return t[k - 1] + w * (t[k] - t[k - 1])
    return float("nan")


def profile_likelihood(
    residuals: Callable[[np.ndarray], np.ndarray],
    theta_hat: Sequence[float],
    index: int,
    *,
    lower: Sequence[float],
    upper: Sequence[float],
    names: Sequence[str] | None = None,
    log: bool | Sequence[bool] = True,
    batched: bool = False,
    options: ProfileOptions | None = None,
    polish: bool = True,
) -> ProfileResult:
    """Profile likelihood of parameter ``index`` around the optimum ``theta_hat``.

    Parameters
    ----------
    residuals : scaled residuals ``(n_par,) -> (n_obs,)`` (and batched, see
        :func:`fit_residuals`).
    theta_hat : (n_par,) the least-squares optimum (re-polished here before profiling unless
        ``polish=False``, which :func:`profile_all` uses so that all profiles share one reference).
    index : which parameter to profile.
    lower, upper : bounds of all parameters (the profile runs up to them).
    names : parameter names (for the result).
    log : which parameters are stepped and optimised in log space.
    options : :class:`ProfileOptions`.
    polish : re-optimise ``theta_hat`` before profiling (else :math:`\\chi^2(\\hat\\theta)` is the
        reference as given).

    Returns
    -------
    ProfileResult

    Notes
    -----
    A single profile does not restart when it finds a better optimum (``improved``); use
    :func:`profile_all` for profiles relative to the global optimum.

    Step control: the step (in the transformed space) doubles while the profile rises by less than
    ``0.1 threshold`` per step and halves (down to ``min_step``) when it rises by more than
    ``0.5 threshold``; a side stops once the profile exceeds ``stop_factor * threshold``, at
    the bound, or after ``max_steps``.
    """
    opt = options or ProfileOptions()
    theta_hat, lo, hi, lg = _validate(theta_hat, lower, upper, log)
    n = theta_hat.size
    if not 0 <= int(index) < n:
        raise ValidationError("index", index, f"an integer in [0, {n - 1}]")
    index = int(index)
    names = tuple(names) if names is not None else tuple(f"p{j}" for j in range(n))
    prob = _Problem(residuals, lo, hi, lg, batched, opt.nan_residual)
    free = np.ones(n, bool)
    free[index] = False
    z_hat = prob.to_z(theta_hat)
    if polish:
        z_hat, chi2_min = prob.fit(z_hat, np.ones(n, bool), ftol=opt.ftol, max_nfev=opt.max_nfev)
    else:
        r_hat = prob.res(z_hat)
        chi2_min = float(r_hat @ r_hat)
    thr = opt.threshold
    sides = {}
    for direction in (-1.0, 1.0):
        bound = prob.lo[index] if direction < 0 else prob.hi[index]
        ts, cs, zs = [], [], []
        z_prev, d_prev, step = z_hat.copy(), 0.0, opt.step0
        for _ in range(int(opt.max_steps)):
            t_prev = z_prev[index]
            if abs(bound - t_prev) <= 1e-12:
                break
            t = t_prev + direction * step
            if (t - bound) * direction > 0:
                t = bound
            z0 = z_prev.copy()
            z0[index] = t
            z, c2 = prob.fit(z0, free, ftol=opt.ftol, max_nfev=opt.max_nfev)
            d = c2 - chi2_min
            if d - d_prev > 0.5 * thr and step > opt.min_step:
                step = max(step / 2, opt.min_step)
                continue
            rise = d - d_prev
            ts.append(t)
            cs.append(d)
            zs.append(z)
            z_prev, d_prev = z, d
            if d > opt.stop_factor * thr:
                break
            if rise < 0.1 * thr:
                step = min(2 * step, opt.max_step)
        sides[direction] = (np.array(ts), np.array(cs), np.array(zs).reshape(-1, n))
    t_lo, d_lo, z_lo = sides[-1.0]
    t_hi, d_hi, z_hi = sides[1.0]
    t_all = np.concatenate([t_lo[::-1], [z_hat[index]], t_hi])
    d_all = np.concatenate([d_lo[::-1], [0.0], d_hi])
    z_all = np.concatenate([z_lo[::-1], z_hat[None, :], z_hi])
    improved = bool(d_all.min() < -opt.improvement_tol)
    cls, open_sides = classify_profile(d_lo, d_hi, threshold=thr, flat_tol=opt.flat_tol)
    c_lo = _crossing(np.concatenate([[z_hat[index]], t_lo]), np.concatenate([[0.0], d_lo]), thr)
    c_hi = _crossing(np.concatenate([[z_hat[index]], t_hi]), np.concatenate([[0.0], d_hi]), thr)
    to_nat = (lambda v: np.exp(v)) if lg[index] else (lambda v: v)
    return ProfileResult(
        name=names[index],
        index=index,
        values=to_nat(t_all),
        delta_chi2=d_all,
        thetas=prob.to_theta(z_all),
        theta_hat=float(to_nat(z_hat[index])),
        chi2_min=chi2_min,
        ci=(float(to_nat(c_lo)), float(to_nat(c_hi))),
        open_sides=open_sides,
        classification=cls,
        improved=improved,
    )
