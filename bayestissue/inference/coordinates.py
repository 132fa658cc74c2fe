"""Sampler coordinates: the map between the sampled parameters :math:`\\theta` and the unconstrained vector
:math:`z` the ensemble sampler moves in, and the generic tools to reshape it.

The posterior is the same in every coordinate system: the sampler's target is
:math:`\\log p(\\theta(z) \\mid y) + \\log|\\det \\partial\\theta/\\partial z|`. What changes is the *shape* the
sampler sees, and emcee's affine-invariant moves only cope with shapes that are close to an affine image of a
simple density.

``box`` (the default; :class:`~bayestissue.inference.parameters.ParameterSet` itself) is the logit of each
parameter's (log-)scaled box. A problem may be given any other coordinate system as a factory ``f(problem) ->
coordinates`` (an object with ``to_unconstrained``, ``from_unconstrained``, ``log_abs_det_jacobian`` and
``parameters``; optionally ``adapt(problem, theta_hat)``, called by :func:`adapt_coordinates` once the least
squares is known). The coordinates that know the physics (the creep-curve and ramp coordinates of the paper's
model) are built that way by :mod:`bayestissue.workflows.coordinates`; this module keeps what is generic:
:class:`ShearedCoordinates`, a base system sheared along a least-squares profile (:func:`profile_shear`), which
straightens a curved valley without touching the Jacobian.
"""

from __future__ import annotations

import numpy as np

from bayestissue._validation import ValidationError

__all__ = ["ShearedCoordinates", "adapt_coordinates", "make_coordinates", "profile_shear"]


def make_coordinates(kind, problem) -> object:
    """The coordinates of ``problem``: its box (``kind = "box"``) or ``kind(problem)`` for a factory."""
    if kind == "box":
        return problem.parameters
    if callable(kind):
        return kind(problem)
    raise ValidationError("sampler coordinates", kind, "'box' or a coordinate factory (bayestissue.workflows)")


def adapt_coordinates(problem, theta_hat):
    """The problem's coordinates refined around the least-squares estimate ``theta_hat`` (material + nuisance): their
    ``adapt`` method if they have one (e.g. a shear along a profile), else unchanged."""
    adapt = getattr(problem.coordinates, "adapt", None)
    if adapt is None:
        return problem.coordinates
    theta_hat = np.clip(np.asarray(theta_hat, dtype=float), problem.parameters.lower, problem.parameters.upper)
    return adapt(problem, theta_hat)


def _free_and_grids(free, grids) -> tuple[np.ndarray, list[np.ndarray]]:
    """Free-coordinate indices as an array and one float grid per free coordinate (a single grid
    may be passed bare for a single free coordinate)."""
    free = np.atleast_1d(np.asarray(free, dtype=int))
    if free.size == 1 and np.ndim(grids[0]) == 0:
        grids = [grids]
    return free, [np.asarray(g, dtype=float) for g in grids]


