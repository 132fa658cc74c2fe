"""Test versus test: tension between experiments, cross-prediction coverage,
leave-one-experiment-out.

* Tension (a likelihood-ratio "goodness-of-fit loss", e.g. Raveri & Hu 2019,
  doi:10.1103/PhysRevD.99.043506): fitting experiments A and B with shared parameters instead of
  separately costs

  .. math:: Q = \\chi^2_{joint,min} - \\chi^2_{A,min} - \\chi^2_{B,min} \\ge 0,

  and under "same parameters" with Gaussian noise and locally linear models :math:`Q \\sim
  \\chi^2_{d}` with :math:`d` the number of shared parameters (an upper bound: parameters neither
  test informs add no freedom, so an effective :math:`d` = number of jointly informed directions is
  also reported by callers).
* Cross-prediction: the share of data points of one experiment inside the central ``level`` band of
  the posterior predictive built from the other experiment's posterior (model prediction plus
  Gaussian noise).
* Leave-one-experiment-out: :math:`\\mathrm{elpd} = \\log \\frac1S \\sum_s p(y_B \\mid \\theta_s)`
  with :math:`\\theta_s` from the posterior of A alone (exact), or by Pareto-smoothed importance
  sampling from the joint posterior (Vehtari, Gelman & Gabry 2017, doi:10.1007/s11222-016-9696-4)
  with the Pareto :math:`\\hat k` diagnostic (unreliable above 0.7).
"""

from __future__ import annotations

import numpy as np
from scipy.special import logsumexp
from scipy.stats import chi2 as _chi2

from bayestissue._validation import ValidationError, check_interval, check_positive

__all__ = [
    "tension",
    "predictive_band",
    "coverage",
    "gaussian_loglik",
    "log_predictive_density",
    "psis_leave_out",
]


def tension(chi2_joint: float, chi2_parts, n_shared: int) -> dict[str, float]:
    """Tension statistic :math:`Q = \\chi^2_{joint} - \\sum_k \\chi^2_k` and its p-value against
    :math:`\\chi^2_{d}`.

    Returns dict with ``Q``, ``df``, ``p_value`` and ``sigma`` (the equivalent two-sided normal
    deviation).
    """
    cj = float(chi2_joint)
    parts = np.asarray(chi2_parts, dtype=float)
    if not np.isfinite(cj) or parts.ndim != 1 or not np.all(np.isfinite(parts)):
        raise ValidationError("chi2", (chi2_joint, parts.tolist()), "finite chi-square values")
    d = int(n_shared)
    if d < 1:
        raise ValidationError("n_shared", n_shared, "an integer >= 1")
    Q = max(cj - float(parts.sum()), 0.0)
    p = float(_chi2.sf(Q, d))
    from scipy.stats import norm

    sigma = float(norm.isf(p / 2)) if p > 0 else float("inf")
    return {"Q": Q, "df": d, "p_value": p, "sigma": sigma}


def predictive_band(pred: np.ndarray, *, level: float = 0.9) -> tuple[np.ndarray, np.ndarray]:
    """Central ``level`` band (lower, upper), each (n_obs,), of predictive draws (n_draws,
    n_obs)."""
    check_interval("level", level, 0.0, 1.0, closed=(False, False))
    pred = np.asarray(pred, dtype=float)
    if pred.ndim != 2 or pred.shape[0] < 2:
        raise ValidationError("pred", pred.shape, "predictive draws of shape (n_draws, n_obs)")
    a = (1 - level) / 2
    return np.nanquantile(pred, a, axis=0), np.nanquantile(pred, 1 - a, axis=0)


def coverage(
    y_obs: np.ndarray,
    pred: np.ndarray,
    *,
    noise_sd: float | np.ndarray | None = None,
    level: float = 0.9,
    rng=None,
) -> float:
    """Share of observations inside the central ``level`` band of the posterior predictive.

    Parameters
    ----------
    y_obs : (n_obs,) observations.
    pred : (n_draws, n_obs) model predictions for posterior draws (rows with NaN are dropped).
    noise_sd : if given, Gaussian noise of this sd is added to each draw (the predictive of new
        data); if None, ``pred`` is taken to include the noise already.
    """
    rng = np.random.default_rng(rng)
    y = np.asarray(y_obs, dtype=float)
    pred = np.asarray(pred, dtype=float)
    if pred.ndim != 2 or pred.shape[1] != y.shape[0]:
        raise ValidationError("pred", pred.shape, f"(n_draws, {y.shape[0]}) matching y_obs")
    pred = pred[np.all(np.isfinite(pred), axis=1)]
    if noise_sd is not None:
        sd = np.broadcast_to(np.asarray(noise_sd, dtype=float), y.shape)
        pred = pred + rng.normal(size=pred.shape) * sd
    lo, hi = predictive_band(pred, level=level)
    return float(np.mean((y >= lo) & (y <= hi)))


def gaussian_loglik(y_obs: np.ndarray, pred: np.ndarray, noise_sd) -> np.ndarray:
    """Gaussian log-likelihood of ``y_obs`` for each row of ``pred`` (n_draws, n_obs); -inf for a
    NaN row."""
    y = np.asarray(y_obs, dtype=float)
    pred = np.atleast_2d(np.asarray(pred, dtype=float))
    sd = np.broadcast_to(np.asarray(noise_sd, dtype=float), y.shape)
    if np.any(~(sd > 0)):
        raise ValidationError("noise_sd", noise_sd, "positive standard deviations")
    r = (y - pred) / sd
    ll = -0.5 * np.sum(r * r, axis=1) - np.sum(np.log(sd)) - 0.5 * y.size * np.log(2 * np.pi)
    return np.where(np.all(np.isfinite(pred), axis=1), ll, -np.inf)


def log_predictive_density(loglik: np.ndarray) -> float:
    """:math:`\\log \\frac1S \\sum_s \\exp(\\ell_s)` of per-draw log-likelihoods (exact
    out-of-sample elpd)."""
    ll = np.asarray(loglik, dtype=float).ravel()
    if ll.size == 0:
        raise ValidationError("loglik", ll.shape, "at least one draw")
    return float(logsumexp(ll) - np.log(ll.size))


def psis_leave_out(loglik_left_out: np.ndarray, *, r_eff: float = 1.0) -> dict[str, float]:
    """PSIS estimate of the elpd of a left-out block from joint-posterior draws.

    The importance ratios :math:`1/p(y_B\\mid\\theta_s)` turn the joint posterior into the posterior
    without block B; Pareto smoothing (arviz ``psislw``) stabilises them.

    Returns dict with ``elpd`` and ``khat`` (the estimate is unreliable for ``khat > 0.7``).
    """
    check_positive("r_eff", r_eff)
    ll = np.asarray(loglik_left_out, dtype=float).ravel()
    if ll.size < 10 or not np.all(np.isfinite(ll)):
        raise ValidationError("loglik_left_out", f"{ll.size} values", "at least 10 finite log-likelihoods")
    import arviz as az

    lw, khat = az.psislw(-ll, reff=r_eff)
    lw = np.asarray(lw) - logsumexp(lw)
    return {"elpd": float(logsumexp(lw + ll)), "khat": float(np.asarray(khat))}
