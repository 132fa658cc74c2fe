r"""Neo-Hookean matrix: :math:`W = \phi_m \tfrac{\mu}{2}(\bar I_1 - 3)`, the Mooney-Rivlin law with :math:`\kappa = 0`.

Stress and tangent are those of :mod:`~bayestissue.mechanics.laws.mooney_rivlin` with its second modulus zero
(:math:`S = \phi_m \mu J^{-2/3}(I - \tfrac{I_1}{3} C^{-1})`); one modulus, the small-strain shear modulus
:math:`\mu`.

Reference: Treloar (1943) Trans Faraday Soc 39:241, doi:10.1039/TF9433900241.
"""

from __future__ import annotations

import numpy as np

from bayestissue.mechanics.laws.base import LawParameter, MatrixLaw

__all__ = ["NeoHookean"]


class NeoHookean(MatrixLaw):
    r""":math:`W = \tfrac{\mu}{2}(\bar I_1 - 3)` (module docstring)."""

    name = "neo_hookean"
    code = 1
    title = "neo-Hookean: one shear modulus"
    reference = "Treloar 1943, doi:10.1039/TF9433900241"

    def parameters(self):
        return (LawParameter("mu", "kPa", 0.001, 1000.0, "log", "modulus", 10.0, "shear modulus"),)

    def energy_reference(self, C, params):
        (mu,) = params
        return 0.5 * mu * (np.linalg.det(C) ** (-1 / 3) * np.trace(C) - 3.0)
