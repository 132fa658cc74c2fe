r"""The paper's fibre: linear in the fibre strain, tension only; with one Prony branch it is the paper's Kelvin fibre.

.. math:: \sigma(\varepsilon) = g_\infty (\varepsilon - \varepsilon_0), \qquad \tau = \max(0, \sigma), \qquad
          \varepsilon = M : E,

:math:`g_\infty` the equilibrium modulus (kPa), :math:`\varepsilon_0` the family's slack strain (a tissue input). The
paper's viscoelastic fibre (eqs. (5)-(9): a standard linear solid, one relaxation time) is this law with one
branch of :mod:`~bayestissue.mechanics.laws.prony`, whose parameters are the paper's :math:`\gamma, \beta`; the
fibre's strain energy :math:`w = \tfrac{g_\infty}{2}\max(0, \varepsilon - \varepsilon_0)^2`.

Reference: Rohan, Cimrman & Kochova (2012), eqs. (4)-(9) (docs/model.md).
"""

from __future__ import annotations

import numpy as np

from bayestissue.mechanics._jit import kernel
from bayestissue.mechanics.laws.base import FibreLaw, LawParameter

__all__ = ["LinearFibre", "linear_fibre_stress"]


@kernel
def linear_fibre_stress(x, ginf):
    """:math:`(\\sigma, d\\sigma/d\\varepsilon)` at :math:`x = \\varepsilon - \\varepsilon_0`."""
    return ginf * x, ginf


class LinearFibre(FibreLaw):
    r""":math:`\sigma = g_\infty(\varepsilon - \varepsilon_0)`, tension only (module docstring)."""

    name = "linear"
    code = 0
    title = "linear, tension only: the paper's fibre (with one Prony branch, its Kelvin fibre)"
    reference = "Rohan, Cimrman & Kochova 2012, eqs. (4)-(9)"

    def parameters(self):
        return (LawParameter("ginf", "kPa", 0.001, 1000.0, "log", "modulus", 125.0, "equilibrium fibre modulus"),)

    def energy_reference(self, strain, params):
        (ginf,) = params
        return 0.5 * ginf * np.where(np.real(strain) > 0, strain, 0.0) ** 2
