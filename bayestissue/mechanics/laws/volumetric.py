r"""The volumetric penalty of the tissue: :math:`W_{vol} = \tfrac{K}{2}(J - 1)^2`, added on its own where a matrix
carries relaxing branches (its isochoric stress relaxes; the penalty, a constraint of near-incompressibility,
does not).

.. math:: S_{vol} = K (J - 1) J C^{-1}, \qquad
          \frac{\partial S_{vol}}{\partial C} = K\left[\tfrac{(2J - 1) J}{2} C^{-1} \otimes C^{-1}
          + (J^2 - J) \frac{\partial C^{-1}}{\partial C}\right]

(as in :mod:`~bayestissue.mechanics.laws.mooney_rivlin`, which fuses it with the paper's matrix).
"""

from __future__ import annotations

from bayestissue.mechanics._jit import kernel
from bayestissue.mechanics.kinematics import VOIGT_I, VOIGT_J

__all__ = ["volumetric_add"]


@kernel
def volumetric_add(J, bulk, Ci, S, D, want_tangent):
    """Add the penalty's stress to ``S`` and, if ``want_tangent``, its tangent to ``D``, at ``J`` with ``Ci`` =
    C^-1; returns its energy."""
    for i in range(6):
        S[i] += bulk * (J - 1.0) * J * Ci[VOIGT_I[i], VOIGT_J[i]]
    if want_tangent:
        for i in range(6):
            a, b = VOIGT_I[i], VOIGT_J[i]
            for j in range(6):
                c, d = VOIGT_I[j], VOIGT_J[j]
                dci = -0.5 * (Ci[a, c] * Ci[b, d] + Ci[a, d] * Ci[b, c])
                val = bulk * ((2.0 * J - 1.0) * J * 0.5 * Ci[a, b] * Ci[c, d] + (J * J - J) * dci)
                D[i, j] += 2.0 * val * (1.0 if j < 3 else 2.0)
    return 0.5 * bulk * (J - 1.0) ** 2
