r"""Does a posterior fit its data, or does it fit by inflating its noise? A posterior predictive check per experiment.

A posterior can meet every convergence rule and still describe its data badly: with the noise sd sampled, a model
that cannot follow a curve widens the sd until the misfit looks like noise (the joint T1 + T2 run of the replicas:
sd 0.39 mm against a true 0.02 mm). Its contraction and KL then measure how a wrong model is constrained, not what
the data say. Three numbers per experiment, from the results file alone (observed data, posterior predictive, noise
sd draws):

* **noise ratio** :math:`\hat\sigma_{post} / \hat\sigma_{data}`: the posterior median noise sd against an estimate
  from the data alone, the difference-based estimator :math:`\hat\sigma_{data} = 1.4826\,\mathrm{MAD}(d) /
  \sqrt{6}` with :math:`d_i = y_{i+1} - 2 y_i + y_{i-1}` (for independent noise on a smooth curve sampled densely,
  :math:`\mathrm{Var}\, d = 6 \sigma^2`; the median absolute deviation ignores the few points where the curve bends
  sharply, e.g. at a load step). Rice (1984), Ann. Statist. 12:1215; Gasser, Sroka & Jennen-Steinmetz (1986),
  Biometrika 73:625.
* **lag-1 autocorrelation** of the residuals :math:`r = y - \tilde u` about the posterior median prediction
  :math:`\tilde u`: :math:`\rho_1 = \sum r_i r_{i+1} / \sum r_i^2`. Independent noise gives
  :math:`\rho_1 \approx N(0, 1/n)` (sd 0.084 at n = 143): a systematic misfit shows as long runs.
* **coverage**: the share of data inside the central 90 % posterior predictive band (model plus noise draws).

Rule (:func:`fit_check`): **MISFIT** if the noise ratio exceeds :data:`MAX_NOISE_RATIO` (the posterior's noise
variance four times the data's) or :math:`\rho_1 >` :data:`MAX_LAG1` (6 sd of white noise at n = 143, 10 at n =
401); otherwise FITS. A data estimate is only as good as the sampling is dense: on a coarsely sampled curve the
second differences carry curvature and :math:`\hat\sigma_{data}` is too large, which errs towards FITS.
"""

from __future__ import annotations

import numpy as np

__all__ = ["MAX_NOISE_RATIO", "MAX_LAG1", "data_noise_sd", "lag1_autocorrelation", "fit_check", "fit_check_text"]

#: A posterior noise sd more than this times the data's own estimate is a misfit.
MAX_NOISE_RATIO = 2.0
#: A residual lag-1 autocorrelation above this is a misfit.
MAX_LAG1 = 0.5


def data_noise_sd(y) -> float:
    """Difference-based noise sd of a densely sampled smooth curve: 1.4826 MAD of the second differences / sqrt(6)."""
    d = np.diff(np.asarray(y, dtype=float), 2)
    return float(1.4826 * np.median(np.abs(d - np.median(d))) / np.sqrt(6.0))


def lag1_autocorrelation(r) -> float:
    """:math:`\\sum r_i r_{i+1} / \\sum r_i^2` of residuals ``r`` (NaN if they are all zero)."""
    r = np.asarray(r, dtype=float)
    den = float(np.sum(r * r))
    return float(np.sum(r[1:] * r[:-1]) / den) if den > 0 else float("nan")


def fit_check(idata) -> dict[str, dict]:
    """The check of the module docstring for every experiment of a results file (``idata``: the groups
    ``observed_data``, ``posterior_predictive`` with ``<exp>`` and ``<exp>_model``, and the noise sd
    ``sigma_<exp>`` in ``posterior``, as written by :func:`bayestissue.inference.posterior.to_inference_data`).

    Returns, per experiment, ``noise_data``, ``noise_posterior`` (None where the sd is not sampled: then no
    ratio), ``noise_ratio``, ``lag1``, ``coverage``, ``n`` and ``misfit`` (bool), with ``reasons``; empty if the
    file has no posterior predictive.
    """
    out = {}
    if not all(hasattr(idata, g) for g in ("observed_data", "posterior_predictive", "posterior")):
        return out
    pp = idata.posterior_predictive
    for name in idata.observed_data.data_vars:
        y = np.asarray(idata.observed_data[name], dtype=float).ravel()
        model = np.asarray(pp[f"{name}_model"], dtype=float).reshape(-1, y.size)
        noisy = np.asarray(pp[name], dtype=float).reshape(-1, y.size)
        model, noisy = model[np.all(np.isfinite(model), axis=1)], noisy[np.all(np.isfinite(noisy), axis=1)]
        lo, hi = np.quantile(noisy, [0.05, 0.95], axis=0)
        sd_key = f"sigma_{name}"
        sd_post = float(np.median(idata.posterior[sd_key])) if sd_key in idata.posterior else None
        sd_data = data_noise_sd(y)
        ratio = sd_post / sd_data if sd_post is not None and sd_data > 0 else None
        rho = lag1_autocorrelation(y - np.median(model, axis=0))
        reasons = []
        if ratio is not None and ratio > MAX_NOISE_RATIO:
            reasons.append(f"noise sd {ratio:.3g} x the data's")
        if rho > MAX_LAG1:
            reasons.append(f"residual lag-1 autocorrelation {rho:.2f}")
        out[name] = {
            "noise_data": sd_data,
            "noise_posterior": sd_post,
            "noise_ratio": ratio,
            "lag1": rho,
            "coverage": float(np.mean((y >= lo) & (y <= hi))),
            "n": int(y.size),
            "misfit": bool(reasons),
            "reasons": reasons,
        }
    return out


def fit_check_text(check: dict[str, dict]) -> str:
    """One line: ``MISFIT: T2 noise sd 19.5 x the data's, ...`` or ``FITS: T1 noise ratio 0.96, lag-1 0.03, ...``."""
    if not check:
        return "NOT CHECKED (no posterior predictive in the results file)"
    bad = [f"{k} {', '.join(v['reasons'])}" for k, v in check.items() if v["misfit"]]
    parts = []
    for k, v in check.items():
        ratio = "n/a" if v["noise_ratio"] is None else f"{v['noise_ratio']:.2f}"
        parts.append(f"{k} noise ratio {ratio}, lag-1 {v['lag1']:.2f}, 90 % band {100 * v['coverage']:.0f} %")
    head = f"MISFIT: {'; '.join(bad)}" if bad else "FITS"
    return f"{head} ({'; '.join(parts)}; rule: noise ratio <= {MAX_NOISE_RATIO:g}, lag-1 <= {MAX_LAG1:g})"
