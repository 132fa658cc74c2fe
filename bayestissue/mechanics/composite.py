r"""The composite's stress, tangent and incremental potential at one strain, within one time step.

The tissue of docs/model.md (paper eq. (4)): the matrix law (isochoric, scaled by :math:`\phi_m`) with its volumetric
penalty, plus the fibre families, each :math:`\phi_k \tau_k H_k` with the family's structure tensor :math:`H_k`
(:math:`M_k = v_k \otimes v_k`, or its dispersed form for a law with dispersion) and fibre strain
:math:`\varepsilon_k = H_k : E`:

.. math:: S = S_m + \sum_k \phi_k \sum_i \tau_{k,i} H_k, \qquad
          \tau_{k,i} = \max\left(0, \frac{r_i \sigma(\varepsilon_k - \varepsilon_{0,k}) + q_{k,i}}{c_{k,i}}\right),

the branches :math:`i` of the Prony series (:mod:`~bayestissue.mechanics.laws.prony`; without branches
:math:`\tau_k = \max(0, \sigma)`), and for a matrix with branches
:math:`S_m = \sum_i (r_i S_{iso} + q_i)/c_i + S_{vol}`. Within a step the history terms :math:`q` are fixed, so
the stress is a function of the strain alone; its tangent is

.. math:: \frac{\partial S}{\partial E} = \frac{\partial S_m}{\partial E}
          + \sum_k \phi_k \sum_i \frac{r_i \sigma'}{c_{k,i}} [\tau_{k,i} > 0]\, H_k \otimes H_k .

The incremental potential (whose gradient is the stress; the Newton loop's merit function) is the matrix energy (for
branches :math:`\sum_i (r_i W_{iso} + q_i : E)/c_i + W_{vol}`) plus the fibres' energies: elastic
:math:`w(\varepsilon)`; with branches, for the linear fibre the exact :math:`\tfrac{c}{2 r g}\max(0, \tilde\tau)^2`
per branch, for a nonlinear fibre :math:`(r w + q\varepsilon)/c` where the branch is in tension (exact there; the
switch point's constant is dropped, so across a switch it is a merit function, not the potential).

Layout (``lay``, :attr:`~bayestissue.mechanics.tissue.TissueConfig.layout`): matrix code, its parameter count,
option, branches; fibre code, parameter count, option, branches; number of families.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from bayestissue.mechanics._jit import kernel
from bayestissue.mechanics.laws.dispatch import (
    fibre_dispersion_index,
    fibre_energy,
    fibre_stress,
    matrix_energy,
    matrix_stress_tangent,
)
from bayestissue.mechanics.laws.mooney_rivlin import mooney_rivlin_energy, mooney_rivlin_stress_tangent
from bayestissue.mechanics.laws.prony import branch_offset, branch_parameter_count
from bayestissue.mechanics.laws.volumetric import volumetric_add

__all__ = [
    "composite_energy",
    "composite_stress_tangent",
    "fibre_offset",
    "scratch",
    "structure_and_strain",
    "workspace",
]


@njit(cache=True)
def workspace():
    """The scratch arrays of the composite's kernels, packed: ``(w33, w6, w66)`` of shapes (4, 3, 3), (4, 6), (6, 6)
    (:func:`scratch` names the parts). Packed because numba passes every array argument as 7-11 machine words, all
    written to the stack at every call: the Newton loop calls the composite at every iteration, and its scratch as
    nine arrays (as it was) took 44 more words per call than these three."""
    return np.empty((4, 3, 3)), np.empty((4, 6)), np.empty((6, 6))


@njit(cache=True)
def scratch(ws):
    """The laws' scratch tuple ``(C, Ci, w, Q, work, G, H)`` (views into the workspace ``ws``): C, Ci, Q, work 3x3;
    w (6,), of which an eigen solve uses the first three entries; G, H (6,)."""
    w33, w6, _ = ws
    return w33[0], w33[1], w6[0], w33[2], w33[3], w6[1], w6[2]


@kernel
def fibre_offset(lay, k):
    """Position of family ``k``'s first parameter (its fibre law's) in a parameter row."""
    stride = lay[5] + branch_parameter_count(lay[7])
    return lay[1] + branch_parameter_count(lay[3]) + k * stride


@kernel
def structure_and_strain(lay, p, off, Mk, e, H):
    """Fill the family's structure tensor ``H`` (6,) (dispersed where the fibre law has a dispersion parameter) and
    return its fibre strain :math:`H : E`."""
    kidx = -1 if lay[4] == 0 else fibre_dispersion_index(lay[4])
    if kidx >= 0:
        kap = p[off + kidx]
        for i in range(6):
            H[i] = (kap if i < 3 else 0.0) + (1.0 - 3.0 * kap) * Mk[i]
    else:
        for i in range(6):
            H[i] = Mk[i]
    eps = H[0] * e[0] + H[1] * e[1] + H[2] * e[2]
    eps += 2.0 * (H[3] * e[3] + H[4] * e[4] + H[5] * e[5])
    return eps


@kernel
def composite_stress_tangent(e, p, lay, M, phi_f, phi_m, bulk, eps0, ms, fs, S, D, want_tangent, ws):
    """Stress ``S`` (6,) and, if ``want_tangent``, tangent ``D`` (6, 6) of the composite at the Voigt strain ``e``.

    ``ms`` (3, max(nb_m, 1), 6): the matrix branches' constants c (each repeated over the six components), history
    terms q, then the branch stresses tau (written). ``fs`` (3, n_f, max(nb_f, 1)): the fibre branches' constants
    c, history terms q, then the tensions tau (written; after the tension cut, the elastic tension without
    branches). ``ws``: the workspace (:func:`workspace`). Returns J (<= 0: inadmissible).
    """
    cm, qm, tau_m = ms[0], ms[1], ms[2]
    cf, qf, tau_f = fs[0], fs[1], fs[2]
    w33, w6, work66 = ws  # the workspace's parts (as in :func:`scratch`; a call would pass its words again)
    C, Ci, Q, work = w33[0], w33[1], w33[2], w33[3]
    w, G, H, work6 = w6[0], w6[1], w6[2], w6[3]
    nb_m = lay[3]
    if nb_m == 0:
        if lay[0] == 0:  # the paper's matrix without the dispatch (fast path: measured below)
            J = mooney_rivlin_stress_tangent(e, p[0], p[1], phi_m, bulk, S, D, want_tangent, C, Ci)
        else:
            J = matrix_stress_tangent(lay[0], lay[2], e, p, 0, phi_m, bulk, S, D, want_tangent, C, Ci, w, Q, work, G)
        if not (J > 0.0):
            return -1.0
    else:
        J = matrix_stress_tangent(lay[0], lay[2], e, p, 0, phi_m, 0.0, work6, work66, want_tangent, C, Ci, w, Q,
                                  work, G)  # fmt: skip
        if not (J > 0.0):
            return -1.0
        for i in range(6):
            S[i] = 0.0
            if want_tangent:
                for j in range(6):
                    D[i, j] = 0.0
        ob = lay[1]
        for b in range(nb_m):
            r = 1.0 if b == 0 else p[ob + branch_offset(b)]
            for i in range(6):
                t = (r * work6[i] + qm[b, i]) / cm[b, i]
                tau_m[b, i] = t
                S[i] += t
            if want_tangent:
                for i in range(6):
                    for j in range(6):
                        D[i, j] += r * work66[i, j] / cm[b, 0]
        volumetric_add(J, bulk, Ci, S, D, want_tangent)
    nb_f = lay[7]
    for k in range(lay[8]):
        off = fibre_offset(lay, k)
        if lay[4] == 0:  # the paper's linear fibre without the dispatch (fast path), on M_k itself
            Hk = M[k]
            eps = Hk[0] * e[0] + Hk[1] * e[1] + Hk[2] * e[2]
            eps += 2.0 * (Hk[3] * e[3] + Hk[4] * e[4] + Hk[5] * e[5])
            sig, dsig = p[off] * (eps - eps0[k]), p[off]
        else:
            eps = structure_and_strain(lay, p, off, M[k], e, H)
            Hk = H
            sig, dsig = fibre_stress(lay[4], lay[6], eps - eps0[k], p, off)
        if nb_f == 0:
            tau_f[k, 0] = sig if sig > 0.0 else 0.0
            if sig > 0.0:
                for i in range(6):
                    S[i] += phi_f[k] * sig * Hk[i]
                if want_tangent:
                    g = phi_f[k] * dsig
                    for i in range(6):
                        for j in range(6):
                            D[i, j] += g * Hk[i] * Hk[j] * (1.0 if j < 3 else 2.0)
            continue
        ob = off + lay[5]
        for b in range(nb_f):
            r = 1.0 if b == 0 else p[ob + branch_offset(b)]
            trial = (r * sig + qf[k, b]) / cf[k, b]
            if trial > 0.0:
                tau_f[k, b] = trial
                for i in range(6):
                    S[i] += phi_f[k] * trial * Hk[i]
                if want_tangent:
                    g = phi_f[k] * (r * dsig) / cf[k, b]
                    for i in range(6):
                        for j in range(6):
                            D[i, j] += g * Hk[i] * Hk[j] * (1.0 if j < 3 else 2.0)
            else:
                tau_f[k, b] = 0.0
    return J


@kernel
def composite_energy(e, p, lay, M, phi_f, phi_m, bulk, eps0, ms, fs, ws):
    """The incremental potential at ``e`` (module docstring); NaN if inadmissible. Arguments as for
    :func:`composite_stress_tangent`."""
    cm, qm = ms[0], ms[1]
    cf, qf = fs[0], fs[1]
    w33, w6, _ = ws
    C, Ci, Q, work = w33[0], w33[1], w33[2], w33[3]
    w, G, H = w6[0], w6[1], w6[2]
    nb_m = lay[3]
    if nb_m == 0 and lay[0] == 0:  # fast path, as in the stress
        total = mooney_rivlin_energy(e, p[0], p[1], phi_m, bulk, C, Ci)
    elif nb_m == 0:
        total = matrix_energy(lay[0], lay[2], e, p, 0, phi_m, bulk, C, Ci, w, Q, work, G)
    else:
        wi = matrix_energy(lay[0], lay[2], e, p, 0, phi_m, 0.0, C, Ci, w, Q, work, G)
        total = 0.0
        ob = lay[1]
        for b in range(nb_m):
            r = 1.0 if b == 0 else p[ob + branch_offset(b)]
            qe = qm[b, 0] * e[0] + qm[b, 1] * e[1] + qm[b, 2] * e[2]
            qe += 2.0 * (qm[b, 3] * e[3] + qm[b, 4] * e[4] + qm[b, 5] * e[5])
            total += (r * wi + qe) / cm[b, 0]
        det = C[0, 0] * (C[1, 1] * C[2, 2] - C[1, 2] * C[2, 1]) - C[0, 1] * (C[1, 0] * C[2, 2] - C[1, 2] * C[2, 0])
        det += C[0, 2] * (C[1, 0] * C[2, 1] - C[1, 1] * C[2, 0])
        total += 0.5 * bulk * (np.sqrt(det) - 1.0) ** 2
    nb_f = lay[7]
    wf = 0.0
    for k in range(lay[8]):
        off = fibre_offset(lay, k)
        eps = structure_and_strain(lay, p, off, M[k], e, H)
        x = eps - eps0[k]
        if nb_f == 0:
            wf += phi_f[k] * fibre_energy(lay[4], lay[6], x, p, off)
            continue
        sig = p[off] * x if lay[4] == 0 else fibre_stress(lay[4], lay[6], x, p, off)[0]
        ob = off + lay[5]
        for b in range(nb_f):
            r = 1.0 if b == 0 else p[ob + branch_offset(b)]
            c = cf[k, b]
            trial = (r * sig + qf[k, b]) / c
            if lay[4] == 0:  # linear fibre: the exact potential of the clipped branch (its slope is r g / c)
                g = p[off]
                if g > 0.0:
                    wf += phi_f[k] * 0.5 * c / (r * g) * max(0.0, trial) ** 2
                else:
                    wf += phi_f[k] * max(0.0, trial) * eps
            elif trial > 0.0:
                wf += phi_f[k] * (r * fibre_energy(lay[4], lay[6], x, p, off) + qf[k, b] * eps) / c
    return total + wf