class ShearedCoordinates:
    """A base coordinate system sheared along the profile of one or two weakly informed coordinates.

    .. math::

        z'_d = z_d - c_d(z_F)\\ (d \\in D), \\qquad z'_j = z_j \\text{ otherwise},

    with :math:`c(z_F)` the least-squares optimum of the dependent coordinates :math:`D` at fixed
    free coordinates :math:`z_F` (a profile, :func:`profile_shear`), tabulated on a grid and
    interpolated between grid points (PCHIP for one free coordinate; a tensor-product cubic
    spline for two), held constant beyond it. The shift depends only on coordinates it does not
    move, so the map is triangular with unit diagonal: the Jacobian is 1 *whatever* :math:`c` is and
    :math:`\\log|\\det\\partial\\theta/\\partial z'|` is the base system's (interpolation error costs
    sampling efficiency, never correctness). It makes a curved valley whose position drifts with the
    flat coordinates straight, which is what affine-invariant moves need.

    Parameters
    ----------
    base : coordinates with ``to_unconstrained``, ``from_unconstrained``, ``log_abs_det_jacobian``.
    free : index of the free coordinate, or a sequence of two.
    dependent : indices of the shifted coordinates.
    grids : the grid of each free coordinate (one array, or a sequence of two).
    offsets : profile values, shape ``(*grid sizes, len(dependent))``.
    """

    def __init__(self, base, free, dependent, grids, offsets):
        from scipy.interpolate import PchipInterpolator, RegularGridInterpolator

        self.base = base
        self.parameters = base.parameters
        self.free, self.grids = _free_and_grids(free, grids)
        self.dependent = np.asarray(dependent, dtype=int)
        if len(self.grids) != self.free.size or self.free.size not in (1, 2):
            raise ValidationError("shear grids", f"{len(self.grids)} grids", "one grid per free coordinate (1 or 2)")
        offsets = np.asarray(offsets, dtype=float)
        shape = (*(g.size for g in self.grids), self.dependent.size)
        if offsets.shape != shape or not np.all(np.isfinite(offsets)):
            raise ValidationError("shear offsets", f"shape {offsets.shape}", f"finite values of shape {shape}")
        if self.free.size == 1:
            self._interp = PchipInterpolator(self.grids[0], offsets, axis=0)
        else:
            self._interp = RegularGridInterpolator(self.grids, offsets, method="cubic")

    def _shift(self, z) -> np.ndarray:
        pts = np.stack(
            [
                np.clip(np.nan_to_num(z[..., f], nan=0.0), g[0], g[-1])
                for f, g in zip(self.free, self.grids, strict=True)
            ],
            axis=-1,
        )
        if self.free.size == 1:
            return self._interp(pts[..., 0])
        flat = self._interp(pts.reshape(-1, self.free.size))
        return flat.reshape(*pts.shape[:-1], self.dependent.size)

    def to_unconstrained(self, theta) -> np.ndarray:
        z = self.base.to_unconstrained(theta)
        z[..., self.dependent] -= self._shift(z)
        return z

    def _base_z(self, z) -> np.ndarray:
        z = np.array(z, dtype=float, copy=True)
        z[..., self.dependent] += self._shift(z)
        return z

    def from_unconstrained(self, z) -> np.ndarray:
        return self.base.from_unconstrained(self._base_z(z))

    def log_abs_det_jacobian(self, z) -> np.ndarray:
        return self.base.log_abs_det_jacobian(self._base_z(z))


def profile_shear(problem, coords, theta_hat, free, dependent, grids) -> ShearedCoordinates:
    """Shear ``coords`` along the least-squares profile over the coordinate(s) ``free``.

    At every grid node the dependent coordinates are fitted by Levenberg-Marquardt (the material
    residuals of :meth:`CalibrationProblem.residuals`); nodes are visited outwards from the one
    nearest ``theta_hat``, each started from the optimum of an already fitted neighbour one step
    closer. Points whose image leaves the box are clipped into it for the fit only. Deterministic:
    the same data and ``theta_hat`` give the same coordinates (needed to resume a checkpointed run).
    """
    from scipy.optimize import least_squares

    free, grids = _free_and_grids(free, grids)
    dependent = np.asarray(dependent, dtype=int)
    z_hat = np.asarray(coords.to_unconstrained(np.atleast_2d(theta_hat)), dtype=float)[0]
    lo, hi = problem.parameters.lower, problem.parameters.upper
    m = problem.n_material

    def resid(q, zfree):
        z = z_hat.copy()
        z[free] = zfree
        z[dependent] = q
        th = coords.from_unconstrained(z[None])
        if not np.all(np.isfinite(th)):
            return np.full(problem.n_obs, 1e3)
        return problem.residuals(np.clip(th, lo, hi)[:, :m])[0]

    start = np.array([int(np.argmin(np.abs(g - z_hat[f]))) for f, g in zip(free, grids, strict=True)])
    shape = tuple(g.size for g in grids)
    nodes = sorted(np.ndindex(*shape), key=lambda ix: (int(np.abs(np.subtract(ix, start)).sum()), ix))
    offsets = np.empty((*shape, dependent.size))
    for ix in nodes:
        step = np.array(ix) - start
        if not step.any():
            q = z_hat[dependent]
        else:  # a neighbour one step closer to the start along the largest offset
            k = int(np.argmax(np.abs(step)))
            prev = np.array(ix)
            prev[k] -= np.sign(step[k])
            q = offsets[tuple(prev)]
        zfree = np.array([g[i] for g, i in zip(grids, ix, strict=True)])
        offsets[ix] = least_squares(resid, q, args=(zfree,), method="lm", max_nfev=100 * (dependent.size + 1)).x
    return ShearedCoordinates(coords, free, dependent, grids, offsets)
