r"""Mooney-Rivlin matrix (the paper's) with the volumetric penalty: second Piola-Kirchhoff stress, consistent tangent.

Stress (docs/model.md; paper eq. (4) with its first bracket corrected to the standard total-Lagrangian neo-Hookean
form):

.. math::

    S_m = \phi_m \left[ \mu J^{-2/3} \left(I - \tfrac{I_1}{3} C^{-1}\right)
          + \kappa J^{-4/3} \left(I_1 I - C - \tfrac{2}{3} I_2 C^{-1}\right) \right], \qquad
    S_{vol} = K (J - 1) J C^{-1},

i.e. :math:`S = 2\,\partial W / \partial C` of
:math:`W = \phi_m [\tfrac{\mu}{2}(J^{-2/3} I_1 - 3) + \tfrac{\kappa}{2}(J^{-4/3} I_2 - 3)] + \tfrac{K}{2}(J-1)^2`.

Tangent :math:`\partial S / \partial E = 2\,\partial S / \partial C` with
:math:`\partial J^{-2/3}/\partial C = -\tfrac13 J^{-2/3} C^{-1}`,
:math:`\partial C^{-1}_{ab}/\partial C_{cd} = -\tfrac12 (C^{-1}_{ac} C^{-1}_{bd} + C^{-1}_{ad} C^{-1}_{bc})`,
:math:`\partial I_2/\partial C = I_1 I - C`:

.. math::

    \frac{\partial S_m}{\partial C} = \phi_m \mu J^{-2/3}\left[-\tfrac13 (I - \tfrac{I_1}{3}C^{-1}) \otimes C^{-1}
      - \tfrac13 C^{-1} \otimes I - \tfrac{I_1}{3} \frac{\partial C^{-1}}{\partial C}\right]
      + \phi_m \kappa J^{-4/3}\left[-\tfrac23 (I_1 I - C - \tfrac23 I_2 C^{-1}) \otimes C^{-1} + I \otimes I
      - \mathbb{I} - \tfrac23 C^{-1} \otimes (I_1 I - C) - \tfrac23 I_2 \frac{\partial C^{-1}}{\partial C}\right],

.. math::

    \frac{\partial S_{vol}}{\partial C} = K\left[\tfrac{(2J - 1) J}{2} C^{-1} \otimes C^{-1}
      + (J^2 - J) \frac{\partial C^{-1}}{\partial C}\right].

In Voigt form the tangent column of a shear component counts both :math:`E_{cd}` and :math:`E_{dc}` (factor 2).

The penalty is computed in the same kernel: the paper's arithmetic, kept as it was so that the paper's model gives the
same bits (a viscoelastic matrix calls it with ``bulk = 0`` for the isochoric part alone,
:mod:`~bayestissue.mechanics.laws.volumetric` adds the penalty). Neo-Hookean is this law with :math:`\kappa = 0`.

References: Mooney (1940) J Appl Phys 11:582, doi:10.1063/1.1712836; Rivlin (1948) Phil Trans R Soc A 241:379,
doi:10.1098/rsta.1948.0024; paper eq. (4).
"""

from __future__ import annotations

import numpy as np

from bayestissue.mechanics._jit import kernel
from bayestissue.mechanics.kinematics import VOIGT_I, VOIGT_J, right_cauchy_green
from bayestissue.mechanics.laws.base import LawParameter, MatrixLaw

__all__ = [
    "MooneyRivlin",
    "invariants",
    "mooney_rivlin_derivatives",
    "mooney_rivlin_energy",
    "mooney_rivlin_stress_tangent",
]

_VI = VOIGT_I
_VJ = VOIGT_J


@kernel
def invariants(C):
    """:math:`I_1 = \\mathrm{tr}\\, C` and :math:`I_2 = \\tfrac12 (I_1^2 - \\mathrm{tr}\\, C^2)` of the 3x3 ``C``."""
    I1 = C[0, 0] + C[1, 1] + C[2, 2]
    trC2 = 0.0
    for a in range(3):
        for b in range(3):
            trC2 += C[a, b] * C[a, b]
    return I1, 0.5 * (I1 * I1 - trC2)


