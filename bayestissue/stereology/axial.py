r"""Axial (undirected) statistics: orientation tensor, Watson distribution and Watson mixtures
fitted by EM.

Lines are axes: :math:`\pm d` are the same direction. These bin-free estimators complement the
equal-area rose of :mod:`bayestissue.stereology.rose` (paper Section 2.5.3), whose answer depends on
the number of cells.

Watson distribution on the unit sphere :math:`S^2` (Fisher, Lewis & Embleton 1987, section 4.4):

.. math:: f(x; \mu, \kappa) = \frac{\exp(\kappa (\mu^T x)^2)}{4\pi\, M(\tfrac12, \tfrac32, \kappa)},

with :math:`M` Kummer's confluent hypergeometric function. For :math:`\kappa > 0`,
:math:`M(\tfrac12,\tfrac32,\kappa) = e^{\kappa} D(\sqrt\kappa)/\sqrt\kappa` with :math:`D` Dawson's
integral, which stays finite in logarithms for any :math:`\kappa` (``hyp1f1`` overflows beyond about
700).

References
----------
Fisher NI, Lewis T, Embleton BJJ (1987) Statistical Analysis of Spherical Data. Cambridge
University Press.
doi:10.1017/CBO9780511623059
Best DJ, Fisher NI (1986) Goodness-of-fit and discordancy tests for samples from the Watson
distribution on the
sphere. Aust. J. Stat. 28:13-31. doi:10.1111/j.1467-842X.1986.tb00580.x
Sra S, Karp D (2013) The multivariate Watson distribution: maximum-likelihood estimation and other
aspects.
J. Multivariate Anal. 114:256-269. doi:10.1016/j.jmva.2012.08.010
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq
from scipy.special import dawsn, erf, logsumexp

from bayestissue._validation import ValidationError, check_positive

__all__ = [
    "orientation_tensor",
    "principal_axes",
    "goh_dispersion",
    "watson_goh_dispersion",
    "axial_angle",
    "watson_log_normaliser",
    "watson_mean_t2",
    "watson_logpdf",
    "watson_pdf",
    "sample_watson",
    "fit_watson",
    "WatsonMixture",
    "fit_watson_mixture",
]


def _directions(x, name="directions") -> np.ndarray:
    d = np.asarray(x, dtype=float)
    if d.ndim != 2 or d.shape[1] != 3:
        raise ValidationError(name, f"shape {d.shape}", "an (n, 3) array of directions")
    n = np.linalg.norm(d, axis=1)
    if not np.all(np.isfinite(d)) or np.any(n == 0):
        raise ValidationError(name, "a zero or non-finite row", "non-zero finite directions")
    return d / n[:, None]


def _weights(w, n: int) -> np.ndarray:
    if w is None:
        return np.ones(n)
    w = np.asarray(w, dtype=float)
    if w.shape != (n,) or not np.all(np.isfinite(w)) or np.any(w < 0) or w.sum() <= 0:
        raise ValidationError("weights", f"shape {w.shape}", f"({n},) finite weights >= 0, not all zero")
    return w


def orientation_tensor(directions, weights=None) -> np.ndarray:
    r"""Length-weighted orientation tensor :math:`T = \sum_i l_i d_i d_i^T / \sum_i l_i` (Fisher et
    al. 1987).

    Parameters
    ----------
    directions : (n, 3) directions (normalised here; sign irrelevant).
    weights : (n,) weights, e.g. line lengths in um; default equal.

    Returns
    -------
    (3, 3) symmetric tensor with trace 1.
    """
    d = _directions(directions)
    w = _weights(weights, len(d))
    return np.einsum("i,ij,ik->jk", w, d, d) / w.sum()


def principal_axes(T) -> tuple[np.ndarray, np.ndarray]:
    """Eigenvalues (descending) and eigenvectors (columns) of an orientation tensor, each with z >=
    0."""
    T = np.asarray(T, dtype=float)
    lam, vec = np.linalg.eigh(T)
    lam, vec = lam[..., ::-1], vec[..., ::-1]
    sign = np.where(vec[..., 2:3, :] < 0, -1.0, 1.0)
    return lam, vec * sign


def goh_dispersion(T) -> float:
    r"""GOH fibre dispersion :math:`\kappa_{GOH} = (1 - \lambda_{max}) / 2` for a rotationally
    symmetric spread.

    0 for perfectly aligned fibres, 1/3 for isotropic ones (Gasser, Ogden & Holzapfel 2006,
    doi:10.1098/rsif.2005.0073).
    """
    lam, _ = principal_axes(T)
    return float((1.0 - lam[..., 0]) / 2.0)


def watson_goh_dispersion(concentration) -> np.ndarray:
    r"""The GOH dispersion of a Watson distribution of concentration :math:`k` about its axis :math:`\mu`:
    :math:`\kappa = (1 - A(k))/2` with :math:`A = E[(\mu^T x)^2]` (:func:`watson_mean_t2`).

    The structure tensor of a density is its second moment :math:`H = E[x \otimes x]`; for a rotationally symmetric
    density it is :math:`\kappa I + (1 - 3\kappa)\mu\otimes\mu` with :math:`\kappa = \tfrac14\int_0^\pi
    \rho(\Theta)\sin^3\Theta\, d\Theta` (the definition of Gasser, Ogden & Holzapfel 2006; :math:`\rho`
    normalised to :math:`\tfrac1{4\pi}\int\rho\, d\omega = 1`), and its eigenvalue along :math:`\mu`,
    :math:`A = 1 - 2\kappa`, gives the mapping. Bipolar densities (:math:`k > 0`) give :math:`\kappa \in (0, 1/3)`,
    the uniform one 1/3, girdles (:math:`k < 0`) more than 1/3 (outside the exponential fibre's range).
    tests/stereology/test_dispersion.py checks it against quadrature over the sphere.
    """
    return (1.0 - watson_mean_t2(concentration)) / 2.0


def axial_angle(a, b) -> np.ndarray:
    r"""Angle in degrees between axes: :math:`\arccos |a \cdot b|` in [0, 90] (broadcasts over
    leading axes)."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    c = np.abs(np.sum(a * b, axis=-1)) / (np.linalg.norm(a, axis=-1) * np.linalg.norm(b, axis=-1))
    return np.degrees(np.arccos(np.clip(c, 0.0, 1.0)))


def watson_log_normaliser(kappa) -> np.ndarray:
    r""":math:`\log(4\pi M(\tfrac12, \tfrac32, \kappa))`, stable for any real :math:`\kappa`.

    :math:`\kappa > 0`: :math:`M = e^\kappa D(\sqrt\kappa)/\sqrt\kappa`; :math:`\kappa < 0`:
    :math:`M = \sqrt\pi\,\mathrm{erf}(\sqrt{|\kappa|}) / (2\sqrt{|\kappa|})`; series near 0.
    """
    k = np.asarray(kappa, dtype=float)
    s = np.sqrt(np.abs(k))
    small = np.abs(k) < 1e-6
    with np.errstate(divide="ignore", invalid="ignore"):
        pos = k + np.log(dawsn(s) / s)
        neg = np.log(np.sqrt(np.pi) * erf(s) / (2 * s))
    logM = np.where(small, k / 3.0 + 2 * k**2 / 45.0, np.where(k > 0, pos, neg))
    return np.log(4 * np.pi) + logM


def watson_mean_t2(kappa) -> np.ndarray:
    r""":math:`A(\kappa) = E[(\mu^T x)^2] = \frac{d}{d\kappa}\log M(\tfrac12,\tfrac32,\kappa)`.

    For :math:`\kappa > 0`, :math:`A = 1/(2 s D(s)) - 1/(2\kappa)`, :math:`s = \sqrt\kappa`; series
    :math:`1/3 + 4\kappa/45` for small :math:`|\kappa|`. Increases from 0 (:math:`\kappa\to-\infty`)
    through 1/3 (uniform) to 1.
    """
    k = np.asarray(kappa, dtype=float)
    s = np.sqrt(np.abs(k))
    with np.errstate(divide="ignore", invalid="ignore"):
        pos = 1.0 / (2 * s * dawsn(s)) - 1.0 / (2 * k)
        # kappa < 0: d/dk log(erf(s)/s), s = sqrt(-k)
        neg = -(np.exp(-(s**2)) / (np.sqrt(np.pi) * s * erf(s)) - 1.0 / (2 * s**2))
    return np.where(np.abs(k) < 1e-3, 1 / 3 + 4 * k / 45, np.where(k > 0, pos, neg))


def _check_mu(mu) -> np.ndarray:
    m = np.asarray(mu, dtype=float)
    if m.shape[-1:] != (3,) or not np.all(np.isfinite(m)) or np.any(np.linalg.norm(m, axis=-1) == 0):
        raise ValidationError("mu", np.asarray(mu).tolist(), "a non-zero finite 3-vector")
    return m / np.linalg.norm(m, axis=-1, keepdims=True)


def watson_logpdf(x, mu, kappa) -> np.ndarray:
    """Log density of the Watson distribution w.r.t. the area measure on the unit sphere."""
    x = np.asarray(x, dtype=float)
    mu = _check_mu(mu)
    t = x @ mu
    return kappa * t**2 - watson_log_normaliser(kappa)


def watson_pdf(x, mu, kappa) -> np.ndarray:
    r"""Watson density :math:`\exp(\kappa(\mu^T x)^2) / (4\pi M(\tfrac12,\tfrac32,\kappa))`;
    integrates to 1."""
    return np.exp(watson_logpdf(x, mu, kappa))


def _sample_t(n: int, kappa: float, rng) -> np.ndarray:
    """|cos| of the angle to the axis, density prop. to exp(kappa t^2) on [0, 1] (kappa >= 0).

    Rejection from the truncated exponential envelope exp(kappa (t - 1)) >= exp(kappa (t^2 - 1)) (as
    in Best & Fisher 1986); acceptance exp(kappa t (t - 1)) is at least about 0.45 for every kappa.
    """
    out = np.empty(0)
    while out.size < n:
        m = int(1.3 * (n - out.size)) + 16
        u = rng.random(m)
        if kappa < 1e-8:
            t = u
        else:  # inverse CDF of the exponential on [0, 1] with rate kappa, anchored at 1
            t = 1.0 + np.log(u + (1 - u) * np.exp(-kappa)) / kappa
        acc = rng.random(m) < np.exp(kappa * t * (t - 1.0))
        out = np.concatenate([out, t[acc]])
    return out[:n]


def sample_watson(n: int, mu, kappa: float, *, rng=None) -> np.ndarray:
    """Draw ``n`` axes from a bipolar Watson distribution (kappa >= 0); returns (n, 3) unit vectors.

    The sign of each axis is random (axes have no sign).
    """
    mu = _check_mu(mu)
    kappa = check_positive("kappa", kappa, allow_zero=True)
    rng = np.random.default_rng(rng)
    t = _sample_t(int(n), kappa, rng)
    phi = 2 * np.pi * rng.random(int(n))
    st = np.sqrt(np.clip(1 - t**2, 0, None))
    a = np.array([1.0, 0, 0]) if abs(mu[0]) < 0.9 else np.array([0, 1.0, 0])
    e1 = np.cross(mu, a)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(mu, e1)
    x = t[:, None] * mu + st[:, None] * (np.cos(phi)[:, None] * e1 + np.sin(phi)[:, None] * e2)
    sign = np.where(rng.random(int(n)) < 0.5, -1.0, 1.0)
    return x * sign[:, None]


def _kappa_from_t2(r: float, kappa_max: float = 1e5) -> float:
    """Solve A(kappa) = r for kappa >= 0 (0 when r <= 1/3)."""
    if r <= 1 / 3 + 1e-12:
        return 0.0
    if watson_mean_t2(kappa_max) <= r:
        return kappa_max
    return float(brentq(lambda k: watson_mean_t2(k) - r, 1e-9, kappa_max, xtol=1e-10, rtol=1e-10))


def fit_watson(directions, weights=None) -> tuple[np.ndarray, float]:
    r"""Maximum-likelihood bipolar Watson fit: :math:`\hat\mu` the top eigenvector of :math:`T`,
    :math:`\hat\kappa` solving :math:`A(\kappa) = \lambda_{max}` (Fisher et al. 1987, section
    6.4.2)."""
    T = orientation_tensor(directions, weights)
    lam, vec = principal_axes(T)
    return vec[:, 0], _kappa_from_t2(lam[0])


@dataclass(frozen=True)
class WatsonMixture:
    """Mixture of bipolar Watson distributions.

    Parameters
    ----------
    axes : (k, 3) unit axes; kappas : (k,) concentrations >= 0; weights : (k,) mixing weights
        summing to 1 - ``background``.
    log_likelihood : weighted log-likelihood of the fitted data (nan when not fitted).
    background : weight of a uniform component, density 1 / (4 pi) (the density of axes in no family: fragments
        traced across sections, say); 0 by default.
    """

    axes: np.ndarray
    kappas: np.ndarray
    weights: np.ndarray
    log_likelihood: float = float("nan")
    background: float = 0.0

    def __post_init__(self):
        axes = _check_mu(np.atleast_2d(self.axes))
        k = len(axes)
        kap = np.asarray(self.kappas, dtype=float)
        w = np.asarray(self.weights, dtype=float)
        if kap.shape != (k,) or np.any(~np.isfinite(kap)) or np.any(kap < 0):
            raise ValidationError("kappas", kap.tolist(), f"{k} concentrations >= 0")
        bg = float(self.background)
        if not 0.0 <= bg < 1.0:
            raise ValidationError("background", bg, "a weight in [0, 1)")
        if w.shape != (k,) or np.any(w < 0) or abs(w.sum() + bg - 1) > 1e-8:
            raise ValidationError("weights", w.tolist(), f"{k} weights >= 0 summing to 1 - background = {1 - bg}")
        object.__setattr__(self, "axes", axes)
        object.__setattr__(self, "kappas", kap)
        object.__setattr__(self, "weights", w)

    def _log_components(self, x) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        t = x @ self.axes.T  # (n, k)
        return self.kappas * t**2 - watson_log_normaliser(self.kappas) + np.log(self.weights)

    def _log_all(self, x) -> np.ndarray:
        """Log components with the uniform background as a last column when it has weight."""
        lc = self._log_components(x)
        if self.background > 0:
            bg = np.full(lc.shape[:-1] + (1,), np.log(self.background / (4 * np.pi)))
            lc = np.concatenate([lc, bg], axis=-1)
        return lc

    def logpdf(self, x) -> np.ndarray:
        """Log density of the mixture at unit vectors ``x`` (n, 3)."""
        return logsumexp(self._log_all(x), axis=-1)

    def pdf(self, x) -> np.ndarray:
        """Density of the mixture (integrates to 1 over the sphere)."""
        return np.exp(self.logpdf(x))

    def sample(self, n: int, *, rng=None) -> tuple[np.ndarray, np.ndarray]:
        """Draw ``n`` axes; returns (n, 3) unit vectors and (n,) component labels."""
        rng = np.random.default_rng(rng)
        k = len(self.weights)
        p = np.append(self.weights, self.background)
        labels = rng.choice(k + 1, size=int(n), p=p / p.sum())
        x = np.empty((int(n), 3))
        for j in range(k + 1):
            idx = np.flatnonzero(labels == j)
            if idx.size and j < k:
                x[idx] = sample_watson(idx.size, self.axes[j], self.kappas[j], rng=rng)
            elif idx.size:  # the uniform background (label k)
                u = rng.normal(size=(idx.size, 3))
                x[idx] = u / np.linalg.norm(u, axis=1, keepdims=True)
        return x, labels

    def responsibilities(self, x) -> np.ndarray:
        """(n, k) posterior probabilities of each axis' Watson components (the background takes 1 - the row
        sum)."""
        lc = self._log_all(x)
        return np.exp(lc - logsumexp(lc, axis=-1, keepdims=True))[..., : len(self.weights)]


def _em(x, w, axes, kappas, weights, max_iter, tol, background=False):
    """EM from the given start; with ``background`` a uniform component (kappa pinned at 0) takes part, starting
    at the weight of one component."""
    ll_old = -np.inf
    k = len(weights)
    bg = 1.0 / (k + 1) if background else 0.0
    weights = weights / weights.sum() * (1.0 - bg)
    for _ in range(max_iter):
        mix = WatsonMixture(axes, kappas, weights, background=bg)
        lc = mix._log_all(x)
        lse = logsumexp(lc, axis=-1)
        ll = float(np.sum(w * lse))
        r = np.exp(lc - lse[:, None]) * w[:, None]  # (n, k [+ 1]) weighted responsibilities
        nk = r.sum(axis=0)
        share = np.maximum(nk / w.sum(), 1e-12)
        share /= share.sum()
        weights, bg = share[:k], (float(share[k]) if background else 0.0)
        S = np.einsum("ik,ij,il->kjl", r[:, :k], x, x) / np.maximum(nk[:k], 1e-300)[:, None, None]
        lam, vec = np.linalg.eigh(S)
        axes = vec[:, :, -1]
        kappas = np.array([_kappa_from_t2(lam[j, -1]) for j in range(k)])
        if abs(ll - ll_old) <= tol * (abs(ll) + 1.0):
            break
        ll_old = ll
    return WatsonMixture(axes, kappas, weights, ll, background=bg)


def fit_watson_mixture(
    directions,
    n_components: int = 3,
    *,
    weights=None,
    init_axes=None,
    n_init: int = 5,
    max_iter: int = 300,
    tol: float = 1e-8,
    background: bool = False,
    rng=None,
) -> WatsonMixture:
    r"""Fit a mixture of bipolar Watson distributions by EM (Sra & Karp 2013), with length weights.

    E-step: responsibilities :math:`r_{ij} \propto \pi_j f(x_i; \mu_j, \kappa_j)`. M-step, with line
    weights :math:`l_i`: :math:`\pi_j = \sum_i l_i r_{ij} / \sum_i l_i`, :math:`S_j = \sum_i l_i
    r_{ij} x_i x_i^T / \sum_i l_i r_{ij}`, :math:`\mu_j` the top eigenvector of :math:`S_j` and
    :math:`\kappa_j` the root of :math:`A(\kappa) = \lambda_{max}(S_j)` (bipolar components,
    :math:`\kappa \ge 0`).

    Parameters
    ----------
    directions : (n, 3) axes; weights : (n,) line lengths (default equal).
    n_components : number of Watson components.
    init_axes : optional (n_components, 3) starting axes (e.g. the rose's top cells); used as the
        first start.
    n_init : number of random starts (data axes spread by farthest-point seeding), in addition to
        ``init_axes``; the best likelihood wins. 0 is allowed with ``init_axes`` (fast bootstrap
        refits).
    background : add a uniform component (a Watson with :math:`\kappa = 0`, pinned) whose weight EM estimates
        with the others: axes that belong to no family (pieces traced through packed cells, which link fragments
        across sections in every direction) go there instead of pulling a component away from its family (the
        noise component of Banfield & Raftery 1993, Biometrics 49:803).
    rng : seed or Generator.

    Returns
    -------
    WatsonMixture with components sorted by decreasing weight (and the background weight).
    """
    x = _directions(directions)
    w = _weights(weights, len(x))
    k = int(n_components)
    if k < 1 or k > len(x):
        raise ValidationError("n_components", n_components, f"an integer in [1, {len(x)}]")
    rng = np.random.default_rng(rng)
    starts = []
    if init_axes is not None:
        starts.append(_check_mu(np.atleast_2d(init_axes)))
        if starts[0].shape != (k, 3):
            raise ValidationError("init_axes", f"shape {starts[0].shape}", f"({k}, 3)")
    if not starts and int(n_init) < 1:
        raise ValidationError("n_init", n_init, "an integer >= 1 when no init_axes are given")
    for _ in range(int(n_init)):
        idx = [rng.choice(len(x), p=w / w.sum())]
        for _ in range(k - 1):  # farthest-point (k-means++ style) seeding on the axial distance 1 - t^2
            dist = np.clip(np.min(1 - (x @ x[idx].T) ** 2, axis=1), 0.0, None) * w
            p = dist / dist.sum() if dist.sum() > 0 else w / w.sum()
            idx.append(rng.choice(len(x), p=p))
        starts.append(x[idx])
    best = None
    for a0 in starts:
        fit = _em(x, w, a0, np.full(k, 5.0), np.full(k, 1.0 / k), max_iter, tol, background)
        if best is None or fit.log_likelihood > best.log_likelihood:
            best = fit
    order = np.argsort(-best.weights, kind="stable")
    axes = best.axes[order] * np.where(best.axes[order, 2:3] < 0, -1.0, 1.0)
    return WatsonMixture(axes, best.kappas[order], best.weights[order], best.log_likelihood, best.background)
