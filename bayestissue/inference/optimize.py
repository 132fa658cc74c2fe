"""The one bounded least-squares routine: trust-region reflective with a batched forward-difference
Jacobian.

Both the warm start (:mod:`bayestissue.inference.warmstart`, the paper's Section 2.7 fit) and the
profile likelihood (:mod:`bayestissue.identifiability.profile`) minimise

.. math:: F(v) = \\tfrac12 \\lVert r(v) \\rVert^2, \\qquad \\ell \\le v \\le u,

with scipy's trust-region-reflective method (``least_squares(method="trf")``, Branch, Coleman & Li
1999, doi:10.1137/S1064827595289108; the method of the paper's Section 2.7.1). The residuals come
from a *batched* function ``batch(V) -> R`` of shape ``(m, n_v) -> (m, n_obs)``, so the forward
differences

.. math::

    J_{:,k} \\approx \\frac{r(v + h_k e_k) - r(v)}{h_k}, \\qquad
    h_k = \\epsilon_{rel} \\max(|v_k|, f_k), \\quad h_k \\to -h_k \\text{ if } v_k + h_k > u_k,

cost one batched forward call of ``n_v`` rows per Jacobian, :math:`r(v)` being reused from the last
residual evaluation at the same :math:`v` (the step points away from the upper bound so that every
evaluated point is feasible). The callers differ only in their variables (natural units, the scaled
box, log space with some coordinates held fixed), step rule and tolerances, which they pass in. Where the forward
model has exact sensitivities (:meth:`bayestissue.mechanics.ForwardModel.sensitivities`) the caller passes the
exact Jacobian instead (the paper's Section 2.7.1: the method "works best when the gradients are provided").
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy.optimize import OptimizeResult, least_squares

__all__ = ["ForwardDifferences", "least_squares_trf"]


class ForwardDifferences:
    """Residuals at one point and their forward-difference Jacobian from a batched residual function.

    ``fun(v)`` evaluates and remembers :math:`r(v)`; ``jac(v)`` builds :math:`J(v)` from one batched
    call of the ``n_v`` shifted points (see the module docstring for :math:`h_k`).
    """

    def __init__(self, batch: Callable[[np.ndarray], np.ndarray], upper, *, rel_step: float, step_floor):
        self.batch, self.upper = batch, np.asarray(upper, dtype=float)
        self.rel_step, self.step_floor = float(rel_step), step_floor
        self._v = self._f = None

    def fun(self, v: np.ndarray) -> np.ndarray:
        f = np.asarray(self.batch(np.asarray(v, dtype=float)[None, :])[0], dtype=float)
        self._v, self._f = np.array(v, dtype=float), f
        return f

    def jac(self, v: np.ndarray, *_args) -> np.ndarray:
        v = np.asarray(v, dtype=float)
        if self._v is None or not np.array_equal(v, self._v):
            self.fun(v)
        h = self.rel_step * np.maximum(np.abs(v), self.step_floor)
        h = np.where(v + h > self.upper, -h, h)
        shifted = self.batch(v[None, :] + np.diag(h))
        return ((shifted - self._f[None, :]) / h[:, None]).T


def least_squares_trf(
    batch: Callable[[np.ndarray], np.ndarray],
    v0,
    lower,
    upper,
    *,
    rel_step: float,
    step_floor=1.0,
    x_scale=1.0,
    ftol: float = 1e-10,
    xtol: float = 1e-10,
    gtol: float = 1e-10,
    max_nfev: int | None = None,
    callback: Callable | None = None,
    jacobian: Callable[[np.ndarray], np.ndarray] | None = None,
) -> OptimizeResult:
    """Minimise :math:`\\tfrac12\\lVert r(v)\\rVert^2` over the box :math:`[\\ell, u]` from ``v0``.

    Parameters
    ----------
    batch : ``(m, n_v) -> (m, n_obs)`` residuals (finite: the caller replaces failed simulations).
    v0, lower, upper : start and bounds in the solver's variables.
    rel_step, step_floor : the difference step :math:`h_k = \\epsilon_{rel}\\max(|v_k|, f_k)`
        (``step_floor`` a scalar or one value per variable).
    x_scale, ftol, xtol, gtol, max_nfev, callback : passed to :func:`scipy.optimize.least_squares`.
    jacobian : ``v -> J`` ``(n_obs, n_v)``, the exact Jacobian (e.g. from the forward model's sensitivities);
        None: the forward differences above.

    Returns
    -------
    scipy's ``OptimizeResult`` (``x``, ``cost`` :math:`=F`, ``fun``, ``jac``, ``active_mask``, ``nfev``,
    ``njev``, ``status``, ``message``).
    """
    diff = ForwardDifferences(batch, upper, rel_step=rel_step, step_floor=step_floor)
    kw = {} if callback is None else {"callback": callback}
    return least_squares(
        diff.fun,
        np.asarray(v0, dtype=float),
        jac=diff.jac if jacobian is None else (lambda v, *_: jacobian(np.asarray(v, dtype=float))),
        bounds=(np.asarray(lower, dtype=float), np.asarray(upper, dtype=float)),
        method="trf",
        x_scale=x_scale,
        ftol=ftol,
        xtol=xtol,
        gtol=gtol,
        max_nfev=max_nfev,
        **kw,
    )
