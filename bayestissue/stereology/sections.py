r"""Systematic uniform random sections (SURS), point counts, volume fractions and their coefficient
of error.

The paper (Kochova et al., Section 2.5.1) estimated the volume fractions of smooth muscle cells
(SMC) and extracellular matrix (ECM) by point counting on ``m = 12`` of 72 serial sections taken
systematically (every sixth, random start), eq. (1):

.. math:: \widehat{V}_V(\text{component}) = \frac{\sum_i Q_i}{\sum_i P_i} = P_P(\text{component}),

with :math:`Q_i` the points hitting the component and :math:`P_i` the points hitting the reference
space (tissue without haemocoelic cavities) on section :math:`i`.

The coefficient of error (CE) of a sum over a systematic sample follows Gundersen & Jensen (1987)
and Gundersen et al. (1999), with :math:`C_k = \sum_i P_i P_{i+k}` (counts zero-padded beyond the
series):

.. math::
    \operatorname{Var}_{SURS}\Big(\sum P\Big) = \alpha(m)\,[3 (C_0 - \nu) - 4 C_1 + C_2], \qquad
    \operatorname{Var}\Big(\sum P\Big) = \operatorname{Var}_{SURS} + \nu,

:math:`\alpha(0) = 1/12` (functions with jumps), :math:`\alpha(1) = 1/240` (smooth functions), and
the point-counting "nugget" :math:`\nu = 0.0724\,(b/\sqrt a)\sqrt{n \sum P}`. The fractional
smoothness variant (Garcia-Finana & Cruz-Orive 2000) uses :math:`\alpha(q)` with :math:`q` estimated
from the data, see :func:`alpha_q` and :func:`smoothness_q_hat`.

All array functions work along the last axis, so a batch of systematic samples (e.g. many random
starts through a known object, zero-padded to a common length) is handled in one call.

References
----------
Gundersen HJG, Jensen EB (1987) The efficiency of systematic sampling in stereology and its
prediction.
J. Microsc. 147:229-263. doi:10.1111/j.1365-2818.1987.tb02837.x
Gundersen HJG, Jensen EBV, Kieu K, Nielsen J (1999) The efficiency of systematic sampling in
stereology --
reconsidered. J. Microsc. 193:199-211. doi:10.1046/j.1365-2818.1999.00457.x
Garcia-Finana M, Cruz-Orive LM (2000) Fractional trend of the variance in Cavalieri sampling.
Image Anal. Stereol. 19:71-79; J. Microsc. 199:224-238. doi:10.1046/j.1365-2818.2000.00731.x
Cochran WG (1977) Sampling Techniques, 3rd ed., Wiley, ch. 6 and 8.
"""

from __future__ import annotations

import numpy as np
from scipy.special import gamma as _gamma
from scipy.special import zeta as _zeta

from bayestissue._validation import ValidationError, check_positive

__all__ = [
    "DISC_SHAPE_FACTOR",
    "surs_indices",
    "alpha_q",
    "covariogram",
    "cross_covariogram",
    "nugget_variance",
    "smoothness_q_hat",
    "surs_sum_variance",
    "ce_sum",
    "ratio_ce",
    "classic_ratio_ce",
    "fraction_covariance",
    "successive_difference_sum",
]

#: Profile shape factor b / sqrt(a) of a disc, 2 sqrt(pi) (Gundersen et al. 1999, Table 1).
DISC_SHAPE_FACTOR = 2.0 * np.sqrt(np.pi)

#: Coefficient of the point-counting noise (nugget), Gundersen et al. (1999), eq. (13).
_NUGGET_COEF = 0.0724


def surs_indices(n_sections: int, period: int, *, rng=None) -> np.ndarray:
    """Select a systematic uniform random sample of sections: random start, then every
    ``period``-th.

    The paper (Section 2.5.1) took every sixth of 72 serial sections from a random start ``72 u /
    m`` with ``u ~ U[0, 1)`` and ``m = 12``; this is ``start = floor(period * u)``.

    Parameters
    ----------
    n_sections : int, number of sections in the series (positions 0 ... n_sections - 1).
    period : int, sampling period k (1 <= k <= n_sections).
    rng : seed or Generator.

    Returns
    -------
    (m,) int ndarray of section positions ``start, start + k, ...`` below ``n_sections``.
    """
    n = _check_int("n_sections", n_sections, 1)
    k = _check_int("period", period, 1)
    if k > n:
        raise ValidationError("period", k, f"an integer <= n_sections = {n}")
    rng = np.random.default_rng(rng)
    start = int(np.floor(k * rng.random()))
    return np.arange(start, n, k)


