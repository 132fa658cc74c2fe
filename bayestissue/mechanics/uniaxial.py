r"""The reduced FE model of a uniaxial test, batched over parameter sets.

A homogeneous block :math:`L_x \times L_y \times L_z` under a dead load along x with traction-free lateral faces
deforms homogeneously, so one element with one quadrature point is exact (docs/model.md). With the rigid rotation fixed
so that :math:`F e_1 \parallel e_1`, equilibrium at every time step reads

.. math:: S(E) = \frac{P_{11}}{\sqrt{C_{11}}}\, e_1 \otimes e_1,

six equations for the six components of the symmetric Green strain :math:`E` (F is *not* forced diagonal: fibre
families that are not mirror-symmetric about x shear the block). They are solved by Newton's method with the
consistent tangent of :mod:`~bayestissue.mechanics.matrix` and :mod:`~bayestissue.mechanics.fibres`, the Jacobian
entry :math:`\partial R_{11}/\partial E_{11}` gaining :math:`P_{11} C_{11}^{-3/2}` from the dead load, safeguarded by
backtracking: a step is accepted when :math:`\|R\|_2` decreases or, failing that, when the incremental potential
:math:`\Pi = W(E) - P_{11}(\sqrt{C_{11}} - 1)` (whose gradient is :math:`R`; the fibre part is the piecewise quadratic
of :func:`~bayestissue.mechanics.fibres.fibre_energy`) satisfies Armijo's condition; otherwise the step is halved,
also whenever :math:`J \le 0`. The potential criterion matters when stiff fibres meet a soft matrix: there the
residual norm is a poor merit function and Newton steps that lower the energy would be rejected. The observable is the
x-displacement of the loaded face, :math:`u = (\sqrt{C_{11}} - 1) L_x`.

Under stretch control (``stretch_control``: displacement-controlled tests, the load history is then the prescribed
stretch :math:`\lambda_n` of the loaded face) :math:`E_{11} = (\lambda_n^2 - 1)/2` is fixed and the other five
equations :math:`S_{ij}(E) = 0`, :math:`ij \ne 11` (traction-free lateral faces; the block may still shear) are solved
for the five free components: row and column 11 of the tangent are replaced by the identity, so the Newton step leaves
:math:`E_{11}` alone, and the potential is :math:`W(E)` over the free components. The observable is then the nominal
stress on the loaded face, :math:`P_{11} = \lambda_n S_{11}` (with :math:`S = S_{11} e_1 \otimes e_1` at
equilibrium, the traction :math:`P e_1 = F S e_1 = S_{11} F e_1` is along x), evaluated at the converged strain.

A parameter set whose solve fails (no convergence in ``MAX_ITER`` iterations, :math:`J \le 0`, a singular tangent,
NaN) is flagged: its row of the output is NaN and ``ok`` is False; the other rows are unaffected.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from bayestissue.mechanics._jit import FASTMATH as _FASTMATH
from bayestissue.mechanics._jit import kernel
from bayestissue.mechanics.fibres import (
    fibre_energy,
    fibre_stress_tangent,
    fibre_tension,
    kelvin_history_update,
    kelvin_step_constants,
)
from bayestissue.mechanics.matrix import matrix_energy, matrix_stress_tangent

__all__ = ["solve_uniaxial_batch", "MAX_ITER", "MAX_HALVINGS", "RTOL", "STEP_TOL"]

#: Newton iterations allowed per time step before the set is declared failed.
MAX_ITER = 60
#: Step halvings allowed per Newton iteration (backtracking line search).
MAX_HALVINGS = 40
#: Residual tolerance relative to max(|P11|, 1 kPa): ||R||_inf <= RTOL * max(|P11|, 1) kPa.
RTOL = 1e-10
#: A full Newton step smaller than this (max-norm of the strain increment) ends the iteration: with quadratic
#: convergence the remaining strain error is ~ k STEP_TOL^2 ~ 1e-11 (k ~ 10 here), i.e. < 1e-10 mm of displacement
#: against data noise of ~0.02 mm; tests compare whole curves with an independent solver to 1e-8 mm.
STEP_TOL = 1e-6


@kernel
def _residual(e, load, mu, kappa, phi_m, bulk, M, phi_f, ginf, eps0, c, q, R, tau, D, want_tangent, C, Ci):
    """R = S(E) - P11/sqrt(C11) e1(x)e1 (and its Jacobian in D). Returns J (<= 0: inadmissible)."""
    J = matrix_stress_tangent(e, mu, kappa, phi_m, bulk, R, D, want_tangent, C, Ci)
    if not (J > 0.0):
        return -1.0
    fibre_stress_tangent(e, M, phi_f, ginf, eps0, c, q, R, D, tau, want_tangent)
    c11 = 1.0 + 2.0 * e[0]
    R[0] -= load / np.sqrt(c11)
    if want_tangent:
        D[0, 0] += load * c11**-1.5
    return J


@kernel
def _potential(e, load, mu, kappa, phi_m, bulk, M, phi_f, ginf, eps0, c, q, C, Ci):
    """Incremental potential of the step: W_matrix + W_fibres - P11 (sqrt(C11) - 1); its gradient is R."""
    w = matrix_energy(e, mu, kappa, phi_m, bulk, C, Ci)
    return w + fibre_energy(e, M, phi_f, ginf, eps0, c, q) - load * (np.sqrt(1.0 + 2.0 * e[0]) - 1.0)


@kernel
def _solve6(A, b, x):
    """Solve the 6x6 system A x = b by Gaussian elimination with partial pivoting (A, b overwritten).

    Returns False if A is numerically singular."""
    n = 6
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
            tmp = b[k]
            b[k] = b[p]
            b[p] = tmp
        inv = 1.0 / A[k, k]
        for i in range(k + 1, n):
            f = A[i, k] * inv
            if f != 0.0:
                for j in range(k + 1, n):
                    A[i, j] -= f * A[k, j]
                b[i] -= f * b[k]
    for i in range(n - 1, -1, -1):
        s = b[i]
        for j in range(i + 1, n):
            s -= A[i, j] * x[j]
        x[i] = s / A[i, i]
    return True


@njit(cache=True, fastmath=_FASTMATH)
def solve_uniaxial_batch(
    params,
    M,
    phi_f,
    phi_m,
    bulk,
    eps0,
    load,
    dt,
    length_x,
    u_out,
    ok,
    strain,
    tension,
    full,
    iterations,
    stretch_control=False,
):
    """Integrate the uniaxial test for every parameter set (row of ``params``).

    Parameters
    ----------
    params : (n_sets, 2 + 3 n_f) ndarray
        ``mu, kappa, ginf_k, gamma_k, beta_k`` in the paper's order.
    M : (n_f, 6) ndarray
        Voigt structure tensors of the fibre directions.
    phi_f, eps0 : (n_f,) ndarray
        Fibre volume fractions and slack strains.
    phi_m, bulk : float
        Matrix volume fraction and bulk modulus (kPa).
    load : (n_steps + 1,) ndarray
        Nominal stress P11 (kPa) at the simulation steps; ``load[0]`` is the unloaded initial state. Under
        ``stretch_control`` the prescribed stretch of the loaded face (``load[0]`` = 1).
    dt, length_x : float
        Simulation step (s) and specimen length along x (mm).
    u_out : (n_sets, n_steps + 1) ndarray, output
        x-displacement of the loaded face (mm); under ``stretch_control`` the nominal stress P11 (kPa). NaN rows
        for failed sets.
    ok : (n_sets,) bool ndarray, output
    strain : (n_sets, n_steps + 1, 6), tension : (n_sets, n_steps + 1, n_f) ndarray, output if ``full``
    iterations : (n_sets,) int64 ndarray, output
        Total Newton iterations (tangent evaluations) and step halvings of each set, a cost diagnostic.
    stretch_control : bool
        Prescribe the stretch (``load``) instead of the nominal stress (module docstring).
    """
    n_sets = params.shape[0]
    nf = M.shape[0]
    n_t = load.shape[0]
    R = np.empty(6)
    D = np.empty((6, 6))
    d = np.empty(6)
    g = np.empty(6)
    e = np.empty(6)
    e_old = np.empty(6)
    e_prev = np.empty(6)
    e_prev2 = np.empty(6)
    e_prev3 = np.empty(6)
    tau = np.empty(nf)
    tau_old = np.empty(nf)
    h = np.empty(nf)
    ginf = np.empty(nf)
    gamma = np.empty(nf)
    beta = np.empty(nf)
    ea = np.empty(nf)
    eh = np.empty(nf)
    c = np.empty(nf)
    q = np.empty(nf)
    C = np.empty((3, 3))
    Ci = np.empty((3, 3))
    for s in range(n_sets):
        mu = params[s, 0]
        kappa = params[s, 1]
        for k in range(nf):
            ginf[k] = params[s, 2 + 3 * k]
            gamma[k] = params[s, 3 + 3 * k]
            beta[k] = params[s, 4 + 3 * k]
        kelvin_step_constants(gamma, beta, dt, ea, eh, c)
        for k in range(nf):
            tau_old[k] = max(0.0, -ginf[k] * eps0[k])  # eq. (8) at E = 0
            h[k] = 0.0  # eq. (9)
        for i in range(6):
            e[i] = 0.0
            e_prev[i] = 0.0
            e_prev2[i] = 0.0
            e_prev3[i] = 0.0
        u_out[s, 0] = 0.0
        if full:
            for i in range(6):
                strain[s, 0, i] = 0.0
            for k in range(nf):
                tension[s, 0, k] = tau_old[k]
        good = True
        total_iter = 0
        for n in range(1, n_t):
            P = 0.0 if stretch_control else load[n]
            e11 = 0.5 * (load[n] * load[n] - 1.0)
            for k in range(nf):
                q[k] = gamma[k] * (ea[k] * h[k] - eh[k] * tau_old[k])
            if n >= 3:  # quadratic extrapolation of the last three states as the initial guess
                for i in range(6):
                    e[i] = 3.0 * (e_prev[i] - e_prev2[i]) + e_prev3[i]
            elif n == 2:
                for i in range(6):
                    e[i] = 2.0 * e_prev[i] - e_prev2[i]
            if stretch_control:
                e[0] = e11
            tol = RTOL * max(abs(P), 1.0)
            alpha = 1.0
            have_old = False
            fallback = n < 2
            rn_old = 0.0
            pot_old = 0.0
            have_pot_old = False
            slope = 0.0
            n_iter = 0
            n_half = 0
            converged = False
            while True:
                J = _residual(e, P, mu, kappa, phi_m, bulk, M, phi_f, ginf, eps0, c, q, R, tau, D, True, C, Ci)
                if stretch_control and J > 0.0:  # E11 prescribed: drop its equation and unknown
                    tol = RTOL * max(abs(R[0]), 1.0)
                    R[0] = 0.0
                    for i in range(6):
                        D[0, i] = 0.0
                        D[i, 0] = 0.0
                    D[0, 0] = 1.0
                rn2 = 0.0
                rinf = 0.0
                if J > 0.0:
                    for i in range(6):
                        rn2 += R[i] * R[i]
                        rinf = max(rinf, abs(R[i]))
                valid = J > 0.0 and np.isfinite(rn2)
                reject = False
                if have_old:
                    if not valid:
                        reject = True
                    elif rn2 > (1.0 - 1e-4 * alpha) ** 2 * rn_old:
                        # residual did not decrease: accept if the potential decreased enough (Armijo)
                        if not have_pot_old:
                            pot_old = _potential(e_old, P, mu, kappa, phi_m, bulk, M, phi_f, ginf, eps0, c, q, C, Ci)
                            have_pot_old = True
                        pot = _potential(e, P, mu, kappa, phi_m, bulk, M, phi_f, ginf, eps0, c, q, C, Ci)
                        reject = not (pot <= pot_old + 1e-4 * alpha * slope)
                if reject:
                    n_half += 1  # backtrack along the Newton direction
                    total_iter += 1
                    if n_half > MAX_HALVINGS:
                        break
                    alpha *= 0.5
                    for i in range(6):
                        e[i] = e_old[i] + alpha * d[i]
                    continue
                if not valid:
                    if fallback:
                        break
                    fallback = True  # extrapolated guess inadmissible: restart from the last state
                    for i in range(6):
                        e[i] = e_prev[i]
                    if stretch_control:
                        e[0] = e11
                    continue
                if rinf <= tol:
                    converged = True
                    break
                n_iter += 1
                total_iter += 1
                if n_iter > MAX_ITER:
                    break
                for i in range(6):
                    R[i] = -R[i]
                    g[i] = R[i] * (1.0 if i < 3 else 2.0)  # minus the gradient of the potential
                if not _solve6(D, R, d):
                    break
                slope = 0.0
                for i in range(6):
                    slope -= g[i] * d[i]
                if slope >= 0.0:  # not a descent direction (tangent not positive definite): steepest descent
                    slope = 0.0
                    for i in range(6):
                        d[i] = g[i]
                        slope -= g[i] * g[i]
                have_pot_old = False
                dmax = 0.0
                for i in range(6):
                    e_old[i] = e[i]
                    e[i] = e_old[i] + d[i]
                    dmax = max(dmax, abs(d[i]))
                rn_old = rn2
                alpha = 1.0
                n_half = 0
                have_old = True
                if dmax <= STEP_TOL:
                    fibre_tension(e, M, ginf, eps0, c, q, tau)
                    converged = True
                    break
            if not converged:
                good = False
                break
            if stretch_control:  # P11 = lambda S11 at the converged strain (R = S with no load; sets tau too)
                _residual(e, 0.0, mu, kappa, phi_m, bulk, M, phi_f, ginf, eps0, c, q, R, tau, D, False, C, Ci)
                obs = load[n] * R[0]
            else:
                obs = (np.sqrt(1.0 + 2.0 * e[0]) - 1.0) * length_x
            kelvin_history_update(tau, tau_old, h, ea, eh)
            for k in range(nf):
                tau_old[k] = tau[k]
            for i in range(6):
                e_prev3[i] = e_prev2[i]
                e_prev2[i] = e_prev[i]
                e_prev[i] = e[i]
            u_out[s, n] = obs
            if full:
                for i in range(6):
                    strain[s, n, i] = e[i]
                for k in range(nf):
                    tension[s, n, k] = tau[k]
        ok[s] = good
        iterations[s] = total_iter
        if not good:
            for n in range(n_t):
                u_out[s, n] = np.nan
            if full:
                for n in range(n_t):
                    for i in range(6):
                        strain[s, n, i] = np.nan
                    for k in range(nf):
                        tension[s, n, k] = np.nan
