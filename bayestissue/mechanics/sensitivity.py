r"""Exact forward sensitivities :math:`\partial y_n / \partial p` by direct differentiation of the discrete steps, one
step at a time inside the time loop (:mod:`~bayestissue.mechanics.solver`).

At step :math:`n` the converged strain satisfies :math:`R(E^n; p, \mathcal H^{n-1}) = 0` on the free components and
:math:`E_i = \bar E_i(t_n)` on the prescribed ones (the load case's targets do not depend on :math:`p`), with
:math:`\mathcal H` the Prony histories. Differentiating,

.. math:: \tilde D\, \frac{dE^n}{dp} = -\left.\frac{\partial S}{\partial p}\right|_{E^n}

on the free rows (:math:`\tilde D` the Newton matrix: the stress tangent, the dead loads' Jacobian, identity rows and
columns for the prescribed components; zero right-hand side there), factorised once for every parameter. The explicit
derivative at fixed strain collects, for the matrix, the law's :math:`\partial S_{iso}/\partial p`
(:func:`~bayestissue.mechanics.laws.dispatch.matrix_derivatives`) and for each of its branches and each fibre
branch (paper eqs. (5)-(6); :math:`\tilde\tau = (r\sigma + q)/c`, :math:`q = \gamma(a h - b\tau^{n-1})`)

.. math:: \left.\frac{d\tilde\tau}{dp}\right|_E = \frac{1}{c}\left[r\frac{\partial\sigma}{\partial p}
          + \sigma\frac{\partial r}{\partial p} + \frac{dq}{dp} - \tilde\tau\frac{\partial c}{\partial p}\right],
          \qquad \frac{dq}{dp} = \frac{\partial q}{\partial p}
          + \gamma\left(a \frac{dh^{n-1}}{dp} - b\frac{d\tau^{n-1}}{dp}\right),

times :math:`\phi_k H_k` on a fibre branch in tension (the one-sided derivative of the branch the kernel takes at
:math:`\tilde\tau = 0`: the compression branch, :math:`d\tau = 0`); a dispersion parameter acts through the fibre
strain (:math:`\partial\varepsilon/\partial\kappa = \mathrm{tr}E - 3 M:E`) and the structure tensor
(:math:`\partial H/\partial\kappa = I - 3M`). The histories are differentiated along:
:math:`d\tau^n = [\tilde\tau > 0](d\tilde\tau|_E + (r\sigma'/c) H : dE^n)` (the matrix branches without the cut,
with the isochoric tangent in place of :math:`\sigma' H\otimes H`) and :math:`dh^n = da\, h^{n-1} + a\, dh^{n-1} +
db(\tau^n - \tau^{n-1}) + b(d\tau^n - d\tau^{n-1})` (eq. (7); :math:`da/d\beta = -\Delta t\, a`,
:math:`db/d\beta = -\tfrac{\Delta t}{2} b`), starting from :math:`\tau^0 = \max(0, r\sigma(-\varepsilon_0))` (eq. (8))
and :math:`dh^0 = 0` (eq. (9)). The observed channels follow from :math:`dE^n/dp` and the total stress derivative
:math:`dS/dp = \partial S/\partial p|_E + (\partial S/\partial E)\, dE^n/dp`: the displacement
:math:`L_i\, dE_{ii}/\lambda_i`, the nominal stress :math:`\lambda_i dS_{ii} + S_{ii}\, dE_{ii}/\lambda_i`, the
simple-shear stress :math:`dS_{12} + 2E_{12}\, dS_{22}`.

Away from the (measure-zero) parameter values where a branch switches, the discrete map is smooth and these are its
exact derivatives up to the Newton tolerance of the stored states.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from bayestissue.mechanics._jit import FASTMATH as _FASTMATH
from bayestissue.mechanics._jit import kernel
from bayestissue.mechanics.composite import fibre_offset, structure_and_strain
from bayestissue.mechanics.laws.dispatch import (
    fibre_derivatives,
    fibre_dispersion_index,
    fibre_stress,
    matrix_derivatives,
    matrix_stress_tangent,
)
from bayestissue.mechanics.laws.prony import branch_offset

__all__ = ["MAX_LAW", "SensitivityState", "sensitivity_step", "start_sensitivities"]


@njit(cache=True, fastmath=_FASTMATH)
def SensitivityState(n_p, nf, nbf1, nbm1, n_ch, want):  # noqa: N802 (a state constructor)
    """The arrays the sensitivity steps carry (one-column placeholders without ``want``): ``B`` (explicit stress
    derivatives), ``X`` (dE/dp) (6, n_p); the fibre branches' dtau (previous and current), dh and d(trial) (n_f, nbf1,
    n_p); the matrix branches' (nbm1, 6, n_p); the channels' derivatives (n_ch, n_p); scratch."""
    m = n_p if want else 1
    return (
        np.zeros((6, m)),  # B
        np.zeros((6, m)),  # X
        np.zeros((nf, nbf1, m)),  # dtau_f of step n - 1
        np.zeros((nf, nbf1, m)),  # dh_f
        np.zeros((nf, nbf1, m)),  # d trial_f at fixed E
        np.zeros((nbm1, 6, m)),  # dtau_m of step n - 1
        np.zeros((nbm1, 6, m)),  # dh_m
        np.zeros((nbm1, 6, m)),  # d trial_m at fixed E
        np.zeros((n_ch, m)),  # the channels
        np.zeros((6, 6)),  # the Newton matrix
        np.zeros((6, 6)),  # the isochoric tangent (matrix branches)
        np.zeros((6, 8)),  # the matrix law's derivatives (at most 8 parameters: 4 Ogden terms... see MAX_LAW)
        np.zeros(8),  # the fibre law's derivatives
        np.zeros(6),  # the isochoric stress
    )


#: Most parameters of one law the scratch arrays hold (Ogden with 4 terms; a larger law raises at compile-time use).
MAX_LAW = 8


@kernel
def _branch_columns(ob, b):
    """Columns of branch ``b``'s r (-1 for the first branch), gamma and beta, its law's branch parameters starting at
    ``ob``."""
    o = ob + branch_offset(b)
    if b == 0:
        return -1, o, o + 1
    return o, o + 1, o + 2


@kernel
def start_sensitivities(sens, p, lay, eps0, tau_f_old):
    """Zero the carried derivatives and set :math:`d\\tau^0/dp` of the fibre branches loaded at E = 0 (eq. (8))."""
    B, X, dtf_old, dhf, dtrf, dtm_old, dhm, dtrm, dobs, Dn, Diso, dSl, dsig, Siso = sens
    dtf_old[:] = 0.0
    dhf[:] = 0.0
    dtm_old[:] = 0.0
    dhm[:] = 0.0
    nb_f = lay[7]
    for k in range(lay[8]):
        off = fibre_offset(lay, k)
        x = 0.0 - eps0[k]
        sig, _ = fibre_stress(lay[4], lay[6], x, p, off)
        fibre_derivatives(lay[4], lay[6], x, p, off, dsig)
        for b in range(max(nb_f, 1)):
            if not (tau_f_old[k, b] > 0.0):
                continue
            ir = -1
            if nb_f > 0:
                ir, _, _ = _branch_columns(off + lay[5], b)
            r = 1.0 if ir < 0 else p[ir]
            for j in range(lay[5]):
                dtf_old[k, b, off + j] = r * dsig[j]
            if ir >= 0:
                dtf_old[k, b, ir] = sig


@kernel
def _matrix_explicit(sens, e, p, lay, phi_m, bulk, dt, am, bm, cm, gm, hm, tau_m_old, tau_m, scr):
    """B += the matrix's stress derivatives at fixed strain (its law's and its branches', with the histories')."""
    B, X, dtf_old, dhf, dtrf, dtm_old, dhm, dtrm, dobs, Dn, Diso, dSl, dsig, Siso = sens
    C, Ci, w, Q, work, G, H = scr
    nb_m = lay[3]
    n_p = B.shape[1]
    J = matrix_stress_tangent(lay[0], lay[2], e, p, 0, phi_m, bulk if nb_m == 0 else 0.0, Siso, Diso, nb_m > 0,
                              C, Ci, w, Q, work, G)  # fmt: skip
    matrix_derivatives(lay[0], lay[2], J, e, p, 0, phi_m, C, Ci, w, Q, work, G, dSl)
    if nb_m == 0:
        for i in range(6):
            for j in range(lay[1]):
                B[i, j] += dSl[i, j]
        return
    for b in range(nb_m):
        ir, ig, ibt = _branch_columns(lay[1], b)
        r = 1.0 if ir < 0 else p[ir]
        c = cm[b]
        for i in range(6):
            for j in range(n_p):  # dq/dp through the history
                dtrm[b, i, j] = gm[b] * (am[b] * dhm[b, i, j] - bm[b] * dtm_old[b, i, j])
            for j in range(lay[1]):
                dtrm[b, i, j] += r * dSl[i, j]
            if ir >= 0:
                dtrm[b, i, ir] += Siso[i]
            dtrm[b, i, ig] += am[b] * hm[b, i] - bm[b] * tau_m_old[b, i] + tau_m[b, i] * bm[b]  # dq/dg; dc/dg = -b
            dtrm[b, i, ibt] += gm[b] * (-dt * am[b] * hm[b, i] + 0.5 * dt * bm[b] * tau_m_old[b, i])
            dtrm[b, i, ibt] -= tau_m[b, i] * gm[b] * 0.5 * dt * bm[b]  # dc/dbeta = gamma b dt / 2
            for j in range(n_p):
                dtrm[b, i, j] /= c
                B[i, j] += dtrm[b, i, j]


@kernel
def _fibre_explicit(sens, e, p, lay, M, phi_f, eps0, dt, af, bf, cf, gf, hf, tau_f_old, tau_f, H):
    """B += the fibres' stress derivatives at fixed strain; keeps each branch's d(trial)/dp for the history."""
    B, X, dtf_old, dhf, dtrf, dtm_old, dhm, dtrm, dobs, Dn, Diso, dSl, dsig, Siso = sens
    n_p = B.shape[1]
    nb_f = lay[7]
    kidx = fibre_dispersion_index(lay[4])
    for k in range(lay[8]):
        off = fibre_offset(lay, k)
        eps = structure_and_strain(lay, p, off, M[k], e, H)
        x = eps - eps0[k]
        sig, dsg = fibre_stress(lay[4], lay[6], x, p, off)
        fibre_derivatives(lay[4], lay[6], x, p, off, dsig)
        deps_k = 0.0
        if kidx >= 0:  # d eps / d kappa at fixed E: tr E - 3 M : E
            me = M[k, 0] * e[0] + M[k, 1] * e[1] + M[k, 2] * e[2]
            me += 2.0 * (M[k, 3] * e[3] + M[k, 4] * e[4] + M[k, 5] * e[5])
            deps_k = e[0] + e[1] + e[2] - 3.0 * me
        for b in range(max(nb_f, 1)):
            ir, ig, ibt = -1, -1, -1
            c = 1.0
            if nb_f > 0:
                ir, ig, ibt = _branch_columns(off + lay[5], b)
                c = cf[k, b]
            r = 1.0 if ir < 0 else p[ir]
            for j in range(n_p):
                dtrf[k, b, j] = 0.0
            if nb_f > 0:
                for j in range(n_p):  # dq/dp through the history
                    dtrf[k, b, j] = gf[k, b] * (af[k, b] * dhf[k, b, j] - bf[k, b] * dtf_old[k, b, j])
                dtrf[k, b, ig] += af[k, b] * hf[k, b] - bf[k, b] * tau_f_old[k, b]
                dtrf[k, b, ibt] += gf[k, b] * (-dt * af[k, b] * hf[k, b] + 0.5 * dt * bf[k, b] * tau_f_old[k, b])
            for j in range(lay[5]):
                dtrf[k, b, off + j] += r * dsig[j]
            if kidx >= 0:
                dtrf[k, b, off + kidx] += r * dsg * deps_k
            if ir >= 0:
                dtrf[k, b, ir] += sig
            trial = tau_f[k, b]
            if nb_f > 0:
                dtrf[k, b, ig] += trial * bf[k, b]  # - trial dc/dgamma, dc/dgamma = -b
                dtrf[k, b, ibt] -= trial * gf[k, b] * 0.5 * dt * bf[k, b]  # dc/dbeta = gamma b dt / 2
                for j in range(n_p):
                    dtrf[k, b, j] /= c
            if trial > 0.0:
                for i in range(6):
                    wgt = phi_f[k] * H[i]
                    for j in range(n_p):
                        B[i, j] += wgt * dtrf[k, b, j]
                if kidx >= 0:
                    for i in range(6):
                        B[i, off + kidx] += phi_f[k] * trial * ((1.0 if i < 3 else 0.0) - 3.0 * M[k, i])


@kernel
def _histories(sens, e, p, lay, M, eps0, dt, am, bm, cm, af, bf, cf, hm, hf, tau_m_old, tau_f_old, tau_m, tau_f, H):
    """The branches' dtau^n and dh^n (eq. (7) differentiated) from dE/dp in X."""
    B, X, dtf_old, dhf, dtrf, dtm_old, dhm, dtrm, dobs, Dn, Diso, dSl, dsig, Siso = sens
    n_p = B.shape[1]
    nb_m = lay[3]
    nb_f = lay[7]
    for b in range(nb_m):
        ir, _, ibt = _branch_columns(lay[1], b)
        r = 1.0 if ir < 0 else p[ir]
        for i in range(6):
            for j in range(n_p):
                dx = 0.0
                for l in range(6):
                    dx += Diso[i, l] * X[l, j]
                dtau = dtrm[b, i, j] + r * dx / cm[b]
                dhm[b, i, j] = am[b] * dhm[b, i, j] + bm[b] * (dtau - dtm_old[b, i, j])
                dtm_old[b, i, j] = dtau
            dhm[b, i, ibt] += -dt * am[b] * hm[b, i] - 0.5 * dt * bm[b] * (tau_m[b, i] - tau_m_old[b, i])
    for k in range(lay[8]):
        off = fibre_offset(lay, k)
        eps = structure_and_strain(lay, p, off, M[k], e, H)
        _, dsg = fibre_stress(lay[4], lay[6], eps - eps0[k], p, off)
        for b in range(max(nb_f, 1)):
            ir, ibt = -1, -1
            c = 1.0
            if nb_f > 0:
                ir, _, ibt = _branch_columns(off + lay[5], b)
                c = cf[k, b]
            r = 1.0 if ir < 0 else p[ir]
            active = tau_f[k, b] > 0.0
            slope = r * dsg / c
            for j in range(n_p):
                dtau = 0.0
                if active:
                    hx = H[0] * X[0, j] + H[1] * X[1, j] + H[2] * X[2, j]
                    hx += 2.0 * (H[3] * X[3, j] + H[4] * X[4, j] + H[5] * X[5, j])
                    dtau = dtrf[k, b, j] + slope * hx
                if nb_f > 0:
                    dhf[k, b, j] = af[k, b] * dhf[k, b, j] + bf[k, b] * (dtau - dtf_old[k, b, j])
                dtf_old[k, b, j] = dtau
            if nb_f > 0:
                dhf[k, b, ibt] += -dt * af[k, b] * hf[k, b] - 0.5 * dt * bf[k, b] * (tau_f[k, b] - tau_f_old[k, b])