def _check_int(name: str, value, low: int) -> int:
    if isinstance(value, bool) or not float(value).is_integer() or int(value) < low:
        raise ValidationError(name, value, f"an integer >= {low}")
    return int(value)


def alpha_q(q) -> np.ndarray:
    r"""Variance coefficient :math:`\alpha(q)` for smoothness :math:`q \in [0, 1]`.

    .. math::
        \alpha(q) = \frac{\Gamma(2q+2)\,\zeta(2q+2)\,\cos(\pi q)}{(2\pi)^{2q+2}\,(1 - 2^{2q-1})}

    (Garcia-Finana & Cruz-Orive 2000). :math:`\alpha(0) = 1/12`, :math:`\alpha(1) = 1/240`; the
    singularity at :math:`q = 1/2` is removable: with :math:`e = q - 1/2`, :math:`\cos(\pi q)/(1 -
    2^{2q-1}) = \sin(\pi e)/\operatorname{expm1}(2 e \ln 2) \to \pi / (2 \ln 2)`, giving
    :math:`\alpha(1/2) = 0.0219639`.
    """
    q = np.asarray(q, dtype=float)
    if np.any(~np.isfinite(q)) or np.any((q < 0) | (q > 1)):
        raise ValidationError("q", q.tolist(), "smoothness values in [0, 1]")
    e = q - 0.5
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = np.where(e == 0, np.pi / (2 * np.log(2.0)), np.sin(np.pi * e) / np.expm1(2 * e * np.log(2)))
    s = 2 * q + 2
    return _gamma(s) * _zeta(s) * ratio / (2 * np.pi) ** s


def _alpha(smoothness) -> float | np.ndarray:
    if isinstance(smoothness, str):
        raise ValidationError("smoothness", smoothness, "0, 1 or a number q in [0, 1], or 'q_hat'")
    return alpha_q(smoothness)


def covariogram(P, max_lag: int = 4) -> np.ndarray:
    r"""Sums :math:`C_k = \sum_i P_i P_{i+k}` for :math:`k = 0 \dots` ``max_lag`` along the last
    axis.

    Returns an array of shape ``P.shape[:-1] + (max_lag + 1,)``.
    """
    return cross_covariogram(P, P, max_lag)


def cross_covariogram(Q, P, max_lag: int = 4) -> np.ndarray:
    r"""Symmetrised cross sums :math:`\tfrac12 \sum_i (Q_i P_{i+k} + Q_{i+k} P_i)`, :math:`k = 0
    \dots` ``max_lag``.

    For :math:`k = 0` this is :math:`A_{QP} = \sum Q_i P_i`, for 1 and 2 the :math:`B_{QP}, C_{QP}`
    of the ratio CE (Gundersen et al. 1999); with ``Q = P`` it is :math:`C_k`.
    """
    Q = np.asarray(Q, dtype=float)
    P = np.asarray(P, dtype=float)
    n = P.shape[-1]
    out = np.zeros(np.broadcast_shapes(Q.shape, P.shape)[:-1] + (max_lag + 1,))
    for k in range(max_lag + 1):
        if k >= n:
            break
        a = np.sum(Q[..., : n - k] * P[..., k:], axis=-1)
        b = np.sum(Q[..., k:] * P[..., : n - k], axis=-1)
        out[..., k] = 0.5 * (a + b)
    return out


def successive_difference_sum(P) -> np.ndarray:
    r""":math:`2 \sum (P_{i+1} - P_i)^2 - \tfrac12 \sum (P_{i+2} - P_i)^2` with zero padding.

    Equals :math:`3 C_0 - 4 C_1 + C_2` (the identity is used as a test of :func:`covariogram`).
    """
    P = np.asarray(P, dtype=float)
    z = np.zeros(P.shape[:-1] + (2,))
    Pp = np.concatenate([z, P, z], axis=-1)
    d1 = np.diff(Pp, axis=-1)
    d2 = Pp[..., 2:] - Pp[..., :-2]
    return 2 * np.sum(d1**2, axis=-1) - 0.5 * np.sum(d2**2, axis=-1)


