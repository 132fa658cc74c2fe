"""The compiled side of the law registry: one branch per law code, so the time loop is compiled once for every law.

A law's code (its class attribute ``code``) selects its kernels here; the registry (:mod:`bayestissue.mechanics.laws`)
checks that every registered law has a branch (``tests/mechanics/test_laws.py`` runs every law through these
functions). Matrix laws receive their parameters as ``p[off:]`` and an integer option (Ogden: the number of terms);
fibre laws the fibre strain minus the family's slack, ``x = H : E - eps0``.

Scratch arrays (no allocation in the Newton loop): ``C``, ``Ci``, ``Q``, ``work`` 3x3, ``w`` (3,), ``G`` (6,).
"""

from __future__ import annotations

from bayestissue.mechanics._jit import kernel
from bayestissue.mechanics.laws.hgo import (
    exponential_fibre_derivatives,
    exponential_fibre_energy,
    exponential_fibre_stress,
)
from bayestissue.mechanics.laws.linear_fibre import linear_fibre_stress
from bayestissue.mechanics.laws.mooney_rivlin import (
    mooney_rivlin_derivatives,
    mooney_rivlin_energy,
    mooney_rivlin_stress_tangent,
)
from bayestissue.mechanics.laws.ogden import ogden_derivatives, ogden_energy, ogden_stress_tangent
from bayestissue.mechanics.laws.yeoh import yeoh_derivatives, yeoh_energy, yeoh_stress_tangent

__all__ = [
    "MATRIX_CODES",
    "FIBRE_CODES",
    "fibre_derivatives",
    "fibre_dispersion_index",
    "fibre_energy",
    "fibre_stress",
    "matrix_derivatives",
    "matrix_energy",
    "matrix_stress_tangent",
]

#: The codes with a branch below (the registry checks its laws against these).
MATRIX_CODES = (0, 1, 2, 3)
FIBRE_CODES = (0, 1)


@kernel
def matrix_stress_tangent(code, opt, e, p, off, phi_m, bulk, S, D, want_tangent, C, Ci, w, Q, work, G):
    """Isochoric stress of the matrix law ``code`` plus the penalty of modulus ``bulk`` (0: the isochoric part
    alone) into ``S`` (6,) and ``D`` (6, 6), overwritten; returns J (<= 0: inadmissible)."""
    if code == 0:  # Mooney-Rivlin (the paper's)
        return mooney_rivlin_stress_tangent(e, p[off], p[off + 1], phi_m, bulk, S, D, want_tangent, C, Ci)
    if code == 1:  # neo-Hookean
        return mooney_rivlin_stress_tangent(e, p[off], 0.0, phi_m, bulk, S, D, want_tangent, C, Ci)
    if code == 2:  # Ogden
        return ogden_stress_tangent(e, p, off, opt, phi_m, bulk, S, D, want_tangent, C, Ci, w, Q, work)
    if code == 3:  # Yeoh
        return yeoh_stress_tangent(e, p[off], p[off + 1], p[off + 2], phi_m, bulk, S, D, want_tangent, C, Ci, G)
    return -1.0


@kernel
def matrix_energy(code, opt, e, p, off, phi_m, bulk, C, Ci, w, Q, work, G):
    """Strain energy (kPa) of the matrix law and the penalty (NaN if inadmissible)."""
    if code == 0:
        return mooney_rivlin_energy(e, p[off], p[off + 1], phi_m, bulk, C, Ci)
    if code == 1:
        return mooney_rivlin_energy(e, p[off], 0.0, phi_m, bulk, C, Ci)
    if code == 2:
        return ogden_energy(e, p, off, opt, phi_m, bulk, C, Ci, w, Q, work)
    if code == 3:
        return yeoh_energy(e, p[off], p[off + 1], p[off + 2], phi_m, bulk, C, Ci, G)
    return 0.0


@kernel
def matrix_derivatives(code, opt, J, e, p, off, phi_m, C, Ci, w, Q, work, G, dS):
    """``dS`` (6, n_law): the isochoric stress's derivatives by the law's parameters at fixed strain, from the state
    the last :func:`matrix_stress_tangent` call at ``e`` left in ``C``, ``Ci`` (its J)."""
    if code == 0 or code == 1:
        mooney_rivlin_derivatives(J, phi_m, C, Ci, dS[:, 0], G)
        if code == 0:
            for i in range(6):
                dS[i, 1] = G[i]
    elif code == 2:
        ogden_derivatives(e, p, off, opt, phi_m, C, Ci, w, Q, work, dS)
    elif code == 3:
        yeoh_derivatives(e, phi_m, C, Ci, G, dS)


@kernel
def fibre_stress(code, opt, x, p, off):
    """``(sigma, dsigma/deps)`` of the fibre law ``code`` at ``x = eps - eps0`` (before the tension cut)."""
    if code == 0:
        return linear_fibre_stress(x, p[off])
    if code == 1:
        return exponential_fibre_stress(x, p, off, opt)
    return 0.0, 0.0


@kernel
def fibre_energy(code, opt, x, p, off):
    """The fibre's elastic strain energy at ``x`` (tension only)."""
    if code == 0:
        return 0.5 * p[off] * max(0.0, x) ** 2
    if code == 1:
        return exponential_fibre_energy(x, p, off, opt)
    return 0.0


@kernel
def fibre_derivatives(code, opt, x, p, off, out):
    """``out[j]``: the fibre stress's derivative by the law's parameter j at fixed fibre strain."""
    if code == 0:
        out[0] = x
    elif code == 1:
        exponential_fibre_derivatives(x, p, off, opt, out)


@kernel
def fibre_dispersion_index(code):
    """Position of the dispersion parameter among the fibre law's own (-1: none, the structure tensor is M)."""
    if code == 1:
        return 2
    return -1
