"""What the data taught: posterior-versus-prior measures in the sampled space, and overlap between
posteriors.

All functions take draws as ``(n_draws, n_par)`` arrays in the space the sampler works in (e.g.
log-parameters), where a uniform-in-log prior is flat and the measures below are comparable between
parameters.

* contraction (Schoot et al.; Betancourt 2018 "posterior z-score/contraction"): :math:`c_j = 1 -
  \\operatorname{var}_{post}(\\theta_j)/\\operatorname{var}_{prior}(\\theta_j)`, 0 for an uninformed
  parameter, near 1 for a well-determined one;
* information gain :math:`\\mathrm{KL}(p_{post}\\,\\|\\,p_{prior}) = \\int
  p_{post}\\log(p_{post}/p_{prior})` of each marginal (nats), by histogram;
* mass piled against a bound;
* Bhattacharyya coefficient :math:`BC = \\int \\sqrt{p q}` between two marginals (1: identical, 0:
  disjoint);
* principal angles between subspaces (Björck & Golub 1973, doi:10.1090/S0025-5718-1973-0348991-3);
* Monte Carlo error of any of these by batch means over contiguous blocks of the (ordered) draws,
  and a test "posterior = prior" whose tolerance is that error (:func:`uninformed_mc`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
from scipy.linalg import subspace_angles

from bayestissue._validation import ValidationError

__all__ = [
    "contraction",
    "kl_divergence",
    "correlation_matrix",
    "bound_flags",
    "bhattacharyya",
    "principal_angles",
    "uninformed",
    "batch_means",
    "uninformed_mc",
]


def _draws(name, x) -> np.ndarray:
    a = np.asarray(x, dtype=float)
    if a.ndim == 1:
        a = a[:, None]
    if a.ndim != 2 or a.shape[0] < 2 or not np.all(np.isfinite(a)):
        raise ValidationError(name, f"array of shape {np.shape(x)}", "finite draws of shape (n_draws, n_par)")
    return a


def contraction(
    post: np.ndarray, prior: np.ndarray | None = None, *, prior_var: Sequence[float] | None = None
) -> np.ndarray:
    """Posterior contraction :math:`1 - \\operatorname{var}_{post}/\\operatorname{var}_{prior}` per
    parameter.

    Parameters
    ----------
    post : (n_draws, n_par) posterior draws.
    prior : (m_draws, n_par) prior draws, or
    prior_var : (n_par,) prior variances (e.g. :math:`(b-a)^2/12` for a uniform prior on [a, b]).
    """
    p = _draws("post", post)
    if prior_var is not None:
        var_prior = np.asarray(prior_var, dtype=float)
    elif prior is not None:
        var_prior = _draws("prior", prior).var(axis=0, ddof=1)
    else:
        raise ValidationError("prior", None, "prior draws or prior_var")
    if var_prior.shape != (p.shape[1],) or np.any(~(var_prior > 0)):
        raise ValidationError("prior_var", var_prior.tolist(), f"{p.shape[1]} positive prior variances")
    return 1.0 - p.var(axis=0, ddof=1) / var_prior


def _bins(x, n_bins):
    lo, hi = float(np.min(x)), float(np.max(x))
    if hi <= lo:
        hi = lo + 1e-12 * max(1.0, abs(lo))
    return np.linspace(lo, hi, n_bins + 1)


def kl_divergence(
    post: np.ndarray,
    prior: np.ndarray | None = None,
    *,
    prior_logpdf: Callable[[np.ndarray], np.ndarray] | Sequence[Callable] | None = None,
    n_bins: int | None = None,
) -> np.ndarray:
    """Marginal information gain :math:`\\mathrm{KL}(p_{post}\\,\\|\\,p_{prior})` per parameter, in
    nats.

    Histogram plug-in estimate on ``n_bins`` equal bins spanning the posterior draws (default
    :math:`\\lfloor\\sqrt{n}/2\\rfloor` clipped to [10, 80]): :math:`\\sum_b P_b \\log(P_b / Q_b)`
    with :math:`P_b` the posterior share of bin :math:`b` and :math:`Q_b` the prior mass of the bin,
    from ``prior_logpdf`` (midpoint rule; one callable per parameter or one for all) or from prior
    draws (with a half-count floor). The estimate is biased upwards by about
    :math:`(n_{bins}-1)/(2n)` for an uninformed parameter.
    """
    p = _draws("post", post)
    n, k = p.shape
    nb = int(n_bins) if n_bins is not None else int(np.clip(np.sqrt(n) / 2, 10, 80))
    if nb < 2:
        raise ValidationError("n_bins", n_bins, "an integer >= 2")
    if prior is None and prior_logpdf is None:
        raise ValidationError("prior", None, "prior draws or prior_logpdf")
    q = _draws("prior", prior) if prior is not None else None
    if q is not None and q.shape[1] != k:
        raise ValidationError("prior", q.shape, f"(m_draws, {k}) draws")
    out = np.empty(k)
    for j in range(k):
        edges = _bins(p[:, j], nb)
        P = np.histogram(p[:, j], edges)[0] / n
        if prior_logpdf is not None:
            f = prior_logpdf[j] if isinstance(prior_logpdf, Sequence) else prior_logpdf
            mid = 0.5 * (edges[1:] + edges[:-1])
            Q = np.exp(np.asarray(f(mid), dtype=float)) * np.diff(edges)
        else:
            cnt = np.histogram(q[:, j], edges)[0].astype(float)
            Q = np.maximum(cnt, 0.5) / q.shape[0]
        m = P > 0
        out[j] = float(np.sum(P[m] * np.log(P[m] / Q[m])))
    return out


def correlation_matrix(post: np.ndarray) -> np.ndarray:
    """Pearson correlation matrix (n_par, n_par) of the draws."""
    p = _draws("post", post)
    sd = p.std(axis=0)
    c = np.corrcoef(p, rowvar=False) if np.all(sd > 0) else np.full((p.shape[1],) * 2, np.nan)
    return np.atleast_2d(c)


def bound_flags(
    post: np.ndarray,
    lower: Sequence[float],
    upper: Sequence[float],
    *,
    edge: float = 0.02,
    min_share: float = 0.05,
) -> dict[str, np.ndarray]:
    """Flag posterior mass piled against a bound.

    The share of draws in the outer ``edge`` fraction of the range at each bound is compared with
    ``min_share``; an uninformed (prior-like, flat) marginal puts about ``edge`` there, so with the
    defaults a flag means at least 2.5 times that much.

    Returns ------- dict with ``share_lower``, ``share_upper`` (n_par,) floats and ``at_lower``,
    ``at_upper`` (n_par,) bools.
    """
    p = _draws("post", post)
    lo = np.broadcast_to(np.asarray(lower, dtype=float), (p.shape[1],))
    hi = np.broadcast_to(np.asarray(upper, dtype=float), (p.shape[1],))
    if np.any(hi <= lo):
        raise ValidationError("upper", hi.tolist(), "bounds above the lower bounds")
    if not 0 < edge < 0.5:
        raise ValidationError("edge", edge, "a fraction in (0, 0.5)")
    w = hi - lo
    s_lo = np.mean(p < lo + edge * w, axis=0)
    s_hi = np.mean(p > hi - edge * w, axis=0)
    return {
        "share_lower": s_lo,
        "share_upper": s_hi,
        "at_lower": s_lo > min_share,
        "at_upper": s_hi > min_share,
    }


def bhattacharyya(a: np.ndarray, b: np.ndarray, *, n_bins: int = 60) -> np.ndarray:
    """Bhattacharyya coefficient :math:`\\sum_b \\sqrt{P_b Q_b}` per parameter between two sets of
    draws.

    Histograms on ``n_bins`` common bins spanning both sets. For two normals :math:`BC =
    \\sqrt{2\\sigma_1\\sigma_2/(\\sigma_1^2+\\sigma_2^2)}\\exp(-(m_1-m_2)^2/(4(\\sigma_1^2+\\sigma_2^2)))`.
    """
    A, B = _draws("a", a), _draws("b", b)
    if A.shape[1] != B.shape[1]:
        raise ValidationError("b", B.shape, f"draws of {A.shape[1]} parameters like a")
    out = np.empty(A.shape[1])
    for j in range(A.shape[1]):
        edges = _bins(np.concatenate([A[:, j], B[:, j]]), n_bins)
        P = np.histogram(A[:, j], edges)[0] / A.shape[0]
        Q = np.histogram(B[:, j], edges)[0] / B.shape[0]
        out[j] = float(np.sum(np.sqrt(P * Q)))
    return out


def principal_angles(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Principal angles (degrees, ascending) between the column spaces of ``A`` (n, k) and ``B`` (n,
    l).

    0 degrees: a direction both inform; 90: directions one informs and the other does not see at
    all.
    """
    A = np.asarray(A, dtype=float)
    B = np.asarray(B, dtype=float)
    if A.ndim != 2 or B.ndim != 2 or A.shape[0] != B.shape[0] or min(A.shape[1], B.shape[1]) == 0:
        raise ValidationError("A, B", (A.shape, B.shape), "non-empty (n, k) and (n, l) matrices")
    return np.sort(np.degrees(subspace_angles(A, B)))


