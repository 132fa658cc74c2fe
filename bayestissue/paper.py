"""The constants of Rohan, Cimrman & Kochova (2012), written once (``docs/model.md``).

Every other module takes the paper's numbers from here: the Table 1 parameter values and box constraints, the
three fibre directions and volume fractions of Section 3.1, the bulk modulus of Section 3.2, and the two
derived conventions this project uses throughout (the mirror-symmetric ties and the in-plane half-angle of
families 2 and 3). Nothing here imports the rest of the package.

References
----------
E. Rohan, R. Cimrman, P. Kochova (2012), "Identification of the smooth muscle tissue parameters: combining
quantitative microscopy and mechanical testing", the paper of ``docs/model.md``.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "PAPER_PARAMETERS",
    "PAPER_BOUNDS",
    "PAPER_DIRECTIONS_PRINTED",
    "PAPER_DIRECTIONS",
    "PAPER_PHI_FIBRES",
    "PAPER_PHI_MATRIX",
    "PAPER_BULK_KPA",
    "PAPER_HALF_ANGLE_DEG",
    "MIRROR_TIES",
    "MODULI",
]

#: Table 1: the paper's initial guess and its final T1 and T2 estimates (11 parameters in the order
#: mu, kappa, then ginf_k, gamma_k, beta_k for k = 1, 2, 3).
PAPER_PARAMETERS = {
    "initial": np.array([10, 50, 125, 0.75, 1.25, 125, 0.75, 1.25, 125, 0.75, 1.25], dtype=float),
    "T1": np.array([2.18, 2.91, 125, 0.75, 1.25, 13.4, 0.891, 0.00056, 13.4, 0.891, 0.00043]),
    "T2": np.array([0.102, 68.5, 125, 0.75, 1.25, 9.52, 0.1, 2.50, 9.52, 0.1, 2.50]),
}
for _v in PAPER_PARAMETERS.values():
    _v.setflags(write=False)

#: Table 1 box constraints [min, max] per parameter (same order).
PAPER_BOUNDS = np.array([[0.001, 1000], [0.001, 1000]] + [[0.001, 1000], [0.1, 0.95], [0.00001, 2.5]] * 3, dtype=float)
PAPER_BOUNDS.setflags(write=False)

#: Section 3.1: the three SMC directions as printed (v1 along y; v2, v3 in the x-y plane, |v| = 0.99737).
PAPER_DIRECTIONS_PRINTED = ((0.0, 1.0, 0.0), (0.9369, 0.3420, 0.0), (0.9369, -0.3420, 0.0))

#: The same directions normalised to unit length, (3, 3) read-only.
PAPER_DIRECTIONS = np.array(PAPER_DIRECTIONS_PRINTED)
PAPER_DIRECTIONS = PAPER_DIRECTIONS / np.linalg.norm(PAPER_DIRECTIONS, axis=1, keepdims=True)
PAPER_DIRECTIONS.setflags(write=False)

#: Section 3.2: volume fraction of each fibre family and of the matrix, and the bulk modulus K (kPa).
PAPER_PHI_FIBRES = (0.2, 0.2, 0.2)
PAPER_PHI_MATRIX = 0.4
PAPER_BULK_KPA = 1000.0

#: In-plane half-angle of families 2 and 3, :math:`\arctan(0.3420 / 0.9369)` = 20.05 degrees.
PAPER_HALF_ANGLE_DEG = float(np.degrees(np.arctan2(PAPER_DIRECTIONS_PRINTED[1][1], PAPER_DIRECTIONS_PRINTED[1][0])))

#: The mirror-symmetric model: family 3 takes family 2's law (pairs ``(name, target)``). Families 2 and 3 are
#: mirror images about the loading axis, so a uniaxial displacement cannot tell them apart.
MIRROR_TIES = (("ginf3", "ginf2"), ("gamma3", "gamma2"), ("beta3", "beta2"))

#: Indices of the moduli (mu, kappa, ginf1, ginf2, ginf3) in the paper's parameter order.
MODULI = (0, 1, 2, 5, 8)
