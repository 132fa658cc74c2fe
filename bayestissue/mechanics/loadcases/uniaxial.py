r"""Uniaxial tension or compression along x, under force or stretch control (the paper's tests, and Budday's
compression).

Force control: a dead load :math:`P_{11}(t)` on the face of normal x, the other faces traction-free (every other
component stress-free); observed the displacement :math:`u = (\lambda - 1) L_x`. Stretch control: the stretch
:math:`\lambda(t)` of that face (:math:`E_{11} = (\lambda^2 - 1)/2`), the rest stress-free; observed the force
:math:`P_{11} L_y L_z` or the nominal stress :math:`P_{11} = \lambda S_{11}`. Compression is the same load case with
:math:`\lambda < 1` (or :math:`P_{11} < 0`).

Incompressible closed form (docs/verification.md): :math:`P_{11} = (\lambda - \lambda^{-2})\,(2 W_1 + 2 W_2/\lambda)`
for an isotropic :math:`W(I_1, I_2)`; for Ogden :math:`P_{11} = \sum_p \tfrac{2\mu_p}{\alpha_p}(\lambda^{\alpha_p - 1}
- \lambda^{-\alpha_p/2 - 1})`.
"""

from __future__ import annotations

import numpy as np

from bayestissue.mechanics.loadcases.base import FREE, LOAD, STRETCH, Channel, LoadCase, stress_or_force

__all__ = ["Uniaxial"]


class Uniaxial(LoadCase):
    """Uniaxial tension or compression along x (module docstring)."""

    name = "uniaxial"
    controls = ("force", "stretch")
    title = "uniaxial tension or compression along x, force- or stretch-controlled"

    def prescribe(self, history, controls):
        self.check_controls(controls)
        kinds = np.array([LOAD if controls == "force" else STRETCH, FREE, FREE, FREE, FREE, FREE], dtype=np.int64)
        values = np.zeros((history.size, 6))
        values[:, 0] = history
        return kinds, values

    def channels(self, controls, columns, specimen_mm):
        if controls == "force":
            return (Channel(0, 0, "displacement", "mm", "displacement_mm"),)
        return (stress_or_force(0, "", columns, specimen_mm[1] * specimen_mm[2]),)