def uninformed(
    post: np.ndarray,
    prior: np.ndarray,
    *,
    max_contraction: float = 0.1,
    max_kl: float = 0.1,
    prior_logpdf=None,
) -> np.ndarray:
    """Bool per parameter: posterior = prior within tolerance (contraction and KL both small)."""
    c = contraction(post, prior)
    kl = kl_divergence(post, prior, prior_logpdf=prior_logpdf)
    return (np.abs(c) < max_contraction) & (kl < max_kl)


def batch_means(post: np.ndarray, statistic: Callable[[np.ndarray], np.ndarray], *, n_batches: int = 10) -> dict:
    """Monte Carlo error and first-order bias of a statistic of MCMC draws, by batch means.

    The draws, in sampling order (ensemble, step, walker, possibly thinned), are cut into
    ``n_batches`` = :math:`B` contiguous batches of :math:`m = n/B` draws; :math:`s_b` is the
    statistic of batch :math:`b` and :math:`s` that of all draws. With batches longer than the
    autocorrelation time the :math:`s_b` are nearly independent (Flegal & Jones 2010,
    doi:10.1214/10-AOS735), so

    .. math::

        \\mathrm{se}(s) = \frac{\\operatorname{sd}(s_b)}{\\sqrt{B}}, \\qquad
        \\mathrm{bias}(s) \approx \frac{\bar s_b - s}{B - 1},

    the bias formula holding for a statistic whose bias is :math:`\\propto 1/n` (a plug-in histogram
    KL: :math:`(n_{bins}-1)/(2 n_{eff})`; a variance of autocorrelated draws), since each batch then
    carries :math:`B` times the bias of the pool (the jackknife argument with batches).

    Returns
    -------
    dict with ``estimate`` :math:`s`, ``corrected`` :math:`s - \\mathrm{bias}`, ``bias``, ``se``
    (each (n_par,)) and ``batches`` (B, n_par).
    """
    p = _draws("post", post)
    B = int(n_batches)
    if B < 2 or p.shape[0] < 2 * B:
        raise ValidationError("n_batches", n_batches, f"an integer in [2, n_draws/2 = {p.shape[0] // 2}]")
    est = np.asarray(statistic(p), dtype=float)
    sb = np.array([np.asarray(statistic(b), dtype=float) for b in np.array_split(p, B)])
    bias = (sb.mean(axis=0) - est) / (B - 1)
    return {
        "estimate": est,
        "corrected": est - bias,
        "bias": bias,
        "se": sb.std(axis=0, ddof=1) / np.sqrt(B),
        "batches": sb,
    }


