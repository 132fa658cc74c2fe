"""Sampler coordinates: the map between the sampled parameters :math:`\\theta` and the
unconstrained vector :math:`z` the ensemble sampler moves in.

The posterior is the same in every coordinate system: the sampler's target is
:math:`\\log p(\\theta(z) \\mid y) + \\log|\\det \\partial\\theta/\\partial z|`. What changes is the
*shape* the sampler sees, and emcee's affine-invariant moves only cope with shapes that are close to
an affine image of a simple density. Two systems:

``box`` (default; :class:`~bayestissue.inference.parameters.ParameterSet` itself)
    Per parameter, the logit of the (log-)scaled box.

``creep`` (:class:`CreepCoordinates`)
    For the matrix parameters :math:`\\mu, \\kappa` and one Kelvin fibre law
    :math:`g_\\infty, \\gamma, \\beta`, the quantities a uniaxial creep curve actually carries.
    Seen in the paper's parameters, the T1 posterior is an "L" in
    :math:`(\\log\\mu, \\log\\kappa)` (only a weighted sum of the two is informed: the split is flat
    to 0.13 in :math:`-2\\log L` over :math:`\\mu/(\\mu + \\kappa)` from 0.0003 to 0.9997) joined to
    a thin curved ridge in :math:`(g_\\infty, \\gamma, \\beta)`; ensembles started on the two arms
    of the L never meet (R-hat 2.1 after 6000 steps).

``ramp`` (:class:`RampCoordinates`)
    The box coordinates, sheared (:class:`ShearedCoordinates`, by :func:`adapt_coordinates`) along
    the least-squares profile over the fibre law's viscosity :math:`(z_\\gamma, z_\\beta)` with
    :math:`(z_{g_\\infty}, z_\\kappa)` dependent, then along the profile over :math:`z_\\mu` with the
    same two dependent. A force ramp (T2) carries the fibres' effective stiffness over the ramp,
    which lies between :math:`g_\\infty` (relaxed) and :math:`g_\\infty/(1-\\gamma)` (instantaneous)
    depending on :math:`\\beta` times the ramp's duration: :math:`g_\\infty` follows
    :math:`(\\gamma, \\beta)` along a curved valley that ends in a cliff where the relaxed stiffness
    alone is already too stiff, and :math:`\\kappa` bends where :math:`\\mu` reaches its own cliff.
    Measured on the T2 replica (mirror model): a Student-t mixture fitted to 1944 posterior draws and
    tested on the other 1944 is accepted as an independence proposal 0.04 of the time in box
    coordinates, 0.29-0.31 after the first shear and 0.34-0.38 after both; sampled with
    ``moves="mixture"`` (36 walkers, 2 x 500 adaptation steps) tau fell from 340-600 steps (box,
    R-hat 1.019-1.066 at 6000 steps) to 20-25 (R-hat 1.0004 after 2100-3900 steps).

The creep coordinates linearise a homogeneous incompressible uniaxial stretch :math:`\\lambda_r`
(the secant of the data's typical stretch). The nominal stresses of the matrix (docs/model.md) and of a
tension fibre :math:`k` are then

.. math::

    P_m = \\phi_m (1 - \\lambda^{-3}) (\\lambda \\mu + \\kappa), \\qquad
    P_k = \\phi_k \\lambda v_{k,x}^2\\, \\tau_k, \\quad
    \\varepsilon_k = \\tfrac12\\big(\\lambda^2 v_{k,x}^2 + \\lambda^{-1}(1 - v_{k,x}^2) - 1\\big),

so the matrix secant modulus is :math:`A = \\alpha(\\lambda_r\\mu + \\kappa)` and the fibres'
:math:`B = b\\, g_\\infty` with :math:`\\alpha = \\phi_m (1 - \\lambda_r^{-3})/(\\lambda_r - 1)`,
:math:`b = \\sum_k \\phi_k \\lambda_r v_{k,x}^2 \\max(\\varepsilon_k, 0)/(\\lambda_r - 1)` over the
families that use the law. A spring :math:`A` in parallel with the Kelvin element (paper eqs. 5-9 in
continuous form) creeps under a constant stress :math:`P` as

.. math::

    \\frac{\\lambda(t) - 1}{P} = \\frac{1}{E_\\infty} - \\Big(\\frac{1}{E_\\infty} -
    \\frac{1}{E_0}\\Big) e^{-\\beta_c t},\\quad
    E_\\infty = A + B,\\ E_0 = A + \\frac{B}{1 - \\gamma},\\
    \\beta_c = \\frac{\\beta E_\\infty}{(1 - \\gamma) E_0},

and the coordinates are

.. math::

    z_f = \\operatorname{logit}\\frac{\\lambda_r\\mu}{\\lambda_r\\mu + \\kappa},\\
    z_m = \\log\\frac{A}{B},\\ z_0 = \\log E_0,\\
    z_J = \\log\\Big(\\frac{1}{E_\\infty} - \\frac{1}{E_0}\\Big),\\ z_c = \\log\\beta_c,

with the closed-form inverse :math:`E_\\infty = (e^{z_J} + 1/E_0)^{-1}`, :math:`A = \\sigma(z_m)
E_\\infty`, :math:`B = E_\\infty - A`, :math:`\\gamma = 1 - B/(E_0 - A)`, :math:`\\beta = e^{z_c} (1
- \\gamma) E_0 / E_\\infty`. Every image lies in :math:`0 < \\gamma < 1` and positive moduli; the box
(Table 1) is enforced by the prior (``-inf`` outside). The Jacobian is exact whatever
:math:`\\lambda_r`, :math:`\\alpha` and :math:`b` are (they only shape the coordinates):

.. math::

    \\Big|\\det \\frac{\\partial(\\mu, \\kappa, g_\\infty, \\gamma, \\beta)}{\\partial(z_f, z_m, z_0,
    z_J, z_c)}\\Big| = \\mu\\, \\kappa\\, g_\\infty\\, \\beta\\, \\gamma (1 - \\gamma),

(checked against finite differences in ``tests/inference/test_coordinates.py``), so with
log-uniform priors on :math:`\\mu, \\kappa, g_\\infty, \\beta` and a uniform one on :math:`\\gamma`
the prior density in these coordinates is :math:`\\propto \\gamma(1-\\gamma)` on the box's image.
All other sampled parameters keep the box coordinates.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy.special import expit

from bayestissue._validation import ValidationError, check_positive
from bayestissue.inference.parameters import ParameterSet

__all__ = ["COORDINATES", "CreepCoordinates", "RampCoordinates", "make_coordinates"]

#: Coordinate systems the sampler can move in.
COORDINATES = ("box", "creep", "ramp")


class CreepCoordinates:
    """Creep-curve coordinates for :math:`(\\mu, \\kappa)` and one fibre law (module docstring).

    Parameters
    ----------
    parameters : ParameterSet
        All sampled parameters; ``mu``, ``kappa`` and the fibre law's ``ginf``, ``gamma``, ``beta``
        must be sampled (not fixed or tied).
    stretch : float
        Reference stretch :math:`\\lambda_r > 1`.
    phi_matrix : float
        Matrix volume fraction.
    fibres : sequence of (phi_k, v_k)
        Volume fraction and unit direction of every family that uses the law (e.g. families 2 and 3
        when family 3 is tied to family 2).
    law : names of the law's (ginf, gamma, beta).
    """

    def __init__(
        self,
        parameters: ParameterSet,
        *,
        stretch: float,
        phi_matrix: float,
        fibres: Sequence,
        law: Sequence[str] = ("ginf2", "gamma2", "beta2"),
    ):
        self.parameters = parameters
        lam = check_positive("reference stretch", stretch)
        if lam <= 1.0:
            raise ValidationError("reference stretch", lam, "a stretch > 1")
        names = parameters.sampled_names
        needed = ["mu", "kappa", *law]
        missing = [n for n in needed if n not in names]
        if missing:
            raise ValidationError(
                "creep coordinates", f"{missing} not sampled", "mu, kappa and the fibre law's ginf, gamma, beta sampled"
            )
        self.slots = np.array([names.index(n) for n in needed])
        self.other = np.array([i for i in range(len(names)) if i not in set(self.slots.tolist())], dtype=int)
        self.stretch = lam
        self.alpha = float(phi_matrix) * (1.0 - lam**-3) / (lam - 1.0)
        b = 0.0
        for phi_k, v in fibres:
            v = np.asarray(v, dtype=float)
            vx2 = v[0] ** 2 / float(v @ v)
            eps = 0.5 * (lam**2 * vx2 + (1.0 - vx2) / lam - 1.0)
            b += float(phi_k) * lam * vx2 * max(eps, 0.0) / (lam - 1.0)
        if b <= 0:
            raise ValidationError("creep coordinates", "fibre law in compression", "a family stretched along x")
        self.b = b

    def _check(self, x) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        n = self.parameters.n_sampled
        if x.shape[-1:] != (n,) or x.ndim > 2:
            raise ValidationError("coordinates", f"array of shape {x.shape}", f"shape (n_sets, {n})")
        return x

    def to_unconstrained(self, theta) -> np.ndarray:
        theta = self._check(theta)
        z = np.array(self.parameters.to_unconstrained(theta), dtype=float)
        mu, kappa, g, gam, beta = np.moveaxis(theta[..., self.slots], -1, 0)
        lam = self.stretch
        with np.errstate(divide="ignore", invalid="ignore"):
            a_mod = self.alpha * (lam * mu + kappa)
            b_mod = self.b * g
            e_inf = a_mod + b_mod
            e_0 = a_mod + b_mod / (1.0 - gam)
            zs = [
                np.log(lam * mu) - np.log(kappa),
                np.log(a_mod) - np.log(b_mod),
                np.log(e_0),
                np.log(1.0 / e_inf - 1.0 / e_0),
                np.log(beta * e_inf / ((1.0 - gam) * e_0)),
            ]
        z[..., self.slots] = np.stack(zs, axis=-1)
        return z

    def _creep_inverse(self, z):
        z_f, z_m, z_0, z_j, z_c = np.moveaxis(z[..., self.slots], -1, 0)
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            e_0 = np.exp(z_0)
            e_inf = 1.0 / (np.exp(z_j) + 1.0 / e_0)
            a_mod = expit(z_m) * e_inf
            b_mod = e_inf - a_mod
            gam = 1.0 - b_mod / (e_0 - a_mod)
            beta = np.exp(z_c) * (1.0 - gam) * e_0 / e_inf
            s = a_mod / self.alpha  # lambda mu + kappa
            f = expit(z_f)
            mu = s * f / self.stretch
            kappa = s * (1.0 - f)
            g = b_mod / self.b
        return mu, kappa, g, gam, beta

    def _box_z(self, z) -> np.ndarray:
        """``z`` with the creep slots zeroed, for the box map of the other parameters."""
        zb = np.array(z, dtype=float, copy=True)
        zb[..., self.slots] = 0.0
        return zb

    def from_unconstrained(self, z) -> np.ndarray:
        z = self._check(z)
        theta = np.array(self.parameters.from_unconstrained(self._box_z(z)), dtype=float)
        theta[..., self.slots] = np.stack(self._creep_inverse(z), axis=-1)
        return theta

    def log_abs_det_jacobian(self, z) -> np.ndarray:
        """:math:`\\log|\\det \\partial\\theta/\\partial z|` (``-inf`` where the image is degenerate)."""
        z = self._check(z)
        box = self.parameters.log_abs_det_jacobian_terms(self._box_z(z))[..., self.other].sum(axis=-1)
        mu, kappa, g, gam, beta = self._creep_inverse(z)
        with np.errstate(divide="ignore", invalid="ignore"):
            creep = np.log(mu) + np.log(kappa) + np.log(g) + np.log(beta) + np.log(gam) + np.log1p(-gam)
        out = box + creep
        return np.where(np.isfinite(out), out, -np.inf)


def make_coordinates(kind: str, problem) -> object:
    """The coordinates ``kind`` (one of :data:`COORDINATES`) for a calibration problem.

    ``creep`` and ``ramp`` use fibre family 2's law (``ginf2``, ``gamma2``, ``beta2``); ``creep`` needs the
    problem's ``geometry`` (plain numbers the caller derives from its model: the reference ``stretch``,
    ``phi_matrix`` and the ``fibres`` ``(phi_k, v_k)`` that use the law; see
    :func:`bayestissue.workflows.problem.creep_geometry`).
    """
    if kind not in COORDINATES:
        raise ValidationError("sampler coordinates", kind, f"one of {list(COORDINATES)}")
    if kind == "box":
        return problem.parameters
    if kind == "ramp":
        return RampCoordinates(problem.parameters)
    if problem.geometry is None:
        raise ValidationError(
            "sampler coordinates", kind, "'box' or 'ramp' for a problem without geometry (stretch, phi_matrix, fibres)"
        )
    return CreepCoordinates(problem.parameters, **problem.geometry)


class RampCoordinates:
    """The box coordinates of ``parameters`` (identity on top of the box's logit map), marked for
    :func:`adapt_coordinates` to shear along the profile over the fibre law's ``gamma``, ``beta``
    with its ``ginf`` and ``kappa`` dependent (module docstring, ``ramp``).

    Raises
    ------
    ValidationError
        If ``kappa`` or any of the law's parameters is not sampled.
    """

    def __init__(self, parameters: ParameterSet, *, law: Sequence[str] = ("ginf2", "gamma2", "beta2")):
        self.parameters = parameters
        names = parameters.sampled_names
        ginf, gamma, beta = law
        missing = [n for n in ("mu", "kappa", *law) if n not in names]
        if missing:
            raise ValidationError(
                "ramp coordinates", f"{missing} not sampled", "mu, kappa and the fibre law's ginf, gamma, beta sampled"
            )
        self.free = np.array([names.index(gamma), names.index(beta)])
        self.dependent = np.array([names.index(ginf), names.index("kappa")])
        self.mu = names.index("mu")

    def to_unconstrained(self, theta) -> np.ndarray:
        return self.parameters.to_unconstrained(theta)

    def from_unconstrained(self, z) -> np.ndarray:
        return self.parameters.from_unconstrained(z)

    def log_abs_det_jacobian(self, z) -> np.ndarray:
        return self.parameters.log_abs_det_jacobian(z)


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


def _shear_grids(coords: CreepCoordinates, theta_hat) -> list[np.ndarray]:
    """Grids over the matrix split and share that cover the box at the estimate's moduli.

    With :math:`E_0, E_\\infty` of ``theta_hat`` held, the box bounds :math:`\\mu, \\kappa \\ge \\ell_m`,
    :math:`g_\\infty \\ge \\ell_g` and :math:`\\gamma \\le \\gamma_u` limit the split to
    :math:`|z_f| \\lesssim \\log(\\lambda_r E_\\infty / (\\alpha \\ell_m))` and the share
    :math:`s = A/E_\\infty = \\sigma(z_m)` to

    .. math::

        \\frac{\\alpha(\\lambda_r + 1)\\ell_m}{E_\\infty} \\le s \\le
        \\min\\Big(1 - \\frac{b\\,\\ell_g}{E_\\infty},\\
        \\frac{E_0 - (E_0 - E_\\infty)/\\gamma_u}{E_\\infty}\\Big)

    (from :math:`\\gamma = (E_0 - E_\\infty)/(E_0 - A)`). The share grid ends at the upper limit:
    beyond it the least-squares profile jumps (the fit is clipped at the bound of :math:`\\gamma`) and
    a spline through the jump would ring inside the support. Limits are capped at 15 either side.
    """
    pars = coords.parameters
    i_mu, i_kappa, i_g, i_gam = coords.slots[:4]
    lo_m = min(pars.lower[i_mu], pars.lower[i_kappa])
    mu, kappa, g, gam = np.asarray(theta_hat, dtype=float)[[i_mu, i_kappa, i_g, i_gam]]
    lam = coords.stretch
    a_mod, b_mod = coords.alpha * (lam * mu + kappa), coords.b * g
    e_inf = a_mod + b_mod
    e_0 = a_mod + b_mod / (1.0 - gam)
    half = float(np.clip(np.log(lam * e_inf / (coords.alpha * lo_m)) + 1.0, 2.0, 15.0))
    s_lo = coords.alpha * (lam + 1.0) * lo_m / e_inf
    s_hi = min(1.0 - coords.b * pars.lower[i_g] / e_inf, (e_0 - (e_0 - e_inf) / pars.upper[i_gam]) / e_inf)
    s_hi = float(np.clip(s_hi, a_mod / e_inf, 1.0 - 1e-6))  # the estimate itself is inside
    s_lo = float(np.clip(s_lo, 1e-7, s_hi / 2.0))
    z_lo = max(float(np.log(s_lo) - np.log1p(-s_lo)) - 1.0, -15.0)
    z_hi = min(float(np.log(s_hi) - np.log1p(-s_hi)), 15.0)
    return [np.linspace(-half, half, 11), np.linspace(z_lo, z_hi, 17)]


#: Grids of the ``ramp`` shears (logit of the scaled box; [-6, 6] holds all but 0.5 % of a uniform prior's
#: mass, mu's grid covers the log-uniform prior's range down to 1e-5 of the box). Node spacing 0.3 for
#: (gamma, beta): the mixture acceptance of the module docstring was 0.24 with spacing 0.5 and 0.29-0.31
#: with 0.25; the 1681 + 65 profile fits take about 8 s on T2.
RAMP_GRID = np.linspace(-6.0, 6.0, 41)
RAMP_MU_GRID = np.linspace(-12.0, 4.0, 65)


def adapt_coordinates(problem, theta_hat):
    """Problem-specific refinement before sampling: the ``creep`` coordinates are sheared along the
    two-dimensional least-squares profile over the matrix split :math:`z_f` and share :math:`z_m`
    (the flat directions of a creep test), the ``ramp`` coordinates along the profile over the
    fibre law's :math:`(z_\\gamma, z_\\beta)` (the flat directions of a force ramp) and then over
    :math:`z_\\mu`, all around the least-squares estimate ``theta_hat`` (material + nuisance). Box
    coordinates are returned unchanged.

    Measured on the T1 replica (mirror model, 36 walkers, 2000 steps): acceptance 0.044 with the two
    earlier one-dimensional shears (split, then share), 0.079 with this two-dimensional one; the
    dependent coordinates' conditional means no longer drift with :math:`(z_f, z_m)`.
    """
    coords = problem.coordinates
    if not isinstance(coords, (CreepCoordinates, RampCoordinates)):
        return coords
    theta_hat = np.clip(np.asarray(theta_hat, dtype=float), problem.parameters.lower, problem.parameters.upper)
    if isinstance(coords, RampCoordinates):
        sheared = profile_shear(problem, coords, theta_hat, coords.free, coords.dependent, [RAMP_GRID, RAMP_GRID])
        return profile_shear(problem, sheared, theta_hat, coords.mu, coords.dependent, RAMP_MU_GRID)
    s = coords.slots
    return profile_shear(problem, coords, theta_hat, s[:2], s[2:], _shear_grids(coords, theta_hat))
