r"""Ogden matrix with N terms, in principal stretches; an exponent may be negative.

.. math:: W = \phi_m \sum_{p=1}^{N} \frac{2\mu_p}{\alpha_p^2}\left(\bar\lambda_1^{\alpha_p} + \bar\lambda_2^{\alpha_p}
          + \bar\lambda_3^{\alpha_p} - 3\right), \qquad \bar\lambda_a = J^{-1/3}\lambda_a,

the form of Budday et al. (2017) in which every :math:`\mu_p > 0` is a shear modulus whatever the sign of
:math:`\alpha_p` (small-strain shear modulus :math:`\sum_p \mu_p`); :math:`N = 1, \alpha = 2` is neo-Hookean,
:math:`N = 2, (\alpha_1, \alpha_2) = (2, -2)` Mooney-Rivlin with :math:`\kappa = \mu_2`. With :math:`c_a = \lambda_a^2`
the eigenvalues of :math:`C` (:mod:`~bayestissue.mechanics.laws.spectral`), :math:`m = \alpha/2`,
:math:`s = \mathrm{tr}\, C^m` and :math:`\bar\lambda_a^\alpha = J^{-\alpha/3} c_a^{m}`, each term's stress is

.. math:: S_p = 2\frac{\partial W_p}{\partial C} = \phi_m\frac{2\mu_p}{\alpha_p} J^{-\alpha_p/3}
          \left(C^{m-1} - \frac{s}{3} C^{-1}\right)

(:math:`\partial\,\mathrm{tr}\,C^m/\partial C = m C^{m-1}`, :math:`\partial J^{-\alpha/3}/\partial C =
-\tfrac{\alpha}{6} J^{-\alpha/3} C^{-1}`), and its tangent :math:`\partial S_p/\partial E = 2\,\partial S_p/\partial C`
with the derivative of :math:`C^{m-1}` by the Daleckii-Krein formula (spectral module) and
:math:`\partial C^{-1}_{ab}/\partial C_{cd} = -\tfrac12(C^{-1}_{ac}C^{-1}_{bd} + C^{-1}_{ad}C^{-1}_{bc})`.
An exponent closer to 0 than :data:`ALPHA_MIN` is taken as :data:`ALPHA_MIN` (the law is continuous there).

References: Ogden (1972) Proc R Soc Lond A 326:565, doi:10.1098/rspa.1972.0026; Budday et al. (2017) Acta Biomater
48:319, doi:10.1016/j.actbio.2016.10.036 (the one-term law with a large negative exponent for brain tissue).
"""

from __future__ import annotations

import math

import numpy as np

from bayestissue._validation import ValidationError
from bayestissue.mechanics._jit import kernel
from bayestissue.mechanics.kinematics import VOIGT_I, VOIGT_J, right_cauchy_green
from bayestissue.mechanics.laws.base import LawParameter, MatrixLaw
from bayestissue.mechanics.laws.spectral import eigh3, power_divided_difference
from bayestissue.mechanics.laws.volumetric import volumetric_add

__all__ = [
    "ALPHA_MIN",
    "MAX_TERMS",
    "Ogden",
    "ogden_derivatives",
    "ogden_energy",
    "ogden_stress_tangent",
    "principal_values",
]

#: Most terms (the sensitivity kernels hold up to 8 parameters of one law).
MAX_TERMS = 4
#: Exponents closer to zero than this are evaluated at it (the limit alpha -> 0 is a Hencky-type energy).
ALPHA_MIN = 1e-8


@kernel
def _alpha(a):
    if abs(a) < ALPHA_MIN:
        return ALPHA_MIN if a >= 0.0 else -ALPHA_MIN
    return a


@kernel
def _spectral(e, C, Ci, w, Q, work):
    """C, C^-1 and the eigen-decomposition of C; returns det C (<= 0: inadmissible)."""
    det = right_cauchy_green(e, C, Ci)
    if not (det > 0.0):
        return -1.0
    if not eigh3(C, w, Q, work):
        return -1.0
    for k in range(3):
        if not (w[k] > 0.0):
            return -1.0
    return det


@kernel
def _power(w, Q, k, a, b):
    """:math:`(C^k)_{ab}` from the eigen-decomposition."""
    s = 0.0
    for j in range(3):
        s += Q[a, j] * Q[b, j] * math.exp(k * math.log(w[j]))
    return s


