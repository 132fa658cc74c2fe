"""Profiles of several parameters relative to the best optimum found.

A profile point that improves on the optimum restarts every profile from it (:func:`profile_all`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from bayestissue._validation import ValidationError, check_positive
from bayestissue.identifiability.profile import ProfileOptions, _validate, fit_residuals, profile_likelihood

__all__ = ["ProfileSet", "profile_all"]


@dataclass(frozen=True)
class ProfileSet:
    """Profiles of several parameters relative to one reference optimum (see :func:`profile_all`).

    ``profiles`` in the order of the requested indices, all relative to ``theta_hat`` with
    :math:`\\chi^2` ``chi2_min``; ``chi2_start`` the :math:`\\chi^2` of the optimum polished from the
    given start; ``n_restarts`` how often a profile point improved on the reference by more than
    ``improvement_tol`` and all parameters were re-optimised from it; ``improvements`` the decrease
    of :math:`\\chi^2` of each restart; ``restart_from`` the parameter whose profile gave each
    restart point; ``converged`` False if ``max_restarts`` was reached with a profile still below
    the reference; ``first_classifications`` the classifications of the first round (relative to
    the starting optimum), to show what the restarts changed.
    """

    profiles: tuple
    theta_hat: np.ndarray
    chi2_min: float
    chi2_start: float
    n_restarts: int = 0
    improvements: tuple = ()
    restart_from: tuple = ()
    converged: bool = True
    improvement_tol: float = 1e-3
    first_classifications: tuple = ()


def _serial_map(func, arg_list, kwargs):
    return [func(*a, **kwargs) for a in arg_list]


def profile_all(
    residuals: Callable[[np.ndarray], np.ndarray],
    theta_hat: Sequence[float],
    indices: Sequence[int] | None = None,
    *,
    lower: Sequence[float],
    upper: Sequence[float],
    names: Sequence[str] | None = None,
    log: bool | Sequence[bool] = True,
    batched: bool = False,
    options: ProfileOptions | None = None,
    max_restarts: int = 5,
    refit_nfev: int = 1000,
    map_fn: Callable | None = None,
) -> ProfileSet:
    """Profile likelihoods of ``indices`` relative to the global optimum, restarting the optimum
    when a profile finds a better one.

    Algorithm: polish ``theta_hat`` by TRF least squares over all parameters (reference
    :math:`\\hat\\theta_0`); profile every parameter relative to it (:func:`profile_likelihood`
    with ``polish=False``); if the lowest profile point :math:`\\theta^*` has :math:`\\chi^2(\\theta^*)
    < \\chi^2(\\hat\\theta_k) -` ``options.improvement_tol``, re-optimise all parameters from
    :math:`\\theta^*` (TRF, ``ftol=1e-10``, ``refit_nfev`` evaluations), take the result as
    :math:`\\hat\\theta_{k+1}` and recompute all profiles; stop when no profile improves on the
    reference or after ``max_restarts`` restarts. The CIs and classifications of the returned
    profiles are those of the last round, i.e. relative to the best optimum found.

    Parameters
    ----------
    residuals, theta_hat, lower, upper, names, log, batched, options : as for
        :func:`profile_likelihood`.
    indices : parameters to profile (default all).
    max_restarts : cap on the restarts (each one recomputes every profile).
    refit_nfev : evaluation cap of each full re-optimisation.
    map_fn : ``map_fn(func, arg_tuples, kwargs) -> list`` used to run the profiles of one round
        (default: serially here), e.g. a wrapper of :func:`bayestissue.parallel.fan_out` for dask
        and the content-hash cache; it must return ``[func(*a, **kwargs) for a in arg_tuples]``.

    Returns
    -------
    ProfileSet

    Raises
    ------
    ValidationError
        For bad ``theta_hat``/bounds (see :func:`profile_likelihood`), ``indices`` out of range or a
        negative ``max_restarts``.

    References
    ----------
    Raue A et al. (2009) Structural and practical identifiability analysis of partially observed
    dynamical models by exploiting the profile likelihood. Bioinformatics 25:1923-1929,
    doi:10.1093/bioinformatics/btp358.
    """
    opt = options or ProfileOptions()
    theta, lo, hi, lg = _validate(theta_hat, lower, upper, log)
    n = theta.size
    idx = list(range(n)) if indices is None else [int(i) for i in indices]
    if not idx or any(not 0 <= i < n for i in idx):
        raise ValidationError("indices", indices, f"integers in [0, {n - 1}]")
    if int(max_restarts) < 0:
        raise ValidationError("max_restarts", max_restarts, "an integer >= 0")
    check_positive("refit_nfev", refit_nfev)
    run = map_fn or _serial_map
    fit_kw = dict(lower=lo, upper=hi, log=lg, batched=batched, ftol=1e-10, max_nfev=int(refit_nfev))
    theta, chi2 = fit_residuals(residuals, theta, **fit_kw)
    chi2_start = chi2
    kw = dict(lower=lo, upper=hi, names=names, log=lg, batched=batched, options=opt, polish=False)
    improvements, sources, converged, first = [], [], True, None
    while True:
        profs = run(profile_likelihood, [(residuals, theta, i) for i in idx], kw)
        first = first or tuple(p.classification for p in profs)
        k_best = int(np.argmin([np.min(p.delta_chi2) for p in profs]))
        best = profs[k_best]
        j = int(np.argmin(best.delta_chi2))
        if best.delta_chi2[j] >= -opt.improvement_tol:
            break
        if len(improvements) >= int(max_restarts):
            converged = False
            break
        start = np.clip(best.thetas[j], lo, hi)
        theta_new, chi2_new = fit_residuals(residuals, start, **fit_kw)
        if not chi2_new <= chi2 + float(best.delta_chi2[j]):  # TRF only accepts decreasing steps
            theta_new, chi2_new = start, chi2 + float(best.delta_chi2[j])
        improvements.append(chi2 - chi2_new)
        sources.append(best.name)
        theta, chi2 = theta_new, chi2_new
    return ProfileSet(
        profiles=tuple(profs),
        theta_hat=theta,
        chi2_min=chi2,
        chi2_start=chi2_start,
        n_restarts=len(improvements),
        improvements=tuple(improvements),
        restart_from=tuple(sources),
        converged=converged,
        improvement_tol=opt.improvement_tol,
        first_classifications=first,
    )
