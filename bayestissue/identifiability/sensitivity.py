"""Local identifiability at a point estimate: scaled sensitivities, their SVD, and collinearity
indices.

The observations :math:`y_i(\\theta)` (``n_obs``) depend on positive parameters :math:`\\theta_j`.
The scaled sensitivity matrix uses log-parameters and the noise standard deviation
:math:`\\sigma_i`,

.. math:: S_{ij} = \\frac{1}{\\sigma_i} \\frac{\\partial y_i}{\\partial \\log \\theta_j},

so that :math:`S^T S` is the Fisher information of :math:`\\log\\theta` under Gaussian noise and a
singular value :math:`s_k \\approx 1` means the data pin the combination :math:`v_k^T \\log\\theta`
to about :math:`\\pm 1/s_k` (a factor :math:`e^{1/s_k}`). Small singular values are "sloppy"
directions (Gutenkunst et al. 2007, doi:10.1371/journal.pcbi.0030189).

Collinearity (Brun, Reichert & Kuensch 2001, doi:10.1029/2000WR900350): with the columns normalised
to unit length, :math:`\\tilde s_j = s_j / \\lVert s_j \\rVert`, a parameter subset :math:`K` has

.. math:: \\gamma_K = \\frac{1}{\\sqrt{\\lambda_{\\min}(\\tilde S_K^T \\tilde S_K)}},

the factor by which a relative change of one parameter can be compensated by the others of
:math:`K`. Brun et al. call a subset poorly identifiable above a critical value of about 10-15
(default here 10). A parameter with zero sensitivity gets :math:`\\gamma = \\infty` in every subset
containing it. Their importance measure is :math:`\\delta^{msqr}_j = \\lVert s_j \\rVert /
\\sqrt{n_{obs}}`.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from bayestissue._validation import ValidationError, check_positive

__all__ = [
    "ZERO_TOL",
    "scaled_sensitivities",
    "SensitivityAnalysis",
    "analyse_sensitivities",
    "collinearity_index",
    "collinearity_table",
    "largest_identifiable_subsets",
    "informed_directions",
]


#: A column whose norm is below ZERO_TOL times the largest column norm counts as zero sensitivity
#: (finite-difference round-off would otherwise give it a random direction after normalisation).
ZERO_TOL = 1e-8


def scaled_sensitivities(
    predict: Callable[[np.ndarray], np.ndarray],
    theta: Sequence[float],
    *,
    noise_sd: float | np.ndarray,
    rel_step: float = 1e-4,
    batched: bool = True,
) -> np.ndarray:
    """Scaled sensitivities :math:`S_{ij} = \\sigma_i^{-1} \\partial y_i / \\partial
    \\log\\theta_j`.

    Central differences in :math:`\\log\\theta` with step ``rel_step`` (second-order accurate).

    Parameters
    ----------
    predict : ``predict(thetas) -> (n_sets, n_obs)`` for ``thetas`` of shape ``(n_sets, n_par)``
        when ``batched`` (one call for all ``2 n_par`` perturbed sets), else ``predict(theta) ->
        (n_obs,)``.
    theta : (n_par,) positive parameter values.
    noise_sd : scalar or (n_obs,) positive noise standard deviations.
    rel_step : step in log-parameter.

    Returns
    -------
    S : (n_obs, n_par) ndarray.

    Raises ------ ValidationError for non-positive parameters, noise or step, or a prediction that
    is not finite.
    """
    theta = np.asarray(theta, dtype=float)
    if theta.ndim != 1 or not np.all(np.isfinite(theta)) or np.any(theta <= 0):
        raise ValidationError("theta", theta.tolist(), "a 1-D array of finite positive parameters")
    h = check_positive("rel_step", rel_step)
    n = theta.size
    lt = np.log(theta)
    sets = np.repeat(lt[None, :], 2 * n, axis=0)
    sets[np.arange(n), np.arange(n)] += h
    sets[n + np.arange(n), np.arange(n)] -= h
    thetas = np.exp(sets)
    if batched:
        y = np.asarray(predict(thetas), dtype=float)
    else:
        y = np.stack([np.asarray(predict(t), dtype=float) for t in thetas])
    if y.ndim != 2 or y.shape[0] != 2 * n:
        raise ValidationError("predict output", y.shape, f"shape ({2 * n}, n_obs)")
    if not np.all(np.isfinite(y)):
        bad = sorted({int(i) % n for i in np.flatnonzero(~np.all(np.isfinite(y), axis=1))})
        raise ValidationError("predict output", f"non-finite for parameters {bad}", "finite predictions")
    sd = np.broadcast_to(np.asarray(noise_sd, dtype=float), (y.shape[1],))
    if np.any(~np.isfinite(sd)) or np.any(sd <= 0):
        raise ValidationError("noise_sd", noise_sd, "positive finite noise standard deviations")
    return ((y[:n] - y[n:]) / (2 * h)).T / sd[:, None]


def collinearity_index(S: np.ndarray, subset: Sequence[int] | None = None) -> float:
    """Brun et al. (2001) collinearity index :math:`\\gamma_K` of the columns ``subset`` of ``S``
    (all if None).

    Returns ``inf`` if a column is zero or the normalised columns are exactly dependent.
    """
    S = np.asarray(S, dtype=float)
    cols = list(range(S.shape[1])) if subset is None else list(subset)
    if len(cols) < 1:
        raise ValidationError("subset", cols, "at least one column index")
    Sk = S[:, cols]
    norms = np.linalg.norm(Sk, axis=0)
    if np.any(norms <= ZERO_TOL * max(np.linalg.norm(S, axis=0).max(), 1e-300)):
        return float("inf")
    Sn = Sk / norms
    lam = np.linalg.eigvalsh(Sn.T @ Sn)[0]
    if lam <= 1e-14 * len(cols):
        return float("inf")
    return float(1.0 / np.sqrt(lam))


def collinearity_table(
    S: np.ndarray, *, min_size: int = 2, max_size: int | None = None
) -> list[tuple[tuple[int, ...], float]]:
    """Collinearity index of every subset of columns of size ``min_size`` .. ``max_size`` (default
    all).

    Returns a list of ``(subset, gamma)`` in order of size, then lexicographic. 11 parameters give
    2036 subsets of size >= 2; each costs one small symmetric eigenvalue problem.
    """
    S = np.asarray(S, dtype=float)
    n = S.shape[1]
    max_size = n if max_size is None else int(max_size)
    if not 1 <= min_size <= max_size <= n:
        raise ValidationError("min_size/max_size", (min_size, max_size), f"1 <= min_size <= max_size <= {n}")
    norms = np.linalg.norm(S, axis=0)
    norms = np.where(norms <= ZERO_TOL * max(norms.max(), 1e-300), 0.0, norms)
    Sn = np.divide(S, norms, out=np.zeros_like(S), where=norms > 0)
    G = Sn.T @ Sn
    out = []
    for k in range(min_size, max_size + 1):
        for sub in itertools.combinations(range(n), k):
            if np.any(norms[list(sub)] == 0):
                out.append((sub, float("inf")))
                continue
            lam = np.linalg.eigvalsh(G[np.ix_(sub, sub)])[0]
            out.append((sub, float("inf") if lam <= 1e-14 * k else float(1 / np.sqrt(lam))))
    return out


def largest_identifiable_subsets(
    table: list[tuple[tuple[int, ...], float]],
    *,
    threshold: float = 10.0,
    singles: Sequence[int] = (),
) -> list[tuple[tuple[int, ...], float]]:
    """The largest subsets whose collinearity index is below ``threshold`` (ties: all, lowest gamma
    first).

    ``singles`` are the parameters usable on their own (non-zero sensitivity), used when no pair
    qualifies.
    """
    check_positive("threshold", threshold)
    ok = [(s, g) for s, g in table if g < threshold]
    if not ok:
        return [((j,), 1.0) for j in singles]
    kmax = max(len(s) for s, _ in ok)
    return sorted([(s, g) for s, g in ok if len(s) == kmax], key=lambda t: t[1])


def informed_directions(S: np.ndarray, *, threshold: float = 1.0) -> np.ndarray:
    """Orthonormal basis (n_par, k) of the log-parameter directions with singular value >
    ``threshold``.

    With the default 1, a direction is informed when the data alone determine it to better than a
    factor e.
    """
    _, s, vt = np.linalg.svd(np.asarray(S, dtype=float), full_matrices=False)
    return vt[s > threshold].T


@dataclass(frozen=True)
class SensitivityAnalysis:
    """The local identifiability of one experiment (or several stacked) at ``theta``.

    Attributes
    ----------
    names : parameter names.
    theta : (n_par,) point of the analysis.
    S : (n_obs, n_par) scaled sensitivities.
    singular_values : (n_par,) descending.
    directions : (n_par, n_par) rows are the right singular vectors (parameter combinations in log
        space).
    delta_msqr : (n_par,) Brun's importance measure.
    std_error_log : (n_par,) Gauss-Newton standard errors of log theta (inf without sensitivity, about
        1e6 / s_max in an exactly degenerate combination).
    collinearity : list of (subset of names, gamma).
    threshold : critical collinearity index.
    largest_subsets : largest subsets with gamma < threshold (names).
    """

    names: tuple[str, ...]
    theta: np.ndarray
    S: np.ndarray
    singular_values: np.ndarray
    directions: np.ndarray
    delta_msqr: np.ndarray
    std_error_log: np.ndarray
    collinearity: list = field(repr=False)
    threshold: float = 10.0
    largest_subsets: list = field(default_factory=list)

    @property
    def condition_number(self) -> float:
        s = self.singular_values
        return float(s[0] / s[-1]) if s[-1] > 0 else float("inf")

    def sloppiest(self, k: int = 1) -> list[dict[str, float]]:
        """The ``k`` least determined parameter combinations, as {name: weight} (weights |w| >
        0.1)."""
        out = []
        for row in self.directions[::-1][:k]:
            out.append({n: float(w) for n, w in zip(self.names, row, strict=True) if abs(w) > 0.1})
        return out

    def gamma(self, subset: Sequence[str]) -> float:
        """Collinearity index of a subset given by names."""
        idx = [self.names.index(n) for n in subset]
        return collinearity_index(self.S, idx)


def analyse_sensitivities(
    S: np.ndarray,
    theta: Sequence[float],
    names: Sequence[str],
    *,
    threshold: float = 10.0,
    max_size: int | None = None,
) -> SensitivityAnalysis:
    """SVD, importance, standard errors, all-subset collinearity and largest identifiable subsets of
    ``S``."""
    S = np.asarray(S, dtype=float)
    names = tuple(names)
    if S.ndim != 2 or S.shape[1] != len(names):
        raise ValidationError("S", S.shape, f"shape (n_obs, {len(names)}) matching names")
    _, s, vt = np.linalg.svd(S, full_matrices=False)
    norms = np.linalg.norm(S, axis=0)
    norms = np.where(norms <= ZERO_TOL * max(norms.max(), 1e-300), 0.0, norms)
    # Gauss-Newton sd of log theta. A zero column has no information (inf); exactly degenerate combinations
    # get a sd of about 1e6 / s_max from a tiny ridge (1e-12 s_max^2) instead of pinv's silent zero.
    live = norms > 0
    se = np.full(len(names), np.inf)
    if np.any(live):
        Fl = S[:, live].T @ S[:, live]
        ridge = 1e-12 * max(s[0] ** 2, 1e-300)
        cov = np.linalg.inv(Fl + ridge * np.eye(Fl.shape[0]))
        se[live] = np.sqrt(np.clip(np.diag(cov), 0, None))
    table = collinearity_table(S, max_size=max_size)
    singles = [j for j in range(len(names)) if norms[j] > 0]
    best = largest_identifiable_subsets(table, threshold=threshold, singles=singles)
    return SensitivityAnalysis(
        names=names,
        theta=np.asarray(theta, dtype=float),
        S=S,
        singular_values=s,
        directions=vt,
        delta_msqr=norms / np.sqrt(S.shape[0]),
        std_error_log=se,
        collinearity=[(tuple(names[i] for i in sub), g) for sub, g in table],
        threshold=threshold,
        largest_subsets=[(tuple(names[i] for i in sub), g) for sub, g in best],
    )