@kernel
def _power_matrix(w, Q, k, P):
    """:math:`P = C^k` (3, 3) from the eigen-decomposition (three powers, one per eigenvalue)."""
    c0 = math.exp(k * math.log(w[0]))
    c1 = math.exp(k * math.log(w[1]))
    c2 = math.exp(k * math.log(w[2]))
    for a in range(3):
        for b in range(a, 3):
            v = Q[a, 0] * Q[b, 0] * c0 + Q[a, 1] * Q[b, 1] * c1 + Q[a, 2] * Q[b, 2] * c2
            P[a, b] = v
            P[b, a] = v


@kernel
def ogden_stress_tangent(e, p, off, n_terms, phi_m, bulk, S, D, want_tangent, C, Ci, w, Q, work):
    """Stress ``S`` (6,) and, if ``want_tangent``, tangent ``D`` (6, 6) of the isochoric Ogden energy plus the penalty
    of modulus ``bulk``; the law's parameters are ``p[off : off + 2 n_terms]`` as (mu_1, alpha_1, ...). Returns J
    (<= 0: inadmissible)."""
    det = _spectral(e, C, Ci, w, Q, work)
    if not (det > 0.0):
        return -1.0
    J = math.sqrt(det)
    lnj = 0.5 * math.log(det)
    for i in range(6):
        S[i] = 0.0
        if want_tangent:
            for j in range(6):
                D[i, j] = 0.0
    volumetric_add(J, bulk, Ci, S, D, want_tangent)
    P = C  # C is not needed past the decomposition: it holds C^(m-1) of each term in turn
    for t in range(n_terms):
        mu = p[off + 2 * t]
        al = _alpha(p[off + 2 * t + 1])
        m = 0.5 * al
        A = phi_m * 2.0 * mu / al
        B = math.exp(-al * lnj / 3.0)
        s = 0.0
        for k in range(3):
            s += math.exp(m * math.log(w[k]))
        _power_matrix(w, Q, m - 1.0, P)
        for i in range(6):
            a, b = VOIGT_I[i], VOIGT_J[i]
            S[i] += A * B * (P[a, b] - s / 3.0 * Ci[a, b])
        if not want_tangent:
            continue
        # divided differences of f(c) = c^(m-1) between the eigenvalues (Daleckii-Krein)
        for k in range(3):
            for l in range(3):
                work[k, l] = power_divided_difference(w[k], w[l], m - 1.0)
        for i in range(6):
            a, b = VOIGT_I[i], VOIGT_J[i]
            tab = P[a, b] - s / 3.0 * Ci[a, b]
            for j in range(6):
                c, d = VOIGT_I[j], VOIGT_J[j]
                dk = 0.0
                for k in range(3):
                    qak = Q[a, k]
                    qck = Q[c, k]
                    qdk = Q[d, k]
                    for l in range(3):
                        dk += qak * Q[b, l] * work[k, l] * 0.5 * (qck * Q[d, l] + qdk * Q[c, l])
                dci = -0.5 * (Ci[a, c] * Ci[b, d] + Ci[a, d] * Ci[b, c])
                dt = dk - m / 3.0 * P[c, d] * Ci[a, b] - s / 3.0 * dci
                val = A * B * (-(al / 6.0) * Ci[c, d] * tab + dt)
                D[i, j] += 2.0 * val * (1.0 if j < 3 else 2.0)
    return J


@kernel
def ogden_energy(e, p, off, n_terms, phi_m, bulk, C, Ci, w, Q, work):
    """Strain energy (kPa) of the Ogden terms and the penalty; NaN if inadmissible."""
    det = _spectral(e, C, Ci, w, Q, work)
    if not (det > 0.0):
        return np.nan
    J = math.sqrt(det)
    lnj = 0.5 * math.log(det)
    total = 0.5 * bulk * (J - 1.0) ** 2
    for t in range(n_terms):
        mu = p[off + 2 * t]
        al = _alpha(p[off + 2 * t + 1])
        s = 0.0
        for k in range(3):
            s += math.exp(0.5 * al * math.log(w[k]))
        total += phi_m * 2.0 * mu / (al * al) * (math.exp(-al * lnj / 3.0) * s - 3.0)
    return total