@kernel
def sensitivity_step(sens, e, p, lay, M, phi_f, phi_m, bulk, eps0, kinds, values, n, dt, lengths, channels, am, bm,
                     cm, gm, af, bf, cf, gf, hm, hf, tau_m_old, tau_f_old, tau_m, tau_f, S, D, scr):  # fmt: skip
    """The derivatives of step ``n`` (module docstring) into ``sens``, from the converged state: ``S``, ``D`` the
    composite stress and stress tangent at ``e``, ``tau_*`` the branch stresses there, ``h*`` and ``tau_*_old`` the
    histories of step n - 1 (not yet updated). Returns False for a singular Newton matrix."""
    B, X, dtf_old, dhf, dtrf, dtm_old, dhm, dtrm, dobs, Dn, Diso, dSl, dsig, Siso = sens
    n_p = B.shape[1]
    for i in range(6):
        for j in range(6):
            Dn[i, j] = D[i, j]
        for j in range(n_p):
            B[i, j] = 0.0
    _matrix_explicit(sens, e, p, lay, phi_m, bulk, dt, am, bm, cm, gm, hm, tau_m_old, tau_m, scr)
    _fibre_explicit(sens, e, p, lay, M, phi_f, eps0, dt, af, bf, cf, gf, hf, tau_f_old, tau_f, scr[6])
    for i in range(3):  # the Newton matrix: dead loads' Jacobian, prescribed components fixed
        if kinds[i] == 1:
            Dn[i, i] += values[n, i] * (1.0 + 2.0 * e[i]) ** -1.5
    for i in range(6):
        if kinds[i] >= 2:
            for j in range(6):
                Dn[i, j] = 0.0
                Dn[j, i] = 0.0
            Dn[i, i] = 1.0
    for i in range(6):
        for j in range(n_p):
            X[i, j] = -B[i, j] if kinds[i] < 2 else 0.0
    if not _factor_solve6(Dn, X):
        return False
    _histories(sens, e, p, lay, M, eps0, dt, am, bm, cm, af, bf, cf, hm, hf, tau_m_old, tau_f_old, tau_m, tau_f,
               scr[6])  # fmt: skip
    for ch in range(channels.shape[0]):
        kind = channels[ch, 0]
        i = channels[ch, 1]
        lam = np.sqrt(1.0 + 2.0 * e[i])
        for j in range(n_p):
            if kind == 0:
                dobs[ch, j] = lengths[i] / lam * X[i, j]
                continue
            ds_i = B[i, j]
            ds_s = B[1, j]
            ds_t = B[3, j]
            for l in range(6):
                ds_i += D[i, l] * X[l, j]
                ds_s += D[1, l] * X[l, j]
                ds_t += D[3, l] * X[l, j]
            if kind == 1:
                if kinds[i] == 2:
                    dobs[ch, j] = values[n, i] * ds_i
                else:
                    dobs[ch, j] = lam * ds_i + S[i] * X[i, j] / lam
            else:
                dobs[ch, j] = ds_t + 2.0 * e[3] * ds_s + 2.0 * X[3, j] * S[1]
    return True


