r"""Spectral tools for laws written in principal stretches: the eigen-decomposition of a symmetric 3x3 matrix and the
derivative of an isotropic matrix function, allocation-free (numba kernels).

Eigen-decomposition by cyclic Jacobi rotations (Golub & Van Loan, *Matrix Computations*, 4th ed., Sec. 8.5): for a
3x3 symmetric matrix a few sweeps reach machine precision, and repeated eigenvalues are harmless.

The derivative of a matrix function :math:`f(C) = \sum_a f(c_a)\, n_a \otimes n_a` (Daleckii & Krein 1965; Higham,
*Functions of Matrices* 2008, Thm. 3.11): in the eigenbasis

.. math:: \left(Q^T\, \mathrm{d}f(C)[H]\, Q\right)_{ab} = f^{[1]}(c_a, c_b)\, (Q^T H Q)_{ab}, \qquad
          f^{[1]}(c_a, c_b) = \frac{f(c_a) - f(c_b)}{c_a - c_b}\ (c_a \ne c_b), \quad f'(c_a)\ (c_a = c_b).

For the power :math:`f(c) = c^k` the divided difference is evaluated without cancellation as
:math:`c_b^{k-1}\,\mathrm{expm1}(k\delta)/\mathrm{expm1}(\delta)`, :math:`\delta = \ln(c_a/c_b)`, exact in the limit
:math:`\delta \to 0`.
"""

from __future__ import annotations

import math

from bayestissue.mechanics._jit import kernel

__all__ = ["eigh3", "power_divided_difference"]


@kernel
def eigh3(A, w, Q, work):
    """Eigenvalues ``w`` (3,) and orthonormal eigenvectors (columns of ``Q``, 3x3) of the symmetric ``A`` (3x3, not
    modified; ``work`` a 3x3 scratch array). Returns False if the rotations did not converge (a NaN input)."""
    for i in range(3):
        for j in range(3):
            work[i, j] = A[i, j]
            Q[i, j] = 1.0 if i == j else 0.0
    scale = abs(work[0, 0]) + abs(work[1, 1]) + abs(work[2, 2])
    for _sweep in range(50):
        off = work[0, 1] * work[0, 1] + work[0, 2] * work[0, 2] + work[1, 2] * work[1, 2]
        if off <= 1e-36 * scale * scale or off == 0.0:
            for i in range(3):
                w[i] = work[i, i]
            return True
        for p in range(2):
            for q in range(p + 1, 3):
                apq = work[p, q]
                if apq == 0.0:
                    continue
                theta = (work[q, q] - work[p, p]) / (2.0 * apq)
                t = (1.0 if theta >= 0.0 else -1.0) / (abs(theta) + math.sqrt(theta * theta + 1.0))
                c = 1.0 / math.sqrt(t * t + 1.0)
                s = t * c
                for k in range(3):  # A <- J^T A J, columns then rows
                    akp = work[k, p]
                    akq = work[k, q]
                    work[k, p] = c * akp - s * akq
                    work[k, q] = s * akp + c * akq
                for k in range(3):
                    apk = work[p, k]
                    aqk = work[q, k]
                    work[p, k] = c * apk - s * aqk
                    work[q, k] = s * apk + c * aqk
                for k in range(3):
                    qkp = Q[k, p]
                    qkq = Q[k, q]
                    Q[k, p] = c * qkp - s * qkq
                    Q[k, q] = s * qkp + c * qkq
    return False


@kernel
def power_divided_difference(ca, cb, k):
    """:math:`(c_a^k - c_b^k)/(c_a - c_b)` for :math:`c_a, c_b > 0` (module docstring), :math:`k c^{k-1}` in the
    limit."""
    d = math.log(ca / cb)
    if abs(d) < 1e-13:
        return k * math.exp((k - 1.0) * 0.5 * (math.log(ca) + math.log(cb)))
    return math.exp((k - 1.0) * math.log(cb)) * math.expm1(k * d) / math.expm1(d)
