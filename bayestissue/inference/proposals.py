"""A fitted Student-t mixture as an independence proposal for emcee.

Ensemble moves (differential evolution, stretch) propose along differences of walkers, so each step
moves a walker only about one ensemble spread's fraction; on a posterior that is a curved or
truncated body their autocorrelation time grows with its awkwardness. An *independence* proposal
jumps anywhere in one step: draw :math:`y \\sim q` regardless of the current :math:`x` and accept
with the Metropolis-Hastings probability (Hastings 1970; Tierney 1994, Section 2.3.3)

.. math::

    \\alpha(x \\to y) = \\min\\Big(1, \\frac{p(y)\\,q(x)}{p(x)\\,q(y)}\\Big),

which leaves :math:`p` invariant for *any* fixed :math:`q` whose support covers :math:`p`'s. Its
efficiency depends on how well :math:`q` matches :math:`p`: here a mixture of multivariate Student-t
densities (heavy tails keep :math:`p/q` bounded in the tails)

.. math::

    q(y) = \\sum_k w_k\\, t_\\nu(y;\\, m_k, s^2 C_k),\\qquad
    t_\\nu(y; m, \\Sigma) = \\frac{\\Gamma(\\frac{\\nu + d}{2})}{\\Gamma(\\frac{\\nu}{2})
    (\\nu\\pi)^{d/2} |\\Sigma|^{1/2}} \\Big(1 + \\frac{(y - m)^T\\Sigma^{-1}(y - m)}{\\nu}\\Big)^{-\\frac{\\nu + d}{2}},

with :math:`(w_k, m_k, C_k)` a Gaussian mixture fitted by EM (scikit-learn) to draws of an adaptation
phase, widened by :math:`s = 1.5` and :math:`\\nu = 5`. The mixture is fitted during burn-in and then
*frozen*; the production chain is an ordinary Metropolis-Hastings chain (adaptation that stops is
valid, Roberts & Rosenthal 2007). The run keeps it (:meth:`TMixture.to_hdf5`) so that a resumed run
proposes from the same density.
"""

from __future__ import annotations

from dataclasses import dataclass

import emcee
import numpy as np
from scipy.linalg import solve_triangular
from scipy.special import gammaln, logsumexp

from bayestissue._validation import ValidationError

__all__ = ["MixtureMove", "TMixture", "fit_t_mixture"]


