r"""Fibre geometry and the paper's Kelvin fibre as a standalone check.

:func:`fibre_structure`: the Voigt components of the structure tensors :math:`M_k = v_k \otimes v_k` of the fibre
directions (docs/model.md). :class:`KelvinFibres`: one paper fibre (the linear fibre law with one Prony branch,
:mod:`~bayestissue.mechanics.laws.prony`) driven through the discrete update of eqs. (5)-(9) alone, for checks
against the closed form and for plots. Continuous form: :math:`\tau = \sigma + \gamma h`,
:math:`h(t) = \int_0^t e^{-\beta (t-s)} \dot\tau(s)\, ds`, :math:`\sigma = g_\infty (\varepsilon - \varepsilon_0)`;
instantaneous modulus :math:`g_\infty / (1-\gamma)`, equilibrium modulus :math:`g_\infty`, relaxation rate
:math:`\beta`.

References: Rohan, Cimrman & Kochova (2012), paper eqs. (5)-(9) (file 000_317b62b3cdfd70d7.txt).
"""

from __future__ import annotations

import numpy as np

from bayestissue.mechanics.laws.prony import branch_constants

__all__ = ["KelvinFibres", "fibre_structure"]


def fibre_structure(directions) -> np.ndarray:
    """(n_f, 3) unit directions -> (n_f, 6) Voigt components of the structure tensors ``M_k = v_k (x) v_k``."""
    v = np.asarray(directions, dtype=float)
    return np.stack(
        [v[:, 0] ** 2, v[:, 1] ** 2, v[:, 2] ** 2, v[:, 0] * v[:, 1], v[:, 0] * v[:, 2], v[:, 1] * v[:, 2]], axis=1
    )


class KelvinFibres:
    """One Kelvin fibre driven through the discrete update of eqs. (5)-(9) (for checks and plots).

    Parameters
    ----------
    ginf, gamma, beta : float
        Equilibrium modulus (kPa), viscous fraction (1, in [0, 1)) and relaxation rate (1/s).
    eps0 : float
        Slack strain.
    """

    def __init__(self, ginf: float, gamma: float, beta: float, *, eps0: float = 0.0):
        self.ginf, self.gamma, self.beta, self.eps0 = (float(ginf), float(gamma), float(beta), float(eps0))

    def strain_for_constant_tension(self, tension_kpa: float, time_s) -> np.ndarray:
        r"""Strain history that holds the discrete tension at ``tension_kpa`` from the first step on.

        At each step of the uniform grid ``time_s`` (``time_s[0] = 0``: unloaded) eq. (5) is inverted for the
        strain (the trial tension is affine in it) and eq. (7) updates the history. The closed form it converges to
        as dt -> 0 is :math:`\varepsilon(t) = (\tau_0/g_\infty)(1 - \gamma e^{-\beta t})` (docs/model.md).
        """
        t = np.asarray(time_s, dtype=float)
        a, b, c = branch_constants(self.gamma, self.beta, t[1] - t[0])
        tau_old, h = max(0.0, -self.ginf * self.eps0), 0.0
        eps = np.zeros_like(t)
        for n in range(1, t.size):
            q = self.gamma * (a * h - b * tau_old)
            eps[n] = self.eps0 + (c * tension_kpa - q) / self.ginf
            tau = max(0.0, (self.ginf * (eps[n] - self.eps0) + q) / c)
            h = a * h + b * (tau - tau_old)
            tau_old = tau
        return eps
