r"""Simple shear: :math:`F = I + \gamma\, e_1 \otimes e_2`, the amount of shear :math:`\gamma(t)` prescribed (the
specimen between two plates, its height fixed; Budday et al. 2017's shear tests).

Every strain component is prescribed: :math:`E_{12} = \gamma/2`, :math:`E_{22} = \gamma^2/2`, the others zero
(:math:`J = 1`). Observed the shear stress on the top face, :math:`P_{12} = (F S)_{12} = S_{12} + \gamma S_{22}`, or
the shear force :math:`P_{12} L_x L_z` (mN).

Incompressible closed form for an isotropic :math:`W(I_1, I_2)` (:math:`I_1 = I_2 = 3 + \gamma^2`; the pressure does
not enter the shear stress): :math:`P_{12} = 2\gamma (W_1 + W_2)`; for Ogden, with the principal stretches
:math:`\lambda_{\pm} = \sqrt{1 + \gamma^2/4} \pm \gamma/2`: :math:`P_{12} = \sum_p \tfrac{2\mu_p}{\alpha_p}
(\lambda_+^{\alpha_p} - \lambda_-^{\alpha_p})/(\lambda_+ + \lambda_-)`.
"""

from __future__ import annotations

import numpy as np

from bayestissue.mechanics.loadcases.base import STRAIN, Channel, LoadCase

__all__ = ["SimpleShear"]


class SimpleShear(LoadCase):
    """Simple shear in the x-y plane (module docstring)."""

    name = "simple_shear"
    controls = ("shear",)
    title = "simple shear F = I + gamma e1 x e2 (gamma prescribed); the shear stress observed"

    def prescribe(self, history, controls):
        self.check_controls(controls)
        kinds = np.full(6, STRAIN, dtype=np.int64)
        values = np.zeros((history.size, 6))
        values[:, 1] = 0.5 * history * history
        values[:, 3] = 0.5 * history
        return kinds, values

    def channels(self, controls, columns, specimen_mm):
        if "shear_force_mN" in columns:
            return (Channel(2, 0, "shear force", "mN", "shear_force_mN", specimen_mm[0] * specimen_mm[2]),)
        return (Channel(2, 0, "shear stress", "kPa", "shear_stress_kpa"),)
