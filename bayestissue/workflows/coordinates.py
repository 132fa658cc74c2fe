"""Sampler coordinates that know the physics: the paper's model seen as a creep curve or a force ramp.

The generic machinery (the box, shears along least-squares profiles) is :mod:`bayestissue.inference.coordinates`;
these two systems need the mechanics (the matrix and fibre laws, the loading) and so live here, where mechanics
meets inference. Both are the paper's laws' (a Mooney-Rivlin matrix, the Kelvin fibre of family 2); another
law samples in box coordinates.

The posterior is the same in every coordinate system: the sampler's target is
:math:`\\log p(\\theta(z) \\mid y) + \\log|\\det \\partial\\theta/\\partial z|`. What changes is the
*shape* the sampler sees, and emcee's affine-invariant moves only cope with shapes that are close to
an affine image of a simple density. Two systems:

``creep`` (:class:`CreepCoordinates`)
    For the matrix parameters :math:`\\mu, \\kappa` and one Kelvin fibre law
    :math:`g_\\infty, \\gamma, \\beta`, the quantities a uniaxial creep curve actually carries.
    Seen in the paper's parameters, the T1 posterior is an "L" in
    :math:`(\\log\\mu, \\log\\kappa)` (only a weighted sum of the two is informed: the split is flat
    to 0.13 in :math:`-2\\log L` over :math:`\\mu/(\\mu + \\kappa)` from 0.0003 to 0.9997) joined to
    a thin curved ridge in :math:`(g_\\infty, \\gamma, \\beta)`; ensembles started on the two arms
    of the L never meet (R-hat 2.1 after 6000 steps).

``ramp`` (:class:`RampCoordinates`)
    The box coordinates, sheared (:class:`~bayestissue.inference.coordinates.ShearedCoordinates`, by its
    ``adapt``) along the least-squares profile over the fibre law's viscosity :math:`(z_\\gamma, z_\\beta)` with
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
from functools import partial

import numpy as np
from scipy.special import expit

from bayestissue._validation import ValidationError, check_positive
from bayestissue.inference.coordinates import profile_shear
from bayestissue.inference.parameters import ParameterSet

__all__ = ["COORDINATES", "CreepCoordinates", "RampCoordinates", "coordinate_advice", "coordinate_factory"]

#: Coordinate systems the sampler can move in (``[sampler] coordinates``).
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

    @classmethod
    def of_problem(cls, problem, *, geometry: dict):
        """The creep coordinates of ``problem``'s parameters with the mechanics' ``geometry``."""
        return cls(problem.parameters, **geometry)

    def adapt(self, problem, theta_hat):
        """Sheared along the two-dimensional least-squares profile over the matrix split :math:`z_f` and share
        :math:`z_m` (the flat directions of a creep test) around the least-squares estimate ``theta_hat``.

        Measured on the T1 replica (mirror model, 36 walkers, 2000 steps): acceptance 0.044 with two
        one-dimensional shears (split, then share), 0.079 with this two-dimensional one; the dependent coordinates'
        conditional means no longer drift with :math:`(z_f, z_m)`.
        """
        s = self.slots
        return profile_shear(problem, self, theta_hat, s[:2], s[2:], _shear_grids(self, theta_hat))

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


class RampCoordinates:
    """The box coordinates of ``parameters`` (identity on top of the box's logit map), marked for
    :meth:`adapt` to shear along the profile over the fibre law's ``gamma``, ``beta``
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

    @classmethod
    def of_problem(cls, problem):
        """The ramp coordinates of ``problem``'s parameters."""
        return cls(problem.parameters)

    def adapt(self, problem, theta_hat):
        """Sheared along the least-squares profile over the fibre law's :math:`(z_\\gamma, z_\\beta)` (the flat
        directions of a force ramp) and then over :math:`z_\\mu`, around ``theta_hat``."""
        sheared = profile_shear(problem, self, theta_hat, self.free, self.dependent, [RAMP_GRID, RAMP_GRID])
        return profile_shear(problem, sheared, theta_hat, self.mu, self.dependent, RAMP_MU_GRID)

    def to_unconstrained(self, theta) -> np.ndarray:
        return self.parameters.to_unconstrained(theta)

    def from_unconstrained(self, z) -> np.ndarray:
        return self.parameters.from_unconstrained(z)

    def log_abs_det_jacobian(self, z) -> np.ndarray:
        return self.parameters.log_abs_det_jacobian(z)


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


def coordinate_factory(kind: str, geometry: dict | None = None):
    """What :class:`~bayestissue.inference.CalibrationProblem` takes for the coordinates ``kind`` (one of
    :data:`COORDINATES`): ``"box"``, or a picklable factory of the creep coordinates (they need the mechanics'
    ``geometry``: the reference ``stretch``, ``phi_matrix`` and the ``fibres`` ``(phi_k, v_k)`` that use family 2's law;
    :func:`bayestissue.workflows.problem.creep_geometry`) or of the ramp coordinates."""
    if kind not in COORDINATES:
        raise ValidationError("sampler coordinates", kind, f"one of {list(COORDINATES)}")
    if kind == "box":
        return "box"
    if kind == "ramp":
        return RampCoordinates.of_problem
    if geometry is None:
        raise ValidationError("sampler coordinates", kind, "'box' or 'ramp' for a problem without geometry")
    return partial(CreepCoordinates.of_problem, geometry=geometry)


def coordinate_advice(kind: str, converged: bool) -> str | None:
    """What to try when an emcee run in the coordinates ``kind`` is NOT CONVERGED, or ``None``.

    The ramp coordinates are sheared along least-squares profiles. Where the data do not inform the viscosity those
    profiles are flat, and the coordinates can hold the ensembles where they start: in the emcee SBC
    (docs/verification.md) a 480 s ramp whose beta2 the data leave at its prior kept all four ensembles at
    beta2 < 0.07 for 6000 steps (the nested check: 0.06-2.0), and in box coordinates the same posterior CONVERGED in
    700 steps with the generating value inside (3 of 3 such fits). Nothing for the creep coordinates: there the box
    is what fails (T1's L-shaped posterior, the module docstring), and no run has shown them failing this way."""
    if kind != "ramp" or converged:
        return None
    return (
        "the ramp coordinates are sheared along least-squares profiles; where the data leave the viscosity flat they "
        'can hold the ensembles where they start: try [sampler] coordinates = "box" (and cross_check = "nested")'
    )
