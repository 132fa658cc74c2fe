r"""Exact forward sensitivities :math:`\partial u_n / \partial p` by direct differentiation of the discrete steps.

The forward kernel (:mod:`~bayestissue.mechanics.uniaxial`) finds at every step :math:`n` the strain :math:`E^n`
with :math:`R(E^n; p, \tau^{n-1}, h^{n-1}) = 0`, where (docs/model.md, paper eqs. (4)-(9))

.. math::

    R = S_m(E; \mu, \kappa) + \sum_k \phi_k \tau_k(E) M_k - \frac{P_{11}}{\sqrt{C_{11}}} e_1 \otimes e_1, \qquad
    \tau_k = \max(0, \tilde\tau_k), \quad
    \tilde\tau_k = \frac{g_{\infty,k}(\varepsilon_k - \varepsilon_{0,k}) + q_k}{c_k},

:math:`\varepsilon_k = M_k : E`, :math:`q_k = \gamma_k (a_k h_k^{n-1} - b_k \tau_k^{n-1})`, :math:`a_k =
e^{-\beta_k \Delta t}`, :math:`b_k = e^{-\beta_k \Delta t/2}`, :math:`c_k = 1 - \gamma_k b_k` (eq. (5)). Differentiating
the converged equation with respect to a parameter :math:`p` (the load does not depend on it):

.. math::

    D\, \frac{dE^n}{dp} = -\left.\frac{\partial R}{\partial p}\right|_{E^n}, \qquad
    \left.\frac{\partial R}{\partial p}\right|_{E} = \frac{\partial S_m}{\partial p}
      + \sum_k \phi_k [\tilde\tau_k > 0]\, M_k\, \left.\frac{d\tilde\tau_k}{dp}\right|_E,

with :math:`D = \partial R/\partial E` the consistent tangent at the converged state (the Newton matrix, recomputed
once per step and factorised once for all 11 right-hand sides), :math:`\partial S_m/\partial\mu = \phi_m J^{-2/3}(I -
\tfrac{I_1}{3} C^{-1})`, :math:`\partial S_m/\partial\kappa = \phi_m J^{-4/3}(I_1 I - C - \tfrac23 I_2 C^{-1})`, and

.. math::

    \left.\frac{d\tilde\tau_k}{dp}\right|_E = \frac{1}{c_k}\left[\frac{\partial g_{\infty,k}}{\partial p}
      (\varepsilon_k - \varepsilon_{0,k}) + \frac{dq_k}{dp} - \tilde\tau_k \frac{\partial c_k}{\partial p}\right],
    \quad \frac{dq_k}{dp} = \frac{\partial q_k}{\partial p}
      + \gamma_k\left(a_k \frac{dh_k^{n-1}}{dp} - b_k \frac{d\tau_k^{n-1}}{dp}\right).

The Kelvin history is differentiated along: :math:`d\tau_k^n/dp = [\tilde\tau_k > 0]\,(d\tilde\tau_k/dp|_E +
(g_{\infty,k}/c_k) M_k : dE^n/dp)` and :math:`dh^n = da\, h^{n-1} + a\, dh^{n-1} + db\,(\tau^n - \tau^{n-1}) +
b\,(d\tau^n - d\tau^{n-1})` (eq. (7)), starting from :math:`d\tau_k^0/dg_{\infty,k} = -\varepsilon_{0,k}` where
:math:`\tau_k^0 = -g_{\infty,k}\varepsilon_{0,k} > 0` (eq. (8)) and :math:`dh^0 = 0` (eq. (9)). The observable
:math:`u = (\sqrt{C_{11}} - 1) L_x` gives :math:`du/dp = L_x (dE_{11}/dp) / \sqrt{C_{11}}`.

Under stretch control (``stretch_control``, :mod:`~bayestissue.mechanics.uniaxial`) :math:`E_{11}` is prescribed,
so :math:`dE_{11}/dp = 0` and only the five lateral equations are differentiated (row and column 11 of :math:`D`
replaced by the identity, row 11 of the right-hand sides by zero); the observable :math:`P_{11} = \lambda S_{11}`
gives :math:`dP_{11}/dp = \lambda\,(\partial S_{11}/\partial p|_E + \sum_j D_{11,j}\, dE_j/dp)` with the
first row of the full tangent, taken before the replacement.

The tension switch: at :math:`\tilde\tau_k = 0` exactly the kernel takes the compression branch (``trial > 0.0`` is
False), so the derivative taken there is the one-sided derivative of that branch (:math:`d\tau_k = 0`): the same
side the forward solution is on, so the sensitivities are those of the function the kernel computes. Away from the
(measure-zero) switching parameter values the discrete map is smooth and the derivative is exact up to the Newton
tolerance of the stored states (``uniaxial.RTOL``, ``STEP_TOL``).

This pass reads the converged strains and tensions of a forward run (``full=True``): no Newton iteration is
repeated. A failed forward set gives a NaN row.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from bayestissue.mechanics._jit import FASTMATH as _FASTMATH
from bayestissue.mechanics._jit import kernel
from bayestissue.mechanics.fibres import fibre_stress_tangent, kelvin_step_constants
from bayestissue.mechanics.matrix import matrix_modulus_derivatives, matrix_stress_tangent

__all__ = ["sensitivities_uniaxial_batch"]


@kernel
def _factor_solve6(A, B, X):
    """Solve ``A X = B`` for the (6, m) right-hand sides ``B`` (Gaussian elimination with partial pivoting, one
    factorisation for all columns; ``A`` and ``B`` are overwritten). Returns False if ``A`` is singular."""
    n = 6
    m = B.shape[1]
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
                tmp = B[k, j]
                B[k, j] = B[p, j]
                B[p, j] = tmp
        inv = 1.0 / A[k, k]
        for i in range(k + 1, n):
            f = A[i, k] * inv
            if f != 0.0:
                for j in range(k + 1, n):
                    A[i, j] -= f * A[k, j]
                for j in range(m):
                    B[i, j] -= f * B[k, j]
    for c in range(m):
        for i in range(n - 1, -1, -1):
            s = B[i, c]
            for j in range(i + 1, n):
                s -= A[i, j] * X[j, c]
            X[i, c] = s / A[i, i]
    return True


@njit(cache=True, fastmath=_FASTMATH)
def sensitivities_uniaxial_batch(
    params, M, phi_f, phi_m, bulk, eps0, load, dt, length_x, strain, tension, ok, du_out, stretch_control=False
):
    """``du_out[s, n, j] = d u_n / d params[s, j]`` from the converged states of a forward run.

    Parameters
    ----------
    params, M, phi_f, phi_m, bulk, eps0, load, dt, length_x : as for
        :func:`~bayestissue.mechanics.uniaxial.solve_uniaxial_batch`.
    strain : (n_sets, n_steps + 1, 6), tension : (n_sets, n_steps + 1, n_f), ok : (n_sets,)
        The forward run's converged Green strains, fibre tensions and success flags (``full=True``).
    du_out : (n_sets, n_steps + 1, 2 + 3 n_f) ndarray, output
        Sensitivities of the loaded face's x-displacement (mm per parameter unit) -- under ``stretch_control`` of
        the nominal stress P11 (kPa per parameter unit); NaN rows for failed sets (and for a singular tangent,
        which a converged state does not have).
    stretch_control : bool
        The forward run prescribed the stretch (``load``) instead of the nominal stress.
    """
    n_sets = params.shape[0]
    nf = M.shape[0]
    n_t = load.shape[0]
    n_p = 2 + 3 * nf
    S = np.empty(6)
    D = np.empty((6, 6))
    B = np.empty((6, n_p))
    X = np.empty((6, n_p))
    D0 = np.empty(6)  # stretch control: row 11 of the tangent and of the right-hand sides
    B0 = np.empty(n_p)
    C = np.empty((3, 3))
    Ci = np.empty((3, 3))
    dmu = np.empty(6)
    dkappa = np.empty(6)
    e = np.empty(6)
    tau = np.empty(nf)
    ginf = np.empty(nf)
    gamma = np.empty(nf)
    beta = np.empty(nf)
    ea = np.empty(nf)
    eh = np.empty(nf)
    c = np.empty(nf)
    q = np.empty(nf)
    h = np.empty(nf)
    dea = np.empty(nf)
    deh = np.empty(nf)
    dtr = np.empty((nf, n_p))
    dtau_old = np.empty((nf, n_p))
    dtau = np.empty((nf, n_p))
    dh = np.empty((nf, n_p))
    for s in range(n_sets):
        if not ok[s]:
            for n in range(n_t):
                for j in range(n_p):
                    du_out[s, n, j] = np.nan
            continue
        mu = params[s, 0]
        kappa = params[s, 1]
        for k in range(nf):
            ginf[k] = params[s, 2 + 3 * k]
            gamma[k] = params[s, 3 + 3 * k]
            beta[k] = params[s, 4 + 3 * k]
        kelvin_step_constants(gamma, beta, dt, ea, eh, c)
        for k in range(nf):
            dea[k] = -dt * ea[k]  # d exp(-beta dt) / d beta
            deh[k] = -0.5 * dt * eh[k]  # d exp(-beta dt / 2) / d beta
            h[k] = 0.0
            for j in range(n_p):
                dh[k, j] = 0.0
                dtau_old[k, j] = 0.0
            if -ginf[k] * eps0[k] > 0.0:  # eq. (8): tau^0 = max(0, -ginf eps0)
                dtau_old[k, 2 + 3 * k] = -eps0[k]
        for j in range(n_p):
            du_out[s, 0, j] = 0.0
        good = True
        for n in range(1, n_t):
            for i in range(6):
                e[i] = strain[s, n, i]
            # the Newton matrix at the converged state (the same kernels as the forward solve)
            for i in range(6):
                S[i] = 0.0
            J = matrix_stress_tangent(e, mu, kappa, phi_m, bulk, S, D, True, C, Ci)
            if not (J > 0.0):
                good = False
                break
            matrix_modulus_derivatives(J, phi_m, C, Ci, dmu, dkappa)
            for k in range(nf):
                tau_old = tension[s, n - 1, k]
                q[k] = gamma[k] * (ea[k] * h[k] - eh[k] * tau_old)
            fibre_stress_tangent(e, M, phi_f, ginf, eps0, c, q, S, D, tau, True)
            c11 = 1.0 + 2.0 * e[0]
            if not stretch_control:
                D[0, 0] += load[n] * c11**-1.5
            # right-hand sides: the explicit parameter derivatives of R at fixed E
            for i in range(6):
                for j in range(n_p):
                    B[i, j] = 0.0
                B[i, 0] = -dmu[i]
                B[i, 1] = -dkappa[i]
            # dtr: d(trial tension)/dp at fixed E, where the fibre is in tension; there tau (written by
            # fibre_stress_tangent) is the trial tension itself, elsewhere dtr is not used
            for k in range(nf):
                tau_old = tension[s, n - 1, k]
                ig, iy, ib = 2 + 3 * k, 3 + 3 * k, 4 + 3 * k
                for j in range(n_p):  # dq/dp through the history
                    dtr[k, j] = gamma[k] * (ea[k] * dh[k, j] - eh[k] * dtau_old[k, j])
                dtr[k, iy] += ea[k] * h[k] - eh[k] * tau_old  # explicit dq/dgamma
                dtr[k, ib] += gamma[k] * (dea[k] * h[k] - deh[k] * tau_old)  # explicit dq/dbeta
                eps = M[k, 0] * e[0] + M[k, 1] * e[1] + M[k, 2] * e[2]
                eps += 2.0 * (M[k, 3] * e[3] + M[k, 4] * e[4] + M[k, 5] * e[5])
                dtr[k, ig] += eps - eps0[k]
                dtr[k, iy] -= tau[k] * (-eh[k])  # dc/dgamma = -eh
                dtr[k, ib] -= tau[k] * (-gamma[k] * deh[k])  # dc/dbeta = -gamma deh
                for j in range(n_p):
                    dtr[k, j] /= c[k]
                if tau[k] > 0.0:
                    for i in range(6):
                        w = phi_f[k] * M[k, i]
                        for j in range(n_p):
                            B[i, j] -= w * dtr[k, j]
            if stretch_control:  # E11 prescribed: keep row 11 for dS11, solve the five lateral equations
                for i in range(6):
                    D0[i] = D[0, i]
                    D[0, i] = 0.0
                    D[i, 0] = 0.0
                for j in range(n_p):
                    B0[j] = B[0, j]
                    B[0, j] = 0.0
                D[0, 0] = 1.0
            if not _factor_solve6(D, B, X):
                good = False
                break
            for k in range(nf):
                tau_old = tension[s, n - 1, k]
                tau_new = tension[s, n, k]
                active = tau[k] > 0.0  # tau holds the tensions of eq. (6) at E^n
                g = ginf[k] / c[k]
                for j in range(n_p):
                    if active:
                        deps = M[k, 0] * X[0, j] + M[k, 1] * X[1, j] + M[k, 2] * X[2, j]
                        deps += 2.0 * (M[k, 3] * X[3, j] + M[k, 4] * X[4, j] + M[k, 5] * X[5, j])
                        dtau[k, j] = dtr[k, j] + g * deps
                    else:
                        dtau[k, j] = 0.0
                for j in range(n_p):
                    dh[k, j] = ea[k] * dh[k, j] + eh[k] * (dtau[k, j] - dtau_old[k, j])
                dh[k, 4 + 3 * k] += dea[k] * h[k] + deh[k] * (tau_new - tau_old)
                h[k] = ea[k] * h[k] + eh[k] * (tau_new - tau_old)
                for j in range(n_p):
                    dtau_old[k, j] = dtau[k, j]
            if stretch_control:  # dP11 = lambda (dS11/dp at fixed E + D[0, :] dE/dp); B holds -dR/dp
                for j in range(n_p):
                    ds = -B0[j]
                    for i in range(6):
                        ds += D0[i] * X[i, j]
                    du_out[s, n, j] = load[n] * ds
            else:
                f = length_x / np.sqrt(c11)
                for j in range(n_p):
                    du_out[s, n, j] = f * X[0, j]
        if not good:
            for n in range(n_t):
                for j in range(n_p):
                    du_out[s, n, j] = np.nan
