r"""Kinematics in Voigt notation for the reduced (one quadrature point) model.

A symmetric tensor is stored as the 6-vector of its independent components in the order
``[11, 22, 33, 12, 13, 23]`` (``VOIGT_I``, ``VOIGT_J``). Shear entries are the tensor components themselves (not
engineering shear), so the double contraction of two symmetric tensors is

.. math:: A : B = \sum_{i<3} a_i b_i + 2 \sum_{i \ge 3} a_i b_i .

With :math:`E` the Green strain, :math:`C = I + 2E`, :math:`J = \sqrt{\det C}`,
:math:`I_1 = \operatorname{tr} C`, :math:`I_2 = \tfrac12((\operatorname{tr} C)^2 - \operatorname{tr}(C^2))`
(docs/model.md).
"""

from __future__ import annotations

import numpy as np

from bayestissue.mechanics._jit import kernel

__all__ = [
    "VOIGT_I",
    "VOIGT_J",
    "STRAIN_COMPONENTS",
    "to_voigt",
    "from_voigt",
    "right_cauchy_green",
]

VOIGT_I = np.array([0, 1, 2, 0, 0, 1])
VOIGT_J = np.array([0, 1, 2, 1, 2, 2])
#: Names of the Voigt components of the Green strain, in storage order.
STRAIN_COMPONENTS = ("E11", "E22", "E33", "E12", "E13", "E23")


def to_voigt(tensor) -> np.ndarray:
    """(..., 3, 3) symmetric tensor -> (..., 6) Voigt vector ``[11, 22, 33, 12, 13, 23]``."""
    t = np.asarray(tensor, dtype=float)
    return t[..., VOIGT_I, VOIGT_J]


def from_voigt(v) -> np.ndarray:
    """(..., 6) Voigt vector -> (..., 3, 3) symmetric tensor."""
    v = np.asarray(v, dtype=float)
    t = np.empty(v.shape[:-1] + (3, 3))
    t[..., VOIGT_I, VOIGT_J] = v
    t[..., VOIGT_J, VOIGT_I] = v
    return t


@kernel
def right_cauchy_green(e, C, Ci):
    """Fill ``C = I + 2E`` and ``Ci = C^-1`` (3x3) from the Voigt strain ``e``; return ``det C``.

    Returns -1 and leaves ``Ci`` undefined when C is not positive definite (no deformation gradient has it; this
    includes J <= 0): a Newton step into such a state is rejected. Checking ``det C > 0`` alone is not enough, as
    C with two negative eigenvalues has a positive determinant and the equilibrium equations have spurious roots
    there.
    """
    C[0, 0] = 1.0 + 2.0 * e[0]
    C[1, 1] = 1.0 + 2.0 * e[1]
    C[2, 2] = 1.0 + 2.0 * e[2]
    C[0, 1] = C[1, 0] = 2.0 * e[3]
    C[0, 2] = C[2, 0] = 2.0 * e[4]
    C[1, 2] = C[2, 1] = 2.0 * e[5]
    a00 = C[1, 1] * C[2, 2] - C[1, 2] * C[2, 1]
    a01 = C[0, 2] * C[2, 1] - C[0, 1] * C[2, 2]
    a02 = C[0, 1] * C[1, 2] - C[0, 2] * C[1, 1]
    det = C[0, 0] * a00 + C[1, 0] * a01 + C[2, 0] * a02
    # C = F^T F must be positive definite (Sylvester): det C > 0 alone admits two negative eigenvalues
    if not (det > 0.0 and C[0, 0] > 0.0 and C[0, 0] * C[1, 1] - C[0, 1] * C[0, 1] > 0.0):
        return -1.0
    inv = 1.0 / det
    Ci[0, 0] = a00 * inv
    Ci[0, 1] = Ci[1, 0] = a01 * inv
    Ci[0, 2] = Ci[2, 0] = a02 * inv
    Ci[1, 1] = (C[0, 0] * C[2, 2] - C[0, 2] * C[2, 0]) * inv
    Ci[1, 2] = Ci[2, 1] = (C[0, 2] * C[1, 0] - C[0, 0] * C[1, 2]) * inv
    Ci[2, 2] = (C[0, 0] * C[1, 1] - C[0, 1] * C[1, 0]) * inv
    return det
