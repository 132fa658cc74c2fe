r"""Uncertainty of stereological estimates, done right for systematic samples.

Volume fractions
    Resampling the sections of ONE systematic sample as if they were independent
    (:func:`naive_section_bootstrap`) overestimates the sampling error several-fold; no unbiased
    variance estimator exists from one systematic sample (Cochran 1977, ch. 8). It is kept only as a
    labelled comparison. The defensible alternatives here: :func:`parametric_fraction_bootstrap`,
    driven by the predicted SURS covariance
    (:func:`bayestissue.stereology.sections.fraction_covariance`), drawing fractions jointly on the
    simplex by a logistic-normal distribution, and :func:`cluster_fraction_bootstrap` over genuinely
    independent units (blocks, animals).

Directions
    :func:`bootstrap_cells` resamples whole traced cells (the independent units of the line system,
    not their segments), refits, and :func:`align_axes` matches each replicate's axes to the
    reference axes by the axial angle with an optimal assignment (Hungarian algorithm), so labels do
    not switch. :func:`confidence_cones` gives the 95 % cone half-angles.

The joint replicates handed to the mechanics are assembled in
:mod:`bayestissue.stereology.replicates`.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy.optimize import linear_sum_assignment

from bayestissue._validation import ValidationError, check_interval
from bayestissue.stereology.axial import axial_angle

__all__ = [
    "logistic_normal_draws",
    "parametric_fraction_bootstrap",
    "cluster_fraction_bootstrap",
    "naive_section_bootstrap",
    "align_axes",
    "bootstrap_cells",
    "confidence_cones",
]


def _n_boot(n_boot) -> int:
    if isinstance(n_boot, bool) or not float(n_boot).is_integer() or int(n_boot) < 1:
        raise ValidationError("n_boot", n_boot, "an integer >= 1")
    return int(n_boot)


def logistic_normal_draws(mean, cov, n: int, *, rng=None) -> np.ndarray:
    r"""Draw compositions on the simplex with approximately the given mean and covariance.

    Additive log-ratio :math:`y_j = \log(V_j / V_K)`, :math:`j < K`, with covariance :math:`\Sigma_y
    = J \Sigma_V J^T`, :math:`J_{jl} = \delta_{jl}/V_j + 1/V_K` (delta method, using the first K-1
    rows/columns of ``cov``), drawn as :math:`y \sim N(\operatorname{alr}(V), \Sigma_y)` and mapped
    back by the softmax. Every draw lies in (0, 1) and sums to 1; mean and covariance match to first
    order in the CE.

    Parameters
    ----------
    mean : (K,) fractions summing to 1, each in (0, 1).
    cov : (K, K) covariance of the fractions.
    n : number of draws. rng : seed or Generator.

    Returns
    -------
    (n, K) array.
    """
    V = np.asarray(mean, dtype=float)
    S = np.asarray(cov, dtype=float)
    K = V.size
    if V.ndim != 1 or K < 2 or np.any(V <= 0) or np.any(V >= 1) or abs(V.sum() - 1) > 1e-8:
        raise ValidationError("mean", V.tolist(), "K >= 2 fractions in (0, 1) summing to 1")
    if S.shape != (K, K) or not np.all(np.isfinite(S)):
        raise ValidationError("cov", f"shape {S.shape}", f"a finite ({K}, {K}) matrix")
    rng = np.random.default_rng(rng)
    J = np.diag(1.0 / V[:-1]) + 1.0 / V[-1]
    Sy = J @ S[:-1, :-1] @ J.T
    Sy = 0.5 * (Sy + Sy.T)
    y = rng.multivariate_normal(np.log(V[:-1] / V[-1]), Sy, size=int(n), method="eigh")
    y = np.concatenate([y, np.zeros((int(n), 1))], axis=1)
    y -= y.max(axis=1, keepdims=True)
    e = np.exp(y)
    return e / e.sum(axis=1, keepdims=True)


def parametric_fraction_bootstrap(counts, *, n_boot: int = 1000, rng=None, **ce_kwargs) -> np.ndarray:
    """Design-aware parametric bootstrap of the volume fractions of one systematic sample.

    The fractions are drawn by :func:`logistic_normal_draws` around the ratio estimates (paper eq.
    1) with the covariance predicted for SURS by
    :func:`bayestissue.stereology.sections.fraction_covariance`.

    Parameters
    ----------
    counts : (n_sections, K) reference-space point counts, sections in series order.
    n_boot : number of replicates. rng : seed or Generator.
    ce_kwargs : ``smoothness``, ``shape_factors``, ``n_profiles``, ``nugget`` for the covariance.

    Returns
    -------
    (n_boot, K) fractions.
    """
    from bayestissue.stereology.sections import fraction_covariance

    Q = np.asarray(counts, dtype=float)
    cov = fraction_covariance(Q, **ce_kwargs)
    V = Q.sum(axis=0) / Q.sum()
    return logistic_normal_draws(V, cov, _n_boot(n_boot), rng=rng)


def cluster_fraction_bootstrap(counts, groups, *, n_boot: int = 1000, rng=None) -> np.ndarray:
    """Bootstrap over independent units (blocks, animals): resample whole groups, pool their counts.

    Parameters
    ----------
    counts : (n_sections, K) reference-space counts; groups : (n_sections,) unit labels (>= 2
        distinct).

    Returns
    -------
    (n_boot, K) ratio estimates sum(Q_k) / sum(P) of the pooled resampled units.
    """
    Q = np.asarray(counts, dtype=float)
    g = np.asarray(groups)
    if g.shape != Q.shape[:1]:
        raise ValidationError("groups", f"shape {g.shape}", f"({Q.shape[0]},) one label per section")
    labels, inv = np.unique(g, return_inverse=True)
    if labels.size < 2:
        raise ValidationError(
            "groups",
            labels.tolist(),
            ">= 2 independent units",
            "use the parametric bootstrap for one unit",
        )
    rng = np.random.default_rng(rng)
    per_unit = np.zeros((labels.size, Q.shape[1]))
    np.add.at(per_unit, inv, Q)
    pick = rng.integers(0, labels.size, size=(_n_boot(n_boot), labels.size))
    sums = per_unit[pick].sum(axis=1)
    return sums / sums.sum(axis=1, keepdims=True)


def naive_section_bootstrap(counts, *, n_boot: int = 1000, rng=None) -> np.ndarray:
    """Resample the sections of ONE systematic sample as if independent. Comparison only: it is
    wrong.

    It ignores the systematic design and overestimates the CE several-fold (demonstrated by
    :func:`bayestissue.stereology.known_object.ce_check`). Returns (n_boot, K) fractions.
    """
    Q = np.asarray(counts, dtype=float)
    if Q.ndim != 2 or Q.shape[0] < 2:
        raise ValidationError("counts", f"shape {Q.shape}", "(n_sections >= 2, K)")
    rng = np.random.default_rng(rng)
    pick = rng.integers(0, Q.shape[0], size=(_n_boot(n_boot), Q.shape[0]))
    sums = Q[pick].sum(axis=1)
    tot = sums.sum(axis=1, keepdims=True)
    return np.divide(sums, tot, out=np.full_like(sums, np.nan), where=tot > 0)


def align_axes(axes, reference) -> tuple[np.ndarray, np.ndarray]:
    """Match estimated axes to reference axes by the axial angle (Hungarian assignment) and fix
    signs.

    Parameters
    ----------
    axes : (k, 3) or (B, k, 3) estimated axes; reference : (k, 3) reference axes.

    Returns
    -------
    aligned : same shape as ``axes``, row j matched to reference j and signed so that a . ref_j >=
        0.
    order : (k,) or (B, k) index of the estimated axis assigned to each reference axis.
    """
    A = np.asarray(axes, dtype=float)
    R = np.asarray(reference, dtype=float)
    single = A.ndim == 2
    A = A[None] if single else A
    if A.shape[1:] != R.shape or R.ndim != 2 or R.shape[1] != 3:
        raise ValidationError("axes", f"shape {np.asarray(axes).shape}", f"(..., {R.shape[0]}, 3)")
    out = np.empty_like(A)
    orders = np.empty(A.shape[:2], dtype=int)
    for b in range(A.shape[0]):
        cost = axial_angle(R[:, None, :], A[b][None, :, :])
        rows, cols = linear_sum_assignment(cost)
        orders[b, rows] = cols
        m = A[b, cols]
        out[b, rows] = m * np.where(np.sum(m * R[rows], axis=1) < 0, -1.0, 1.0)[:, None]
    return (out[0], orders[0]) if single else (out, orders)


def bootstrap_cells(
    cell_ids,
    estimator: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]],
    *,
    n_boot: int = 500,
    rng=None,
    progress: Callable[[int, int], None] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Bootstrap over whole traced cells: resample cells with replacement and refit.

    Parameters
    ----------
    cell_ids : (n_segments,) id of the traced cell of each segment.
    estimator : ``f(segment_indices) -> (axes (k, 3), values (k,) or (k, m))`` fitting the chosen segments
        (with repeats, so resampled cells count as often as drawn); the values are per family (the length shares,
        say, with further columns such as the families' concentrations).
    n_boot : number of replicates. rng : seed or Generator.
    progress : ``progress(done, n_boot)`` after each replicate.

    Returns
    -------
    axes (n_boot, k, 3) and values (n_boot, k[, m]), in the estimator's order (align them with
    :func:`align_axes`).
    """
    ids = np.asarray(cell_ids)
    cells, inv = np.unique(ids, return_inverse=True)
    if cells.size < 2:
        raise ValidationError("cell_ids", cells.tolist(), ">= 2 traced cells to resample")
    members = [np.flatnonzero(inv == c) for c in range(cells.size)]
    rng = np.random.default_rng(rng)
    axes, shares = [], []
    total = _n_boot(n_boot)
    for k in range(total):
        pick = rng.integers(0, cells.size, size=cells.size)
        idx = np.concatenate([members[c] for c in pick])
        a, s = estimator(idx)
        axes.append(a)
        shares.append(s)
        if progress is not None:
            progress(k + 1, total)
    return np.asarray(axes), np.asarray(shares)


def confidence_cones(replicate_axes, reference, *, level: float = 0.95) -> np.ndarray:
    """Cone half-angles (degrees) around the reference axes holding ``level`` of the aligned
    replicates.

    Parameters
    ----------
    replicate_axes : (B, k, 3) replicate axes (aligned or not; aligned here).
    reference : (k, 3) point estimates, the cone axes.

    Returns
    -------
    (k,) half-angles: the ``level`` quantile of the axial angle between replicate and reference
    axes.
    """
    check_interval("level", level, 0.0, 1.0, closed=(False, False))
    aligned, _ = align_axes(replicate_axes, reference)
    ang = axial_angle(aligned, np.asarray(reference, dtype=float)[None])
    return np.quantile(ang, level, axis=0)
