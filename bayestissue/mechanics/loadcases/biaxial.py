r"""Planar biaxial tension in the x-y plane (equibiaxial, general ratio) and pure shear, the thickness face free.

Stretch control: :math:`\lambda_1(t)` the protocol's stretch, :math:`\lambda_2 = 1 + \rho(\lambda_1 - 1)` with the
ratio :math:`\rho` (1: equibiaxial; 0: pure shear, planar tension, :math:`\lambda_2 = 1`), or, for the general
biaxial case, :math:`\lambda_2(t)` a history of its own (a measured ``stretch_2`` column: non-proportional loading,
e.g. several ratios in sequence); :math:`P_{33} = 0` and the shears stress-free. Force control: dead loads
:math:`P_1(t)` and :math:`P_2 = \rho P_1`, or :math:`P_2(t)` of its own (a ``force_2_mN`` column). Observed: the
nominal stress or force on each loaded face (stretch control) or each face's displacement (force control); pure
shear observes face 1 only.

Incompressible closed forms (docs/verification.md), isotropic :math:`W(I_1, I_2)`: equibiaxial
:math:`P = 2(\lambda - \lambda^{-5})(W_1 + \lambda^2 W_2)`; pure shear :math:`P_1 = 2(\lambda - \lambda^{-3})(W_1 +
W_2)`; Ogden equibiaxial :math:`P = \sum_p \tfrac{2\mu_p}{\alpha_p}(\lambda^{\alpha_p - 1} - \lambda^{-2\alpha_p - 1})`,
pure shear :math:`P_1 = \sum_p \tfrac{2\mu_p}{\alpha_p}(\lambda^{\alpha_p - 1} - \lambda^{-\alpha_p - 1})`.
"""

from __future__ import annotations

import numpy as np

from bayestissue._validation import check_finite
from bayestissue.mechanics.loadcases.base import FREE, LOAD, STRETCH, Channel, LoadCase, stress_or_force

__all__ = ["Biaxial", "Equibiaxial", "PureShear"]


class Biaxial(LoadCase):
    """Planar biaxial tension with face 2 following face 1 at the ratio ``ratio`` (module docstring)."""

    name = "biaxial"
    controls = ("force", "stretch")
    title = "planar biaxial (x and y), ratio = (lambda_2 - 1)/(lambda_1 - 1) or P_2/P_1; P_33 = 0"
    options = {"ratio": 1.0}
    observe_second = True
    #: the ratio of a subclass that fixes it (None: the option's)
    fixed_ratio = None

    def __init__(self, **options):
        super().__init__(**options)
        ratio = self.settings.get("ratio", 1.0) if self.fixed_ratio is None else self.fixed_ratio
        self.ratio = check_finite("protocol ratio", ratio)
        self.ratio_given = "ratio" in options

    def check_second_history(self) -> None:
        if self.fixed_ratio is not None or self.ratio_given:
            super().check_second_history()

    def prescribe(self, history, controls):
        self.check_controls(controls)
        rho = self.ratio
        kind = LOAD if controls == "force" else STRETCH
        kinds = np.array([kind, kind, FREE, FREE, FREE, FREE], dtype=np.int64)
        history = np.asarray(history, dtype=float)
        values = np.zeros((history.shape[0], 6))
        if history.ndim == 2:  # the second face's own stretch or load history
            self.check_second_history()
            values[:, :2] = history
            return kinds, values
        values[:, 0] = history
        values[:, 1] = rho * history if controls == "force" else 1.0 + rho * (history - 1.0)
        return kinds, values

    def channels(self, controls, columns, specimen_mm):
        lx, ly, lz = specimen_mm
        if controls == "force":
            out = [Channel(0, 0, "displacement", "mm", "displacement_mm"),
                   Channel(0, 1, "displacement of face 2", "mm", "displacement_2_mm")]  # fmt: skip
        else:
            out = [stress_or_force(0, "", columns, ly * lz), stress_or_force(1, "_2", columns, lx * lz)]
        return tuple(out if self.observe_second else out[:1])


class Equibiaxial(Biaxial):
    """Equibiaxial tension: :math:`\\lambda_1 = \\lambda_2` (or :math:`P_1 = P_2`)."""

    name = "equibiaxial"
    title = "equibiaxial tension (lambda_1 = lambda_2, or P_1 = P_2); P_33 = 0"
    options = {}
    fixed_ratio = 1.0


class PureShear(Biaxial):
    """Pure shear (planar tension): :math:`\\lambda_2 = 1`, face 1 observed."""

    name = "pure_shear"
    controls = ("stretch",)
    title = "pure shear (planar tension): lambda_2 = 1, P_33 = 0; face 1 observed"
    options = {}
    observe_second = False
    fixed_ratio = 0.0