@kernel
def ogden_derivatives(e, p, off, n_terms, phi_m, C, Ci, w, Q, work, dS):
    """``dS`` (6, 2 n_terms): the stress's derivatives by (mu_1, alpha_1, ...) at fixed strain (module docstring)."""
    det = _spectral(e, C, Ci, w, Q, work)
    lnj = 0.5 * math.log(det)
    for t in range(n_terms):
        mu = p[off + 2 * t]
        al = _alpha(p[off + 2 * t + 1])
        m = 0.5 * al
        A = phi_m * 2.0 * mu / al
        B = math.exp(-al * lnj / 3.0)
        s = 0.0
        ds = 0.0
        for k in range(3):
            ck = math.exp(m * math.log(w[k]))
            s += ck
            ds += 0.5 * math.log(w[k]) * ck
        for i in range(6):
            a, b = VOIGT_I[i], VOIGT_J[i]
            T = _power(w, Q, m - 1.0, a, b) - s / 3.0 * Ci[a, b]
            dP = 0.0
            for k in range(3):
                dP += Q[a, k] * Q[b, k] * 0.5 * math.log(w[k]) * math.exp((m - 1.0) * math.log(w[k]))
            dS[i, 2 * t] = phi_m * 2.0 / al * B * T
            dS[i, 2 * t + 1] = -A / al * B * T - lnj / 3.0 * A * B * T + A * B * (dP - ds / 3.0 * Ci[a, b])


class Ogden(MatrixLaw):
    r""":math:`W = \sum_p \frac{2\mu_p}{\alpha_p^2}(\sum_a \bar\lambda_a^{\alpha_p} - 3)` with ``terms`` = N terms
    (module docstring)."""

    name = "ogden"
    code = 2
    title = "Ogden, N terms (terms = N): shear moduli mu_p > 0, exponents alpha_p of either sign"
    reference = "Ogden 1972, doi:10.1098/rspa.1972.0026; form of Budday et al. 2017, doi:10.1016/j.actbio.2016.10.036"
    options = {"terms": 1}

    def __init__(self, **options):
        super().__init__(**options)
        n = self.settings["terms"]
        if not isinstance(n, int) or isinstance(n, bool) or not 1 <= n <= MAX_TERMS:
            raise ValidationError("tissue terms", n, f"a number of Ogden terms in 1..{MAX_TERMS}")

    def kernel_options(self) -> int:
        return self.settings["terms"]

    def parameters(self):
        out = []
        starts = (2.0, -2.0, 5.0, -5.0)
        for t in range(1, self.settings["terms"] + 1):
            out += [
                LawParameter(f"mu{t}", "kPa", 0.001, 1000.0, "log", "modulus", 1.0, f"shear modulus of term {t}"),
                LawParameter(f"alpha{t}", "1", -50.0, 50.0, "linear", "exponent", starts[t - 1],
                             f"exponent of term {t} (either sign)"),
            ]  # fmt: skip
        return tuple(out)

    def label_groups(self):
        """The terms are exchangeable (the energy is a sum over them): ordered by decreasing exponent."""
        n = self.settings["terms"]
        return (((tuple((f"alpha{t}", f"mu{t}") for t in range(1, n + 1))), True),) if n > 1 else ()

    def energy_reference(self, C, params):
        c = principal_values(C)
        det = c[0] * c[1] * c[2]
        total = 0.0
        for mu, al in zip(params[0::2], params[1::2], strict=True):
            total = total + 2.0 * mu / al**2 * (det ** (-al / 6.0) * sum(x ** (al / 2.0) for x in c) - 3.0)
        return total


def principal_values(C):
    """The eigenvalues of a symmetric 3x3 ``C`` by the trigonometric solution of its characteristic cubic (Smith 1961,
    Commun ACM 4:168): analytic in the entries where they are distinct, so complex-step derivatives go through it."""
    q = (C[0, 0] + C[1, 1] + C[2, 2]) / 3.0
    M = C - q * np.eye(3)
    p = np.sqrt(np.sum(M * M) / 6.0)
    Bm = M / p
    r = (Bm[0, 0] * (Bm[1, 1] * Bm[2, 2] - Bm[1, 2] * Bm[2, 1]) - Bm[0, 1] * (Bm[1, 0] * Bm[2, 2] - Bm[1, 2] * Bm[2, 0])
         + Bm[0, 2] * (Bm[1, 0] * Bm[2, 1] - Bm[1, 1] * Bm[2, 0])) / 2.0  # fmt: skip
    phi = np.arccos(r) / 3.0
    c1 = q + 2.0 * p * np.cos(phi)
    c3 = q + 2.0 * p * np.cos(phi + 2.0 * np.pi / 3.0)
    return c1, 3.0 * q - c1 - c3, c3
