r"""The exact population posterior of a Gaussian hierarchy: an independent check of the two-stage sampler.

When specimen :math:`i`'s stage-1 posterior of a population parameter is Gaussian on the population scale,
:math:`N(y_i, \sigma_i^2)` (flat stage-1 prior there), the model of :mod:`bayestissue.inference.hierarchy` for that
parameter is a Gaussian linear model: :math:`y_i \sim N(m + d_{g(i)}, s^2 + \sigma_i^2)` after the specimens'
:math:`z_i` are integrated out, with Gaussian priors on :math:`\beta = (m, d)`. Given :math:`s`, :math:`\beta` is
Gaussian (conjugate) and :math:`p(s \mid y)` is the prior times :math:`N(y \mid X b_0, X \Sigma_0 X^T + V_s)`; one
dimension, so quadrature on a grid gives every quantile of :math:`s`, and the quantiles of :math:`m` and :math:`d`
follow from the mixture of Gaussians over that grid. Nothing here is shared with the sampler.
"""

from __future__ import annotations

import numpy as np
from scipy import stats

__all__ = ["gaussian_population_quantiles"]


def gaussian_population_quantiles(y, sig, group_index, *, centre: float, width: float, sd_scale: float,
                                  effect_scale: float, qs=(0.05, 0.5, 0.95), s_max: float | None = None,
                                  n_grid: int = 4000) -> dict:  # fmt: skip
    """Quantiles ``qs`` of m, of each non-reference group's d (``d[g]``, g >= 1) and of s.

    y, sig : (I,) each specimen's stage-1 posterior mean and sd on the population scale; ``group_index`` (I,) 0 for
    the reference group. Priors as the sampler's: m ~ N(centre, width^2), d_g ~ N(0, effect_scale^2),
    s ~ half-normal(sd_scale).
    """
    y, sig, gi = np.asarray(y, float), np.asarray(sig, float), np.asarray(group_index)
    n_g = int(gi.max()) + 1
    X = np.zeros((y.size, n_g))
    X[:, 0] = 1.0
    for i, g in enumerate(gi):
        if g > 0:
            X[i, g] = 1.0
    b0 = np.r_[centre, np.zeros(n_g - 1)]
    S0 = np.diag(np.r_[width**2, np.full(n_g - 1, effect_scale**2)])
    S0i = np.linalg.inv(S0)
    grid = np.linspace(1e-5, s_max or 10.0 * sd_scale, n_grid)
    logp = np.empty(n_grid)
    means = np.empty((n_grid, n_g))
    sds = np.empty((n_grid, n_g))
    for k, s in enumerate(grid):
        V = np.diag(s**2 + sig**2)
        logp[k] = stats.multivariate_normal(X @ b0, X @ S0 @ X.T + V).logpdf(y) + stats.halfnorm(scale=sd_scale).logpdf(
            s
        )
        Vi = np.linalg.inv(V)
        Ai = np.linalg.inv(X.T @ Vi @ X + S0i)
        means[k] = Ai @ (X.T @ Vi @ y + S0i @ b0)
        sds[k] = np.sqrt(np.diag(Ai))
    w = np.exp(logp - logp.max())
    w /= w.sum()
    out = {"s": np.array([grid[min(np.searchsorted(np.cumsum(w), q), n_grid - 1)] for q in qs])}
    for c in range(n_g):
        lo = float(np.min(means[:, c] - 8 * sds[:, c]))
        hi = float(np.max(means[:, c] + 8 * sds[:, c]))
        xs = np.linspace(lo, hi, 6000)
        cdf = (w[:, None] * stats.norm.cdf(xs[None, :], means[:, c : c + 1], sds[:, c : c + 1])).sum(axis=0)
        out["m" if c == 0 else f"d[{c}]"] = np.array([xs[min(np.searchsorted(cdf, q), xs.size - 1)] for q in qs])
    return out