@kernel
def mooney_rivlin_stress_tangent(e, mu, kappa, phi_m, bulk, S, D, want_tangent, C, Ci):
    """Matrix + penalty stress ``S`` (6,) and, if ``want_tangent``, tangent ``D`` (6, 6) at Voigt strain ``e``.

    ``D[i, j] = dS_i / de_j`` with ``e_j`` the independent Voigt components; ``C`` and ``Ci`` are (3, 3) scratch
    arrays (no allocation in the hot loop). Returns J (<= 0: inadmissible state, ``S`` and ``D`` undefined).
    """
    det = right_cauchy_green(e, C, Ci)
    if not (det > 0.0):
        return -1.0
    J = np.sqrt(det)
    I1, I2 = invariants(C)
    jm23 = 1.0 / np.cbrt(det)  # J^(-2/3) = det(C)^(-1/3)
    jm43 = jm23 * jm23
    a_nh = phi_m * mu * jm23
    a_mr = phi_m * kappa * jm43
    pv = bulk * (J - 1.0) * J
    for i in range(6):
        a = _VI[i]
        b = _VJ[i]
        dab = 1.0 if a == b else 0.0
        S[i] = (
            a_nh * (dab - I1 / 3.0 * Ci[a, b]) + a_mr * (I1 * dab - C[a, b] - 2.0 / 3.0 * I2 * Ci[a, b]) + pv * Ci[a, b]
        )
    if not want_tangent:
        return J
    # Grouped form of the tangent (same terms as the module docstring, collected by tensor structure):
    # dS/dC = alpha Ci(x)Ci + beta dCi/dC + G(x)Ci + Ci(x)G + a_mr (I(x)I - II),
    # G = -a_nh/3 I - 2 a_mr/3 (I1 I - C).
    alpha = a_nh * I1 / 9.0 + a_mr * 4.0 / 9.0 * I2 + bulk * (2.0 * J - 1.0) * J * 0.5
    beta = -a_nh * I1 / 3.0 - a_mr * 2.0 / 3.0 * I2 + pv
    for i in range(6):
        a = _VI[i]
        b = _VJ[i]
        cab = Ci[a, b]
        gab = -2.0 / 3.0 * a_mr * (-C[a, b]) if a != b else -a_nh / 3.0 - 2.0 / 3.0 * a_mr * (I1 - C[a, b])
        for j in range(i, 6):
            c = _VI[j]
            d = _VJ[j]
            ccd = Ci[c, d]
            gcd = -2.0 / 3.0 * a_mr * (-C[c, d]) if c != d else -a_nh / 3.0 - 2.0 / 3.0 * a_mr * (I1 - C[c, d])
            dci = -0.5 * (Ci[a, c] * Ci[b, d] + Ci[a, d] * Ci[b, c])
            iso = 0.0
            if i < 3 and j < 3:
                iso = 1.0 - (1.0 if i == j else 0.0)  # delta_ab delta_cd - II_abcd on the normal block
            elif i == j:
                iso = -0.5  # II_abab for a != b
            val = 2.0 * (alpha * cab * ccd + beta * dci + gab * ccd + cab * gcd + a_mr * iso)
            D[i, j] = val * (1.0 if j < 3 else 2.0)
            if j != i:
                D[j, i] = val * (1.0 if i < 3 else 2.0)
    return J


@kernel
def mooney_rivlin_energy(e, mu, kappa, phi_m, bulk, C, Ci):
    """Strain energy W (kPa) of matrix + penalty at Voigt strain ``e`` (NaN if J <= 0); see the module docstring."""
    det = right_cauchy_green(e, C, Ci)
    if not (det > 0.0):
        return np.nan
    J = np.sqrt(det)
    I1, I2 = invariants(C)
    jm23 = 1.0 / np.cbrt(det)
    return 0.5 * phi_m * (mu * (jm23 * I1 - 3.0) + kappa * (jm23 * jm23 * I2 - 3.0)) + 0.5 * bulk * (J - 1.0) ** 2


@kernel
def mooney_rivlin_derivatives(J, phi_m, C, Ci, dmu, dkappa):
    r"""``dmu``, ``dkappa`` (6,): :math:`\partial S_m/\partial\mu = \phi_m J^{-2/3}(I - \tfrac{I_1}{3} C^{-1})` and
    :math:`\partial S_m/\partial\kappa = \phi_m J^{-4/3}(I_1 I - C - \tfrac23 I_2 C^{-1})` (the matrix stress is
    linear in both moduli), from ``J``, ``C`` and ``Ci`` as :func:`mooney_rivlin_stress_tangent` left them."""
    I1, I2 = invariants(C)
    jm23 = 1.0 / np.cbrt(J * J)
    for i in range(6):
        a = _VI[i]
        b = _VJ[i]
        dab = 1.0 if a == b else 0.0
        dmu[i] = phi_m * jm23 * (dab - I1 / 3.0 * Ci[a, b])
        dkappa[i] = phi_m * jm23 * jm23 * (I1 * dab - C[a, b] - 2.0 / 3.0 * I2 * Ci[a, b])


class MooneyRivlin(MatrixLaw):
    r"""Mooney-Rivlin: :math:`W = \phi_m [\tfrac{\mu}{2}(\bar I_1 - 3) + \tfrac{\kappa}{2}(\bar I_2 - 3)]`
    (module docstring; the paper's matrix, eq. (4))."""

    name = "mooney_rivlin"
    code = 0
    title = "Mooney-Rivlin: the paper's matrix, two moduli (of the first and second invariant)"
    reference = "Mooney 1940, doi:10.1063/1.1712836; Rivlin 1948, doi:10.1098/rsta.1948.0024"

    def parameters(self):
        return (
            LawParameter("mu", "kPa", 0.001, 1000.0, "log", "modulus", 10.0, "modulus of the first invariant"),
            LawParameter("kappa", "kPa", 0.001, 1000.0, "log", "modulus", 50.0, "modulus of the second invariant"),
        )

    def energy_reference(self, C, params):
        mu, kappa = params
        det = np.linalg.det(C)
        i1 = np.trace(C)
        i2 = 0.5 * (i1 * i1 - np.trace(C @ C))
        return 0.5 * mu * (det ** (-1 / 3) * i1 - 3.0) + 0.5 * kappa * (det ** (-2 / 3) * i2 - 3.0)
