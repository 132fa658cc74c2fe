"""The forward kernel as it was before the laws became plug-ins (commit cb83b05), frozen as the speed and bitwise
baseline of benchmarks/bench_forward.py and tests/mechanics/test_viscoelastic.py: the paper's Mooney-Rivlin
matrix and Kelvin fibres in one uniaxial time loop. Not used by the package."""

from __future__ import annotations

import numpy as np
from numba import njit

from bayestissue.mechanics._jit import FASTMATH as _FASTMATH
from bayestissue.mechanics._jit import kernel
from bayestissue.mechanics.kinematics import VOIGT_I, VOIGT_J, right_cauchy_green

__all__ = ["legacy_solve_uniaxial_batch"]

_VI = VOIGT_I
_VJ = VOIGT_J
MAX_ITER = 60
MAX_HALVINGS = 40
RTOL = 1e-10
STEP_TOL = 1e-6


@kernel
def _invariants(C):
    """:math:`I_1 = \\mathrm{tr}\\, C` and :math:`I_2 = \\tfrac12 (I_1^2 - \\mathrm{tr}\\, C^2)` of the 3x3 ``C``."""
    I1 = C[0, 0] + C[1, 1] + C[2, 2]
    trC2 = 0.0
    for a in range(3):
        for b in range(3):
            trC2 += C[a, b] * C[a, b]
    return I1, 0.5 * (I1 * I1 - trC2)


@kernel
def matrix_stress_tangent(e, mu, kappa, phi_m, bulk, S, D, want_tangent, C, Ci):
    """Matrix + penalty stress ``S`` (6,) and, if ``want_tangent``, tangent ``D`` (6, 6) at Voigt strain ``e``.

    ``D[i, j] = dS_i / de_j`` with ``e_j`` the independent Voigt components; ``C`` and ``Ci`` are (3, 3) scratch
    arrays (no allocation in the hot loop). Returns J (<= 0: inadmissible state, ``S`` and ``D`` undefined).
    """
    det = right_cauchy_green(e, C, Ci)
    if not (det > 0.0):
        return -1.0
    J = np.sqrt(det)
    I1, I2 = _invariants(C)
    jm23 = 1.0 / np.cbrt(det)  # J^(-2/3) = det(C)^(-1/3)
    jm43 = jm23 * jm23
    a_nh = phi_m * mu * jm23
    a_mr = phi_m * kappa * jm43
    pv = bulk * (J - 1.0) * J
    for i in range(6):
        a = _VI[i]
        b = _VJ[i]
        dab = 1.0 if a == b else 0.0
        S[i] = (
            a_nh * (dab - I1 / 3.0 * Ci[a, b]) + a_mr * (I1 * dab - C[a, b] - 2.0 / 3.0 * I2 * Ci[a, b]) + pv * Ci[a, b]
        )
    if not want_tangent:
        return J
    # Grouped form of the tangent (same terms as the module docstring, collected by tensor structure):
    # dS/dC = alpha Ci(x)Ci + beta dCi/dC + G(x)Ci + Ci(x)G + a_mr (I(x)I - II),
    # G = -a_nh/3 I - 2 a_mr/3 (I1 I - C).
    alpha = a_nh * I1 / 9.0 + a_mr * 4.0 / 9.0 * I2 + bulk * (2.0 * J - 1.0) * J * 0.5
    beta = -a_nh * I1 / 3.0 - a_mr * 2.0 / 3.0 * I2 + pv
    for i in range(6):
        a = _VI[i]
        b = _VJ[i]
        cab = Ci[a, b]
        gab = -2.0 / 3.0 * a_mr * (-C[a, b]) if a != b else -a_nh / 3.0 - 2.0 / 3.0 * a_mr * (I1 - C[a, b])
        for j in range(i, 6):
            c = _VI[j]
            d = _VJ[j]
            ccd = Ci[c, d]
            gcd = -2.0 / 3.0 * a_mr * (-C[c, d]) if c != d else -a_nh / 3.0 - 2.0 / 3.0 * a_mr * (I1 - C[c, d])
            dci = -0.5 * (Ci[a, c] * Ci[b, d] + Ci[a, d] * Ci[b, c])
            iso = 0.0
            if i < 3 and j < 3:
                iso = 1.0 - (1.0 if i == j else 0.0)  # delta_ab delta_cd - II_abcd on the normal block
            elif i == j:
                iso = -0.5  # II_abab for a != b
            val = 2.0 * (alpha * cab * ccd + beta * dci + gab * ccd + cab * gcd + a_mr * iso)
            D[i, j] = val * (1.0 if j < 3 else 2.0)
            if j != i:
                D[j, i] = val * (1.0 if i < 3 else 2.0)
    return J