@dataclass(frozen=True)
class TMixture:
    """A mixture of multivariate Student-t densities (module docstring)."""

    weights: np.ndarray  # (K,)
    means: np.ndarray  # (K, d)
    covs: np.ndarray  # (K, d, d) scale matrices Sigma_k
    df: float

    def __post_init__(self):
        w, m, c = (np.asarray(a, dtype=float) for a in (self.weights, self.means, self.covs))
        k, d = m.shape
        if w.shape != (k,) or c.shape != (k, d, d) or not np.isclose(w.sum(), 1.0) or np.any(w < 0):
            raise ValidationError(
                "t mixture",
                f"weights {w.shape}, means {m.shape}, covs {c.shape}",
                "K weights >= 0 summing to 1, (K, d) means, (K, d, d) scales",
            )
        if not self.df > 0:
            raise ValidationError("t mixture df", self.df, "a number > 0")
        chol = np.linalg.cholesky(c)
        object.__setattr__(self, "_chol", chol)
        object.__setattr__(self, "_log_det", np.log(np.diagonal(chol, axis1=1, axis2=2)).sum(axis=1))

    @property
    def ndim(self) -> int:
        return int(np.shape(self.means)[1])

    def sample(self, n: int, random: np.random.RandomState) -> np.ndarray:
        """``n`` draws, using the legacy ``RandomState`` emcee passes to moves (reproducible runs)."""
        k = random.choice(len(self.weights), size=n, p=self.weights)
        g = random.standard_normal((n, self.ndim))
        scale = np.sqrt(self.df / random.chisquare(self.df, size=n))
        return self.means[k] + scale[:, None] * np.einsum("nij,nj->ni", self._chol[k], g)

    def logpdf(self, x) -> np.ndarray:
        """:math:`\\log q(x)` for ``x`` of shape ``(n, d)``."""
        x = np.atleast_2d(np.asarray(x, dtype=float))
        d, nu = self.ndim, self.df
        const = gammaln((nu + d) / 2) - gammaln(nu / 2) - 0.5 * d * np.log(nu * np.pi)
        terms = []
        for w, m, chol, log_det in zip(self.weights, self.means, self._chol, self._log_det, strict=True):
            r = solve_triangular(chol, (x - m).T, lower=True)
            maha = np.sum(r * r, axis=0)
            terms.append(np.log(w) + const - log_det - 0.5 * (nu + d) * np.log1p(maha / nu))
        return logsumexp(np.stack(terms), axis=0)

    def to_hdf5(self, path, name: str) -> None:
        """Store under group ``name`` of the HDF5 file ``path`` (replacing an earlier one)."""
        import h5py

        with h5py.File(path, "a") as f:
            if name in f:
                del f[name]
            g = f.create_group(name)
            for key in ("weights", "means", "covs"):
                g.create_dataset(key, data=np.asarray(getattr(self, key), dtype=float))
            g.attrs["df"] = float(self.df)

    @classmethod
    def from_hdf5(cls, path, name: str) -> TMixture | None:
        """The mixture stored under ``name``, or None if there is none."""
        import h5py

        with h5py.File(path, "r") as f:
            if name not in f:
                return None
            g = f[name]
            return cls(g["weights"][()], g["means"][()], g["covs"][()], float(g.attrs["df"]))


def fit_t_mixture(draws, *, n_components: int = 16, widen: float = 1.5, df: float = 5.0, seed: int = 0) -> TMixture:
    """Fit the proposal to ``draws`` (n, d): EM for a full-covariance Gaussian mixture (scikit-learn,
    two initialisations), scales widened by ``widen`` and tails made Student-t with ``df``.

    ``n_components`` is reduced so that every component has at least ``20 d`` draws.
    """
    from sklearn.mixture import GaussianMixture
    from threadpoolctl import threadpool_limits

    draws = np.asarray(draws, dtype=float)
    if draws.ndim != 2 or not np.all(np.isfinite(draws)):
        raise ValidationError("mixture draws", f"array of shape {draws.shape}", "finite values of shape (n, d)")
    n, d = draws.shape
    k = max(1, min(int(n_components), n // (20 * d)))
    if n < 2 * (d + 1):
        raise ValidationError("mixture draws", f"{n} draws", f"at least {2 * (d + 1)} for {d} dimensions")
    scale = draws.std(axis=0).mean()
    gm = GaussianMixture(
        k,
        covariance_type="full",
        reg_covar=1e-8 * scale**2 + 1e-12,
        max_iter=500,
        n_init=2,
        init_params="k-means++",
        random_state=seed,
    )
    # one OpenMP thread: the ensembles run in forked processes, and a GNU OpenMP pool started in the
    # parent (by any earlier fit) deadlocks a forked child's first parallel region
    with threadpool_limits(limits=1):
        gm.fit(draws)
    return TMixture(gm.weights_ / gm.weights_.sum(), gm.means_, gm.covariances_ * widen**2, df)


class MixtureMove(emcee.moves.MHMove):
    """Independence Metropolis-Hastings move with proposal ``mixture`` (a :class:`TMixture`): the
    log-ratio passed to emcee is :math:`\\log q(x) - \\log q(y)` (module docstring)."""

    def __init__(self, mixture: TMixture):
        self.mixture = mixture
        super().__init__(self._propose, ndim=mixture.ndim)

    def _propose(self, coords, random):
        y = self.mixture.sample(coords.shape[0], random)
        return y, self.mixture.logpdf(coords) - self.mixture.logpdf(y)