def nugget_variance(P, *, shape_factor: float = DISC_SHAPE_FACTOR, n_profiles=None) -> np.ndarray:
    r"""Point-counting noise :math:`\nu = 0.0724\,(b/\sqrt a)\,\sqrt{n \sum P}` (Gundersen et al.
    1999, eq. 13).

    Parameters
    ----------
    P : (..., n) point counts per section.
    shape_factor : profile shape factor :math:`b/\sqrt a` (boundary length over root area); a disc
        has :math:`2\sqrt\pi = 3.545` (the default), elongated or irregular profiles more.
    n_profiles : number of profiles :math:`n`; default the number of sections with a non-zero
        count. For a fragmented phase (many profiles per section) pass the profile count.
    """
    P = np.asarray(P, dtype=float)
    s = check_positive("shape_factor", shape_factor)
    n = np.count_nonzero(P, axis=-1) if n_profiles is None else np.asarray(n_profiles, dtype=float)
    return _NUGGET_COEF * s * np.sqrt(n * np.sum(P, axis=-1))


def smoothness_q_hat(P, *, nugget=0.0) -> np.ndarray:
    r"""Estimated fractional smoothness (Garcia-Finana & Cruz-Orive 2004), capped to [0, 1].

    .. math:: \hat q = \max\Big(0, \frac{1}{2 \ln 2}
        \ln\frac{3 (C_0 - \nu) - 4 C_2 + C_4}{3 (C_0 - \nu) - 4 C_1 + C_2} - \frac12\Big)

    The numerator is the variance term of the sample with doubled period. Needs at least 5 sections.
    """
    P = _check_counts("P", P)
    _check_n(P, 5, "the fractional smoothness q_hat")
    C = covariogram(P, 4)
    c0 = C[..., 0] - np.asarray(nugget, dtype=float)
    num = 3 * c0 - 4 * C[..., 2] + C[..., 4]
    den = 3 * c0 - 4 * C[..., 1] + C[..., 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        q = np.log(num / den) / (2 * np.log(2.0)) - 0.5
    q = np.where(np.isfinite(q), q, 0.0)
    return np.clip(q, 0.0, 1.0)


def surs_sum_variance(
    P, *, smoothness=1, nugget=None, shape_factor: float = DISC_SHAPE_FACTOR, n_profiles=None
) -> np.ndarray:
    r"""Predicted variance of :math:`\sum P` over the random start of a systematic sample.

    .. math:: \operatorname{Var}(\textstyle\sum P) = \max\{0, \alpha(q)\,[3 (C_0 - \nu) - 4 C_1 +
        C_2]\} + \nu

    Parameters
    ----------
    P : (..., n) counts (or areas) on consecutive systematic sections, zero-padded if batched.
    smoothness : 0 (functions with jumps), 1 (smooth, the default, ellipsoid-like bodies), a value
        in [0, 1], or ``"q_hat"`` to estimate it (:func:`smoothness_q_hat`).
    nugget : point-counting variance :math:`\nu`; default :func:`nugget_variance` (pass 0 for exact
        areas).
    shape_factor, n_profiles : passed to :func:`nugget_variance`.

    Notes
    -----
    The convention pinned here (Gundersen et al. 1999): :math:`\nu` is subtracted inside the bracket
    and added back outside. A negative systematic term (possible for very noisy counts) is set to 0.
    """
    P = _check_counts("P", P)
    _check_n(P, 3, "the Gundersen-Jensen CE")
    nu = (
        nugget_variance(P, shape_factor=shape_factor, n_profiles=n_profiles)
        if nugget is None
        else np.asarray(nugget, dtype=float)
    )
    if isinstance(smoothness, str) and smoothness == "q_hat":
        a = alpha_q(smoothness_q_hat(P, nugget=nu))
    else:
        a = _alpha(smoothness)
    C = covariogram(P, 2)
    var_surs = a * (3 * (C[..., 0] - nu) - 4 * C[..., 1] + C[..., 2])
    return np.maximum(var_surs, 0.0) + nu


def ce_sum(P, **kwargs) -> np.ndarray:
    r"""Coefficient of error of :math:`\sum P`: :math:`\sqrt{\operatorname{Var}(\sum P)} / \sum P`.

    Keyword arguments as :func:`surs_sum_variance`.
    """
    P = _check_counts("P", P)
    return np.sqrt(surs_sum_variance(P, **kwargs)) / np.sum(P, axis=-1)


def fraction_covariance(
    counts, *, smoothness=1, shape_factors=DISC_SHAPE_FACTOR, n_profiles=None, nugget=True
) -> np.ndarray:
    r"""Predicted covariance of the volume fractions :math:`V_j = \sum Q_j / \sum P`, :math:`P =
    \sum_j Q_j`.

    The SURS covariances of the component sums follow Gundersen et al. (1999),

    .. math:: G_{jk} = \alpha\,[3 A_{jk} - 4 B_{jk} + C_{jk}] \;(+\nu_j \text{ on the diagonal,
        inside and out}),

    with :math:`A, B, C` the symmetrised cross sums at lag 0, 1, 2 (:func:`cross_covariogram`), and
    the ratio covariance by the delta method:

    .. math:: \frac{\operatorname{Cov}(V_j, V_k)}{V_j V_k} = \frac{G_{jk}}{Q_j Q_k} -
        \frac{G_{jP}}{Q_j P}
        - \frac{G_{kP}}{Q_k P} + \frac{G_{PP}}{P^2}.

    The diagonal is the ratio CE of :func:`ratio_ce` squared times :math:`V_j^2`. The nugget of the
    reference sum :math:`P` is that of the reference profiles, not the sum of the component nuggets,
    so rows need not sum to exactly zero; draw fractions on the simplex
    (:mod:`bayestissue.stereology.uncertainty`).

    Parameters
    ----------
    counts : (..., n, K) point counts of the K reference-space components (exclude cavities first).
    smoothness : as :func:`surs_sum_variance` (``"q_hat"`` estimates q from the reference counts).
    shape_factors : scalar or (K + 1,) shape factors of the components and (last) the reference.
    n_profiles : None or (K + 1,) profile counts (default: non-zero sections).
    nugget : include the point-counting noise (False for exact areas).

    Returns
    -------
    (..., K, K) covariance matrix of the fractions.
    """
    Q = _check_counts("counts", counts)
    if Q.ndim < 2:
        raise ValidationError("counts", f"shape {Q.shape}", "an (n_sections, n_components) array")
    Q = np.moveaxis(Q, -1, -2)  # (..., K, n)
    K = Q.shape[-2]
    P = Q.sum(axis=-2)
    _check_n(P, 3, "the ratio CE")
    X = np.concatenate([Q, P[..., None, :]], axis=-2)  # (..., K+1, n)
    if isinstance(smoothness, str) and smoothness == "q_hat":
        nuP = nugget_variance(P, shape_factor=np.ravel(np.broadcast_to(shape_factors, K + 1))[-1])
        a = alpha_q(smoothness_q_hat(P, nugget=nuP if nugget else 0.0))
    else:
        a = _alpha(smoothness)
    a_vec = np.asarray(a)[..., None]  # broadcasts against (..., K+1)
    a_mat = a_vec[..., None]  # against (..., K+1, K+1)
    sums = X.sum(axis=-1)
    G = np.empty(X.shape[:-2] + (K + 1, K + 1))
    for j in range(K + 1):
        for k in range(j, K + 1):
            c = cross_covariogram(X[..., j, :], X[..., k, :], 2)
            G[..., j, k] = G[..., k, j] = 3 * c[..., 0] - 4 * c[..., 1] + c[..., 2]
    if nugget:
        sf = np.broadcast_to(np.asarray(shape_factors, dtype=float), (K + 1,))
        npf = [None] * (K + 1) if n_profiles is None else list(n_profiles)
        nu = np.stack(
            [nugget_variance(X[..., j, :], shape_factor=sf[j], n_profiles=npf[j]) for j in range(K + 1)],
            axis=-1,
        )
        idx = np.arange(K + 1)
        diag = np.maximum(a_vec * (G[..., idx, idx] - 3 * nu), 0.0) + nu
        G = a_mat * G
        G[..., idx, idx] = diag
    else:
        G = a_mat * G
    inv = np.divide(1.0, sums, out=np.zeros_like(sums), where=sums > 0)  # absent component: 0
    R = G * inv[..., :, None] * inv[..., None, :]
    rel = R[..., :K, :K] - R[..., :K, K : K + 1] - R[..., K : K + 1, :K] + R[..., K : K + 1, K : K + 1]
    V = sums[..., :K] * inv[..., K : K + 1]
    cov = rel * V[..., :, None] * V[..., None, :]
    return np.where(np.isfinite(cov), cov, 0.0)


def ratio_ce(Q, P, **kwargs) -> np.ndarray:
    r"""CE of the ratio estimator :math:`\widehat V_V = \sum Q / \sum P` (paper eq. 1), with the
    covariance term.

    .. math:: CE^2(\widehat V_V) = \frac{\operatorname{Var}(\sum Q)}{(\sum Q)^2}
        + \frac{\operatorname{Var}(\sum P)}{(\sum P)^2}
        - \frac{2\operatorname{Cov}(\sum Q, \sum P)}{\sum Q \sum P},

    :math:`\operatorname{Cov}_{SURS} = \alpha\,[3 A_{QP} - 4 B_{QP} + C_{QP}]` (Gundersen et al.
    1999).

    Parameters
    ----------
    Q : (..., n) points on the phase; P : (..., n) points on the reference space (``Q <= P``).
    kwargs : ``smoothness``, ``nugget`` (bool), ``shape_factors`` and ``n_profiles`` (each a scalar
        or (phase, reference)), as :func:`fraction_covariance`.
    """
    Q = _check_counts("Q", Q)
    P = _check_counts("P", P)
    if Q.shape != P.shape:
        raise ValidationError("Q", f"shape {Q.shape}", f"the shape of P {P.shape}")
    bad = np.argwhere(Q > P)
    if bad.size:
        i = tuple(bad[0])
        raise ValidationError("Q", f"{Q[i]:g} > P = {P[i]:g} at section {i[-1]}", "phase counts <= reference counts")
    sf = kwargs.pop("shape_factors", DISC_SHAPE_FACTOR)
    sf = np.broadcast_to(np.asarray(sf, dtype=float), (2,))
    npf = kwargs.pop("n_profiles", None)
    if npf is not None:
        npf = np.broadcast_to(np.asarray(npf, dtype=float), (2,))
        kwargs["n_profiles"] = (npf[0], npf[0], npf[1])
    counts = np.stack([Q, P - Q], axis=-1)
    # the complement R = P - Q only enters through G_PP and G_QP; its own shape factor is not used
    cov = fraction_covariance(counts, shape_factors=(sf[0], sf[0], sf[1]), **kwargs)
    V = Q.sum(axis=-1) / P.sum(axis=-1)
    return np.sqrt(np.maximum(cov[..., 0, 0], 0.0)) / V


def classic_ratio_ce(Q, P) -> np.ndarray:
    r"""The "independent units" ratio CE (Cochran 1977, ch. 6), for comparison only.

    .. math:: CE^2 = \frac{n}{n-1} \sum_i \Big(\frac{Q_i}{\sum Q} - \frac{P_i}{\sum P}\Big)^2

    It treats systematic sections as independent, which they are not, and overestimates the error of
    SURS.
    """
    Q = _check_counts("Q", Q)
    P = _check_counts("P", P)
    n = P.shape[-1]
    _check_n(P, 2, "the independent-units CE")
    d = Q / Q.sum(axis=-1, keepdims=True) - P / P.sum(axis=-1, keepdims=True)
    return np.sqrt(n / (n - 1) * np.sum(d**2, axis=-1))


def _check_counts(name: str, x) -> np.ndarray:
    a = np.asarray(x, dtype=float)
    if a.ndim == 0 or a.size == 0:
        raise ValidationError(name, x, "a non-empty array of counts per section")
    if not np.all(np.isfinite(a)):
        raise ValidationError(name, a.tolist() if a.size < 20 else "array", "finite counts")
    if np.any(a < 0):
        i = tuple(np.argwhere(a < 0)[0])
        raise ValidationError(name, f"{a[i]:g} at index {i}", "counts >= 0")
    return a


def _check_n(P: np.ndarray, n_min: int, what: str) -> None:
    n = P.shape[-1]
    if n < n_min:
        raise ValidationError("number of sections", n, f">= {n_min} sections for {what}", "sample more sections")