def uninformed_mc(
    post: np.ndarray,
    *,
    prior_var: Sequence[float],
    prior_logpdf: Callable[[np.ndarray], np.ndarray] | Sequence[Callable],
    n_bins: int = 30,
    n_batches: int = 10,
    level: float = 0.99,
) -> dict:
    """Test "posterior = prior" per parameter with a tolerance set by the Monte Carlo error.

    For contraction :math:`c` and KL divergence, :func:`batch_means` gives the bias-corrected
    estimates :math:`\tilde c, \\widetilde{KL}` and their errors; with
    :math:`t = t_{B-1}((1+\\mathrm{level})/2)` (3.25 for B = 10 and level 0.99), a parameter is
    uninformed if

    .. math::

        |\tilde c| \\le t\\,\\mathrm{se}(c) \\quad\text{and}\\quad
        \\widetilde{KL} \\le t\\,\\mathrm{se}(KL),

    i.e. neither measure differs from its prior value 0 by more than the chains can resolve. A
    short chain thus passes more easily than a long one: the test answers "can these draws tell
    the posterior from the prior", not "are they equal".

    Returns
    -------
    dict of (n_par,) arrays: ``contraction``, ``kl`` (plain estimates), ``contraction_corrected``,
    ``kl_corrected``, ``se_contraction``, ``se_kl``, ``tol_contraction``, ``tol_kl`` (t se) and
    ``uninformed`` (bool); plus ``t`` and ``n_batches``.
    """
    from scipy.stats import t as student_t

    if not 0 < level < 1:
        raise ValidationError("level", level, "a probability in (0, 1)")
    c = batch_means(post, lambda x: contraction(x, prior_var=prior_var), n_batches=n_batches)
    k = batch_means(post, lambda x: kl_divergence(x, prior_logpdf=prior_logpdf, n_bins=n_bins), n_batches=n_batches)
    t = float(student_t.ppf((1 + level) / 2, int(n_batches) - 1))
    tol_c, tol_k = t * c["se"], t * k["se"]
    return {
        "contraction": c["estimate"],
        "kl": k["estimate"],
        "contraction_corrected": c["corrected"],
        "kl_corrected": k["corrected"],
        "se_contraction": c["se"],
        "se_kl": k["se"],
        "tol_contraction": tol_c,
        "tol_kl": tol_k,
        "uninformed": (np.abs(c["corrected"]) <= tol_c) & (k["corrected"] <= tol_k),
        "t": t,
        "n_batches": int(n_batches),
    }
