"""Initial walkers around a least-squares optimum (Laplace scatter, mapped to the sampler's coordinates)."""

from __future__ import annotations

import emcee
import numpy as np

from bayestissue._validation import ValidationError
from bayestissue.inference.problem import CalibrationProblem

__all__ = ["initial_walkers"]


def initial_walkers(
    problem: CalibrationProblem,
    center,
    n_walkers: int,
    *,
    cov=None,
    scatter: float = 1.0,
    nuisance_sd_z: float = 0.1,
    max_sd_z: float = 0.3,
    min_sd_z: float = 1e-4,
    rng=None,
) -> np.ndarray:
    """Initial walker positions in the unconstrained space, ``(n_walkers, ndim)``.

    The centre :math:`\\hat\\theta` (natural units, clipped to :math:`u \\in [10^{-4}, 1 - 10^{-4}]`
    so a parameter on its bound maps to a finite :math:`z`) is mapped to :math:`\\hat z` by the
    problem's sampler coordinates; the material block of ``cov`` (natural units, e.g. the
    Gauss-Newton covariance) is mapped by their Jacobian :math:`D = dz/d\\theta` (central
    differences), :math:`\\Sigma_z = D \\Sigma D^T`,
    its eigenvalues clipped to ``[min_sd_z**2, max_sd_z**2]``; nuisance parameters get
    ``nuisance_sd_z``. Walkers with a non-finite log-posterior are redrawn; the set passes emcee's
    linear-independence check.

    Raises
    ------
    ValidationError
        If ``center`` has the wrong shape or no valid walkers can be drawn.
    """
    rng = np.random.default_rng(rng)
    pars = problem.parameters
    center = np.asarray(center, dtype=float).ravel()
    if center.shape != (problem.ndim,):
        raise ValidationError("center", f"shape {center.shape}", f"shape ({problem.ndim},)")
    u = np.clip(pars.to_unit(center), 1e-4, 1 - 1e-4)
    theta_c = pars.from_unit(u)
    coords = problem.coordinates
    z_c = coords.to_unconstrained(theta_c)
    if not np.all(np.isfinite(z_c)):
        raise ValidationError("center", theta_c, "a point the sampler coordinates can represent")
    cov_z = np.diag(np.full(problem.ndim, nuisance_sd_z**2))
    m = problem.n_material
    if cov is not None:
        cov = np.asarray(cov, dtype=float)
        if cov.shape != (m, m):
            raise ValidationError("cov", f"shape {cov.shape}", f"shape ({m}, {m}) (material block)")
        # dz/dtheta by central differences (relative step 1e-6; the maps are smooth inside the box)
        h = 1e-6 * np.maximum(np.abs(theta_c), 1e-3 * (pars.upper - pars.lower))
        steps = np.diag(h)
        dzdx = (coords.to_unconstrained(theta_c + steps) - coords.to_unconstrained(theta_c - steps)).T / (2 * h)
        full = np.zeros((problem.ndim, problem.ndim))
        full[:m, :m] = cov
        block = (dzdx @ full @ dzdx.T)[:m, :m]
        block = np.where(np.isfinite(block), block, 0.0)
        block = 0.5 * (block + block.T)
        w, v = np.linalg.eigh(block)
        w = np.clip(w, min_sd_z**2, max_sd_z**2)
        cov_z[:m, :m] = (v * w) @ v.T
    else:
        cov_z[:m, :m] = np.diag(np.full(m, (0.1 * max_sd_z) ** 2))
    chol = np.linalg.cholesky(cov_z * scatter**2)
    walkers = z_c + rng.standard_normal((n_walkers, problem.ndim)) @ chol.T
    for attempt in range(20):
        lp = problem.log_posterior_unconstrained(walkers)
        bad = ~np.isfinite(lp)
        if not np.any(bad) and emcee.ensemble.walkers_independent(walkers):
            return walkers
        # redraw around the centre; after 10 rounds (a centre next to a region where solves fail) around
        # walkers already valid, at a tenth of the scatter
        base = z_c
        if attempt >= 10 and np.any(~bad):
            base = walkers[rng.choice(np.flatnonzero(~bad), int(bad.sum()))]
        scale = 1.0 if attempt < 10 else 0.1
        walkers[bad] = base + scale * rng.standard_normal((int(bad.sum()), problem.ndim)) @ chol.T
        if not np.any(bad):  # degenerate: add jitter
            walkers += 1e-3 * rng.standard_normal(walkers.shape)
    raise ValidationError(
        "initial walkers",
        f"{int(bad.sum())} of {n_walkers} with -inf log-posterior",
        "finite log-posterior at the start",
        "check the centre (least-squares estimate) and the forward model",
    )