@kernel
def _factor_solve6(A, X):
    """Solve ``A Y = X`` in place for the (6, m) right-hand sides ``X`` (Gaussian elimination with partial pivoting,
    one factorisation for all columns; ``A`` overwritten). Returns False if ``A`` is singular."""
    n = 6
    m = X.shape[1]
    for k in range(n):
        p = k
        amax = abs(A[k, k])
        for i in range(k + 1, n):
            if abs(A[i, k]) > amax:
                amax = abs(A[i, k])
                p = i
        if not (amax > 1e-300):
            return False
        if p != k:
            for j in range(n):
                tmp = A[k, j]
                A[k, j] = A[p, j]
                A[p, j] = tmp
            for j in range(m):
                tmp = X[k, j]
                X[k, j] = X[p, j]
                X[p, j] = tmp
        inv = 1.0 / A[k, k]
        for i in range(k + 1, n):
            f = A[i, k] * inv
            if f != 0.0:
                for j in range(k + 1, n):
                    A[i, j] -= f * A[k, j]
                for j in range(m):
                    X[i, j] -= f * X[k, j]
    for c in range(m):
        for i in range(n - 1, -1, -1):
            s = X[i, c]
            for j in range(i + 1, n):
                s -= A[i, j] * X[j, c]
            X[i, c] = s / A[i, i]
    return True
