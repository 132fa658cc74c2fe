"""Gaussian noise sds integrated out analytically: the likelihood of the material parameters alone.

For an experiment with independent Gaussian residuals :math:`r` (:math:`n` of them, :math:`S = \\sum r_t^2`) and an
unknown sd :math:`\\sigma` with the box prior :math:`p(\\sigma) = c\\,\\sigma^{-k}` on :math:`[a, b]`
(log-uniform: :math:`k = 1`, :math:`c = 1/\\log(b/a)`; uniform: :math:`k = 0`, :math:`c = 1/(b - a)`), the
substitution :math:`t = S / (2\\sigma^2)` gives

.. math::

    L_m = \\int_a^b (2\\pi\\sigma^2)^{-n/2} e^{-S/(2\\sigma^2)}\\, p(\\sigma)\\, d\\sigma
        = \\frac{c}{2}\\, (2\\pi)^{-n/2} \\left(\\frac S2\\right)^{-\\nu} \\Gamma(\\nu)
          \\left[P(\\nu, t_a) - P(\\nu, t_b)\\right],
    \\qquad \\nu = \\frac{n + k - 1}{2},\\; t_a = \\frac{S}{2a^2},\\; t_b = \\frac{S}{2b^2},

with :math:`P` the regularised lower incomplete gamma function: exact, the box truncation included. So
:math:`\\int L(\\theta, \\sigma) p(\\theta) p(\\sigma) = \\int L_m(\\theta) p(\\theta)`: the evidence is unchanged,
and a sampler of :math:`\\theta` alone no longer has to follow the sharp ridge between :math:`\\sigma` and the
residual sum of squares (where nautilus's bounds were measured to cut the posterior; docs/verification.md). Given
:math:`\\theta`, :math:`t` is Gamma(:math:`\\nu`) truncated to :math:`[t_b, t_a]`, so :math:`\\sigma` is drawn
exactly by inverting :math:`P`: the pairs :math:`(\\theta, \\sigma)` then follow the joint posterior.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.special import gammainc, gammaincc, gammaincinv, gammaln

from bayestissue.inference.likelihood import GaussianNoise

__all__ = ["can_marginalise", "log_marginal_gaussian", "draw_sd", "MarginalNoise"]


def _shape(n: int, prior: str) -> tuple[float, float]:
    """(k, nu) of the sd prior ``prior``."""
    k = 1.0 if prior == "loguniform" else 0.0
    return k, 0.5 * (n + k - 1.0)


def _log_upper(nu: float, t: np.ndarray) -> np.ndarray:
    """:math:`\\log Q(\\nu, t)`, also where :math:`Q` underflows: there (:math:`t > \\nu + 1`) Legendre's continued
    fraction :math:`Q = e^{-t} t^\\nu / \\Gamma(\\nu) \\cdot 1/(t + 1 - \\nu - 1(1 - \\nu)/(t + 3 - \\nu - \\dots))`,
    evaluated by the modified Lentz method (Press et al., Numerical Recipes, 3rd ed., 6.2)."""
    t = np.asarray(t, dtype=float)
    with np.errstate(divide="ignore"):
        out = np.log(gammaincc(nu, t))
    bad = ~(out > -690.0) & (t > nu + 1.0)
    if np.any(bad):
        x = t[bad]
        tiny = 1e-300
        b = x + 1.0 - nu
        c = np.full_like(x, 1.0 / tiny)
        d = 1.0 / b
        h = d.copy()
        for i in range(1, 300):
            an = -i * (i - nu)
            b = b + 2.0
            d = an * d + b
            d = np.where(np.abs(d) < tiny, tiny, d)
            c = b + an / c
            c = np.where(np.abs(c) < tiny, tiny, c)
            d = 1.0 / d
            delta = d * c
            h = h * delta
            if np.all(np.abs(delta - 1.0) < 1e-15):
                break
        out[bad] = -x + nu * np.log(x) - gammaln(nu) + np.log(h)
    return out


def _log_lower(nu: float, t: np.ndarray) -> np.ndarray:
    """:math:`\\log P(\\nu, t)`, also where :math:`P` underflows (small :math:`t`): the series
    :math:`P = e^{-t} t^\\nu / \\Gamma(\\nu + 1) \\sum_j t^j / ((\\nu + 1) \\cdots (\\nu + j))`."""
    t = np.asarray(t, dtype=float)
    with np.errstate(divide="ignore"):
        out = np.log(gammainc(nu, t))
    bad = ~(out > -690.0) & (t < nu)
    if np.any(bad):
        x = t[bad]
        term = np.ones_like(x)
        total = np.ones_like(x)
        for j in range(1, 500):
            term = term * x / (nu + j)
            total = total + term
            if np.all(term < 1e-16 * total):
                break
        with np.errstate(divide="ignore"):
            out[bad] = -x + nu * np.log(x) - gammaln(nu + 1.0) + np.log(total)
    return out


def _log_box_mass(nu: float, t_hi: np.ndarray, t_lo: np.ndarray) -> np.ndarray:
    """:math:`\\log(P(\\nu, t_{hi}) - P(\\nu, t_{lo}))` for :math:`t_{lo} < t_{hi}`, through whichever tail does
    not round to one."""
    with np.errstate(divide="ignore", invalid="ignore"):
        upper_tail = t_lo > nu  # both in the upper tail: Q(t_lo) - Q(t_hi)
        qa, qb = _log_upper(nu, t_lo), _log_upper(nu, t_hi)
        pa, pb = _log_lower(nu, t_hi), _log_lower(nu, t_lo)
        via_q = qa + np.log1p(-np.exp(np.minimum(qb - qa, 0.0)))
        via_p = pa + np.log1p(-np.exp(np.minimum(pb - pa, 0.0)))
    return np.where(upper_tail, via_q, via_p)


def log_marginal_gaussian(rss, n: int, lower: float, upper: float, prior: str = "loguniform") -> np.ndarray:
    """:math:`\\log L_m` for residual sums of squares ``rss`` ``(n_sets,)`` of ``n`` observations (module
    equation), accurate also where the box holds a vanishing share of the conditional (residuals far larger or
    smaller than the box allows; the incomplete gamma tails are taken in log space); ``-inf`` for a non-finite
    ``rss``."""
    rss = np.asarray(rss, dtype=float)
    k, nu = _shape(n, prior)
    log_c = -math.log(math.log(upper / lower)) if k == 1.0 else -math.log(upper - lower)
    with np.errstate(divide="ignore", invalid="ignore"):
        mass = _log_box_mass(nu, rss / (2.0 * lower**2), rss / (2.0 * upper**2))
        out = log_c - 0.5 * n * math.log(2.0 * math.pi) - math.log(2.0) - nu * np.log(0.5 * rss) + gammaln(nu) + mass
    return np.where(np.isfinite(out), out, -np.inf)


def draw_sd(rss, n: int, lower: float, upper: float, prior: str = "loguniform", *, rng=None) -> np.ndarray:
    """One :math:`\\sigma` per residual sum of squares from :math:`p(\\sigma \\mid S)` on the box (module)."""
    rng = np.random.default_rng(rng)
    rss = np.asarray(rss, dtype=float)
    _, nu = _shape(n, prior)
    p_lo = gammainc(nu, rss / (2.0 * upper**2))
    p_hi = gammainc(nu, rss / (2.0 * lower**2))
    t = gammaincinv(nu, p_lo + rng.random(rss.shape) * (p_hi - p_lo))
    return np.clip(np.sqrt(rss / (2.0 * np.maximum(t, 1e-300))), lower, upper)


def can_marginalise(problem) -> bool:
    """True if ``problem`` samples at least one noise sd and every nuisance parameter it samples is the unknown sd
    of Gaussian noise (AR(1) and Student-t noise keep their nuisance parameters sampled)."""
    found = False
    for k, e in enumerate(problem.experiments):
        sl = problem.nuisance_slice(k)
        if sl.stop == sl.start:
            continue
        if not (type(e.noise) is GaussianNoise and e.noise.sd is None and sl.stop - sl.start == 1):
            return False
        found = True
    return found


class MarginalNoise:
    """The likelihood of the sampled material parameters with every sampled Gaussian sd integrated out, and the
    draw of the sds that completes a material sample to a joint one."""

    def __init__(self, problem):
        self.problem = problem
        self._sd = {}  # experiment index -> (column in theta, lower, upper, prior)
        for k in range(len(problem.experiments)):
            sl = problem.nuisance_slice(k)
            if sl.stop > sl.start:
                spec = problem.parameters.sampled[sl.start]
                self._sd[k] = (sl.start, spec.lower, spec.upper, spec.prior)

    def log_likelihood(self, theta_material) -> np.ndarray:
        """:math:`\\sum_e \\log L_{m,e}` (known-sd experiments: their ordinary Gaussian log-likelihood),
        ``(n_sets,)``; ``-inf`` for a failed solve."""
        problem = self.problem
        tm = np.atleast_2d(np.asarray(theta_material, dtype=float))
        preds = problem.predict_material(tm)
        total = np.zeros(tm.shape[0])
        for k, (e, pred) in enumerate(zip(problem.experiments, preds, strict=True)):
            r = pred - e.observed
            if k in self._sd:
                _, lo, hi, prior = self._sd[k]
                total += log_marginal_gaussian(np.sum(r**2, axis=1), e.observed.size, lo, hi, prior)
            else:
                with np.errstate(invalid="ignore", over="ignore"):
                    total += e.noise.loglik_pointwise(r, np.zeros((r.shape[0], 0))).sum(axis=1)
        return np.where(np.isfinite(total), total, -np.inf)

    def complete(self, theta_material, *, rng=None) -> np.ndarray:
        """Full ``theta`` ``(n_sets, ndim)``: the material parameters and one sd per experiment drawn from its
        conditional posterior."""
        rng = np.random.default_rng(rng)
        problem = self.problem
        tm = np.atleast_2d(np.asarray(theta_material, dtype=float))
        theta = np.empty((tm.shape[0], problem.ndim))
        theta[:, : problem.n_material] = tm
        preds = problem.predict_material(tm)
        for k, (col, lo, hi, prior) in self._sd.items():
            e = problem.experiments[k]
            rss = np.sum((preds[k] - e.observed) ** 2, axis=1)
            theta[:, col] = draw_sd(rss, e.observed.size, lo, hi, prior, rng=rng)
        return theta
