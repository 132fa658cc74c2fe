r"""Yeoh matrix: a cubic in the first isochoric invariant, :math:`W = \phi_m \sum_{i=1}^{3} c_i (\bar I_1 - 3)^i`.

With :math:`x = \bar I_1 - 3`, :math:`W_1 = \partial W/\partial\bar I_1 = c_1 + 2 c_2 x + 3 c_3 x^2` and
:math:`W_{11} = 2 c_2 + 6 c_3 x`, :math:`G = \partial\bar I_1/\partial C = J^{-2/3}(I - \tfrac{I_1}{3}C^{-1})`:

.. math:: S = 2\phi_m W_1\, G, \qquad
          \frac{\partial S}{\partial E} = 2\frac{\partial S}{\partial C}
          = 4\phi_m W_{11}\, G \otimes G + 2\phi_m (2 W_1) \frac{\partial G}{\partial C},

the second term being the neo-Hookean tangent of :mod:`~bayestissue.mechanics.laws.mooney_rivlin` with
:math:`\mu = 2 W_1` (the kernel reuses it). :math:`c_1` is half the small-strain shear modulus; :math:`c_2` is
typically negative for rubber (the softening before the upturn), :math:`c_3` positive (the upturn at large stretch).

Reference: Yeoh (1993) Rubber Chem Technol 66:754, doi:10.5254/1.3538343.
"""

from __future__ import annotations

import numpy as np

from bayestissue.mechanics._jit import kernel
from bayestissue.mechanics.kinematics import VOIGT_I, VOIGT_J, right_cauchy_green
from bayestissue.mechanics.laws.base import LawParameter, MatrixLaw
from bayestissue.mechanics.laws.mooney_rivlin import invariants, mooney_rivlin_stress_tangent

__all__ = ["Yeoh", "yeoh_derivatives", "yeoh_energy", "yeoh_stress_tangent"]


@kernel
def _x_and_g(e, C, Ci, G):
    """:math:`x = \\bar I_1 - 3`, ``det C`` and ``G`` (6,) at the Voigt strain ``e``; det <= 0 if C is
    inadmissible."""
    det = right_cauchy_green(e, C, Ci)
    if not (det > 0.0):
        return 0.0, -1.0
    I1, _ = invariants(C)
    jm23 = 1.0 / np.cbrt(det)
    for i in range(6):
        a = VOIGT_I[i]
        b = VOIGT_J[i]
        G[i] = jm23 * ((1.0 if a == b else 0.0) - I1 / 3.0 * Ci[a, b])
    return jm23 * I1 - 3.0, det


@kernel
def yeoh_stress_tangent(e, c1, c2, c3, phi_m, bulk, S, D, want_tangent, C, Ci, G):
    """Stress ``S`` and tangent ``D`` (with the penalty of modulus ``bulk``); returns J (<= 0: inadmissible)."""
    x, det = _x_and_g(e, C, Ci, G)
    if not (det > 0.0):
        return -1.0
    w1 = c1 + 2.0 * c2 * x + 3.0 * c3 * x * x
    J = mooney_rivlin_stress_tangent(e, 2.0 * w1, 0.0, phi_m, bulk, S, D, want_tangent, C, Ci)
    if want_tangent and J > 0.0:
        w11 = 4.0 * phi_m * (2.0 * c2 + 6.0 * c3 * x)
        for i in range(6):
            for j in range(6):
                D[i, j] += w11 * G[i] * G[j] * (1.0 if j < 3 else 2.0)
    return J


@kernel
def yeoh_energy(e, c1, c2, c3, phi_m, bulk, C, Ci, G):
    """Strain energy (kPa) with the penalty; NaN if inadmissible."""
    x, det = _x_and_g(e, C, Ci, G)
    if not (det > 0.0):
        return np.nan
    J = np.sqrt(det)
    return phi_m * x * (c1 + x * (c2 + x * c3)) + 0.5 * bulk * (J - 1.0) ** 2


@kernel
def yeoh_derivatives(e, phi_m, C, Ci, G, dS):
    """``dS`` (6, 3): :math:`\\partial S/\\partial c_i = 2\\phi_m\\, i\\, x^{i-1} G` (the stress is linear in the
    coefficients)."""
    x, _ = _x_and_g(e, C, Ci, G)
    for i in range(6):
        dS[i, 0] = 2.0 * phi_m * G[i]
        dS[i, 1] = 2.0 * phi_m * 2.0 * x * G[i]
        dS[i, 2] = 2.0 * phi_m * 3.0 * x * x * G[i]


class Yeoh(MatrixLaw):
    r""":math:`W = \sum_{i=1}^3 c_i (\bar I_1 - 3)^i` (module docstring)."""

    name = "yeoh"
    code = 3
    title = "Yeoh: cubic in the first invariant (c1 > 0, c2 usually < 0, c3 > 0)"
    reference = "Yeoh 1993, doi:10.5254/1.3538343"

    def parameters(self):
        return (
            LawParameter("c1", "kPa", 0.001, 1000.0, "log", "modulus", 5.0, "half the small-strain shear modulus"),
            LawParameter("c2", "kPa", -1000.0, 1000.0, "linear", "modulus", 0.0, "second-order coefficient"),
            LawParameter("c3", "kPa", -1000.0, 1000.0, "linear", "modulus", 0.0, "third-order coefficient"),
        )

    def energy_reference(self, C, params):
        c1, c2, c3 = params
        x = np.linalg.det(C) ** (-1 / 3) * np.trace(C) - 3.0
        return c1 * x + c2 * x**2 + c3 * x**3