@kernel
def matrix_energy(e, mu, kappa, phi_m, bulk, C, Ci):
    """Strain energy W (kPa) of matrix + penalty at Voigt strain ``e`` (NaN if J <= 0); see the module docstring."""
    det = right_cauchy_green(e, C, Ci)
    if not (det > 0.0):
        return np.nan
    J = np.sqrt(det)
    I1, I2 = _invariants(C)
    jm23 = 1.0 / np.cbrt(det)
    return 0.5 * phi_m * (mu * (jm23 * I1 - 3.0) + kappa * (jm23 * jm23 * I2 - 3.0)) + 0.5 * bulk * (J - 1.0) ** 2


@kernel
def kelvin_step_constants(gamma, beta, dt, ea, eh, c):
    """Fill per-fibre ``ea = exp(-beta dt)``, ``eh = exp(-beta dt / 2)``, ``c = 1 - gamma eh`` (eq. (5))."""
    for k in range(gamma.shape[0]):
        eh[k] = np.exp(-0.5 * beta[k] * dt)
        ea[k] = eh[k] * eh[k]
        c[k] = 1.0 - gamma[k] * eh[k]


@kernel
def fibre_stress_tangent(e, M, phi, ginf, eps0, c, q, S, D, tau, want_tangent):
    """Add the fibre stress to ``S`` (6,) and, if ``want_tangent``, its tangent to ``D`` (6, 6).

    ``q_k = gamma_k (ea_k h_k^n - eh_k tau_k^n)`` is the history term of eq. (5), fixed within a step. The trial
    tensions (eq. (6) applied) are written to ``tau`` (n_f,).
    """
    for k in range(M.shape[0]):
        eps = M[k, 0] * e[0] + M[k, 1] * e[1] + M[k, 2] * e[2]
        eps += 2.0 * (M[k, 3] * e[3] + M[k, 4] * e[4] + M[k, 5] * e[5])
        trial = (ginf[k] * (eps - eps0[k]) + q[k]) / c[k]
        if trial > 0.0:
            tau[k] = trial
            for i in range(6):
                S[i] += phi[k] * trial * M[k, i]
            if want_tangent:
                g = phi[k] * ginf[k] / c[k]
                for i in range(6):
                    for j in range(6):
                        D[i, j] += g * M[k, i] * M[k, j] * (1.0 if j < 3 else 2.0)
        else:
            tau[k] = 0.0


@kernel
def fibre_tension(e, M, ginf, eps0, c, q, tau):
    """Eqs. (5)-(6) only: the tensions ``tau`` (n_f,) at Voigt strain ``e`` (no stress, no tangent)."""
    for k in range(M.shape[0]):
        eps = M[k, 0] * e[0] + M[k, 1] * e[1] + M[k, 2] * e[2]
        eps += 2.0 * (M[k, 3] * e[3] + M[k, 4] * e[4] + M[k, 5] * e[5])
        tau[k] = max(0.0, (ginf[k] * (eps - eps0[k]) + q[k]) / c[k])


@kernel
def fibre_energy(e, M, phi, ginf, eps0, c, q):
    r"""Incremental fibre potential :math:`\sum_k \phi_k w_k` whose strain derivative is the tension of eq. (6).

    Within a step :math:`\tilde\tau` is affine in :math:`\varepsilon` with slope :math:`g_\infty / c`, so
    :math:`w = \frac{c}{2 g_\infty} \max(0, \tilde\tau)^2` (or :math:`\max(0, q/c)\,\varepsilon` if
    :math:`g_\infty = 0`) has :math:`dw/d\varepsilon = \max(0, \tilde\tau)`.
    """
    w = 0.0
    for k in range(M.shape[0]):
        eps = M[k, 0] * e[0] + M[k, 1] * e[1] + M[k, 2] * e[2]
        eps += 2.0 * (M[k, 3] * e[3] + M[k, 4] * e[4] + M[k, 5] * e[5])
        trial = (ginf[k] * (eps - eps0[k]) + q[k]) / c[k]
        if ginf[k] > 0.0:
            w += phi[k] * 0.5 * c[k] / ginf[k] * max(0.0, trial) ** 2
        else:
            w += phi[k] * max(0.0, trial) * eps
    return w


@kernel
def kelvin_history_update(tau_new, tau_old, h, ea, eh):
    """Eq. (7): ``h <- ea h + eh (tau_new - tau_old)`` in place."""
    for k in range(h.shape[0]):
        h[k] = ea[k] * h[k] + eh[k] * (tau_new[k] - tau_old[k])


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
def legacy_solve_uniaxial_batch(
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
