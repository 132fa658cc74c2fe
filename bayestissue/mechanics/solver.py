r"""The one time loop: a homogeneous load case of the composite, batched over parameter sets, with optional exact
sensitivities.

A block under a homogeneous load case (:mod:`~bayestissue.mechanics.loadcases`) deforms homogeneously, so one element
with one quadrature point is exact (docs/model.md). With the rigid rotation fixed, the unknowns are the six Voigt
components of the Green strain :math:`E`; the load case says, per component, what holds at every step (``kinds``):

* ``0``: a stress-free component, :math:`S_i(E) = 0` (the lateral faces and the shears of a uniaxial test);
* ``1``: a dead load :math:`P_i` on face i (a normal component): :math:`S_{ii} = P_i/\sqrt{C_{ii}}`, i.e.
  :math:`P_i = \lambda_i S_{ii}` with the traction :math:`S_{ii} F e_i` along the face's stretched normal;
* ``2``: a prescribed stretch :math:`\lambda_i` of face i: :math:`E_{ii} = (\lambda_i^2 - 1)/2`;
* ``3``: a prescribed strain component (simple shear prescribes them all).

The free components are found by Newton's method with the consistent tangent of
:mod:`~bayestissue.mechanics.composite` (a dead load adds :math:`P_i C_{ii}^{-3/2}` to :math:`\partial R_i/\partial
E_{ii}`; a prescribed component's row and column are the identity), safeguarded by backtracking: a step is accepted
when :math:`\|R\|_2` decreases or, failing that, when the incremental potential
:math:`\Pi = W(E) - \sum_{\text{loads}} P_i(\sqrt{C_{ii}} - 1)` (whose gradient is :math:`R`) satisfies Armijo's
condition; otherwise the step is halved, also whenever :math:`J \le 0`. The potential criterion matters when stiff
fibres meet a soft matrix: there the residual norm is a poor merit function.

What is observed (``channels``: rows of (kind, component)): ``0`` the displacement of face i,
:math:`(\sqrt{C_{ii}} - 1) L_i`; ``1`` the nominal stress :math:`P_i = \lambda_i S_{ii}` (:math:`\lambda_i` the
prescribed stretch where there is one); ``2`` the shear stress of simple shear,
:math:`P_{12} = (F S)_{12} = S_{12} + \gamma S_{22}` with :math:`\gamma = 2E_{12}` (:math:`F = I + \gamma e_1
\otimes e_2`).

After each converged step the Prony histories are updated (paper eq. (7)); with ``dout`` the step's exact
parameter derivatives follow in the same loop (:mod:`~bayestissue.mechanics.sensitivity`). A parameter set whose
solve fails (no convergence in :data:`MAX_ITER` iterations, :math:`J \le 0`, a singular tangent, NaN) is flagged:
its rows of the output are NaN and ``ok`` is False; the other rows are unaffected.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from bayestissue.mechanics._jit import FASTMATH as _FASTMATH
from bayestissue.mechanics._jit import kernel
from bayestissue.mechanics.composite import (
    composite_energy,
    composite_stress_tangent,
    fibre_offset,
    scratch,
    structure_and_strain,
    workspace,
)
from bayestissue.mechanics.laws.dispatch import fibre_stress
from bayestissue.mechanics.laws.prony import branch_constants, branch_offset
from bayestissue.mechanics.sensitivity import SensitivityState, sensitivity_step, start_sensitivities

__all__ = ["MAX_HALVINGS", "MAX_ITER", "RTOL", "STEP_TOL", "solve_batch"]

#: Newton iterations allowed per time step before the set is declared failed.
MAX_ITER = 60
#: Step halvings allowed per Newton iteration (backtracking line search).
MAX_HALVINGS = 40
#: Residual tolerance relative to the loads: ||R||_inf <= RTOL * max(|P_i|, |S_ii| of the prescribed components, 1 kPa).
RTOL = 1e-10
#: A full Newton step smaller than this (max-norm of the strain increment) ends the iteration: with quadratic
#: convergence the remaining strain error is ~ k STEP_TOL^2 ~ 1e-11 (k ~ 10 here), i.e. < 1e-10 mm of displacement
#: against data noise of ~0.02 mm; tests compare whole curves with an independent solver to 1e-8 mm.
STEP_TOL = 1e-6


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


@kernel
def _fix(kinds, R, D):
    """Drop the prescribed components' equations: zero residual, identity row and column. Returns the largest
    |R_i| among them before zeroing (their stress scale, for the tolerance)."""
    big = 0.0
    for i in range(6):
        if kinds[i] >= 2:
            big = max(big, abs(R[i]))
            R[i] = 0.0
            for j in range(6):
                D[i, j] = 0.0
                D[j, i] = 0.0
            D[i, i] = 1.0
    return big


@kernel
def _set_targets(kinds, targets_all, n, e):
    """The prescribed components of step ``n`` into ``e``."""
    for i in range(6):
        if kinds[i] >= 2:
            e[i] = targets_all[n, i]


@njit(cache=True, fastmath=_FASTMATH, inline="always")
def _observe(channels, kinds, values, n, e, S, lengths, out):
    """The observed channels at the converged step (module docstring). Inlined in the time loop: a call would cost
    more than the work (its arguments are about 50 machine words, written once per step)."""
    for c in range(channels.shape[0]):
        kind = channels[c, 0]
        i = channels[c, 1]
        if kind == 0:
            out[c] = (np.sqrt(1.0 + 2.0 * e[i]) - 1.0) * lengths[i]
        elif kind == 1:
            lam = values[n, i] if kinds[i] == 2 else np.sqrt(1.0 + 2.0 * e[i])
            out[c] = lam * S[i]
        else:
            out[c] = S[3] + 2.0 * e[3] * S[1]


@kernel
def _tensions(e, p, lay, M, eps0, fs, H):
    """The fibre branches' tensions at ``e`` into ``fs[2]`` (the history needs them; the stress is not recomputed).
    ``fs`` as for the composite (its branches' constants, history terms, tensions)."""
    cf, qf, tau_f = fs[0], fs[1], fs[2]
    nb_f = lay[7]
    for k in range(lay[8]):
        off = fibre_offset(lay, k)
        eps = structure_and_strain(lay, p, off, M[k], e, H)
        sig = p[off] * (eps - eps0[k]) if lay[4] == 0 else fibre_stress(lay[4], lay[6], eps - eps0[k], p, off)[0]
        if nb_f == 0:
            tau_f[k, 0] = max(0.0, sig)
        for b in range(nb_f):
            r = 1.0 if b == 0 else p[off + lay[5] + branch_offset(b)]
            tau_f[k, b] = max(0.0, (r * sig + qf[k, b]) / cf[k, b])


@njit(cache=True, fastmath=_FASTMATH)
def solve_batch(params, lay, M, phi_f, phi_m, bulk, eps0, kinds, values, dt, lengths, channels, out, ok, strain,
                tension, full, iterations, dout):  # fmt: skip
    """Integrate the load case for every parameter set (row of ``params``).

    Parameters
    ----------
    params : (n_sets, n_p) ndarray, in the tissue's order (:attr:`~bayestissue.mechanics.tissue.TissueConfig.layout`,
        ``lay``).
    M : (n_f, 6) Voigt structure tensors of the fibre directions; ``phi_f``, ``eps0`` (n_f,) fractions and slack
        strains; ``phi_m``, ``bulk`` the matrix fraction and bulk modulus (kPa).
    kinds : (6,) int64, ``values`` (n_steps + 1, 6): the load case (module docstring); step 0 is the unloaded state.
    dt : simulation step (s); ``lengths`` (3,) the specimen's edges (mm).
    channels : (n_ch, 2) int64, the observed quantities (module docstring).
    out : (n_sets, n_steps + 1, n_ch), output; NaN rows for failed sets. ``ok`` (n_sets,) bool, output.
    strain : (n_sets, n_steps + 1, 6), tension : (n_sets, n_steps + 1, n_f), output if ``full``: the Green strain
        and each family's tension (the sum over its branches).
    iterations : (n_sets,) int64, output: Newton iterations and step halvings of each set (cost diagnostic).
    dout : None, or (n_sets, n_steps + 1, n_ch, n_p) to be filled with the channels' derivatives by every parameter.
        numba compiles the two cases apart (its branch pruning on a None argument), so a run without sensitivities
        carries none of their code.
    """
    n_sets = params.shape[0]
    n_p = params.shape[1]
    nf = M.shape[0]
    nb_m = lay[3]
    nb_f = lay[7]
    nbf1 = max(nb_f, 1)
    n_t = values.shape[0]
    n_ch = channels.shape[0]
    R = np.empty(6)
    D = np.empty((6, 6))
    d = np.empty(6)
    g = np.empty(6)
    e = np.empty(6)
    e_old = np.empty(6)
    e_prev = np.empty(6)
    e_prev2 = np.empty(6)
    e_prev3 = np.empty(6)
    obs = np.empty(n_ch)
    ws = workspace()  # the composite's scratch, packed (composite.workspace says why)
    scr = scratch(ws)
    am = np.empty(max(nb_m, 1))
    bm = np.empty(max(nb_m, 1))
    cm = np.ones(max(nb_m, 1))
    gm = np.empty(max(nb_m, 1))
    # the composite's matrix-branch state: constants (cm repeated over the six components), history terms, stresses
    ms = np.ones((3, max(nb_m, 1), 6))
    qm, tau_m = ms[1], ms[2]
    qm[:, :] = 0.0
    tau_m[:, :] = 0.0
    hm = np.zeros((max(nb_m, 1), 6))
    tau_m_old = np.zeros((max(nb_m, 1), 6))
    af = np.empty((nf, nbf1))
    bf = np.empty((nf, nbf1))
    gf = np.zeros((nf, nbf1))
    fs = np.zeros((3, nf, nbf1))  # the composite's fibre-branch state: constants, history terms, tensions
    cf, qf, tau_f = fs[0], fs[1], fs[2]
    cf[:, :] = 1.0
    hf = np.zeros((nf, nbf1))
    tau_f_old = np.zeros((nf, nbf1))
    sens = SensitivityState(n_p, nf, nbf1, max(nb_m, 1), n_ch, dout is not None)
    # flat views of the fibre branches' arrays (C order: family-major), for the per-step updates
    n_fb = nf * nb_f
    af1, bf1, gf1 = af.reshape(nf * nbf1), bf.reshape(nf * nbf1), gf.reshape(nf * nbf1)
    qf1, hf1 = qf.reshape(nf * nbf1), hf.reshape(nf * nbf1)
    tau_f1, tau_f_old1 = tau_f.reshape(nf * nbf1), tau_f_old.reshape(nf * nbf1)
    # what every set shares, once: each step's load scale and prescribed strains, what the channels need
    pmax = np.ones(n_t)
    targets_all = np.zeros((n_t, 6))
    prescribed = False
    for n in range(1, n_t):
        for i in range(6):
            if kinds[i] == 1:
                pmax[n] = max(pmax[n], abs(values[n, i]))
            elif kinds[i] == 2:
                targets_all[n, i] = 0.5 * (values[n, i] * values[n, i] - 1.0)
                prescribed = True
            elif kinds[i] == 3:
                targets_all[n, i] = values[n, i]
                prescribed = True
    stress_needed = nb_m > 0 or dout is not None or _needs_stress(channels)
    loaded = np.array([i for i in range(3) if kinds[i] == 1], dtype=np.int64)
    n_loaded = loaded.size
    for s in range(n_sets):
        p = params[s]
        ob = lay[1]
        for b in range(nb_m):  # matrix branch constants (eq. (5))
            o = ob + branch_offset(b) + (1 if b > 0 else 0)
            gm[b] = p[o]
            am[b], bm[b], cm[b] = branch_constants(p[o], p[o + 1], dt)
            for i in range(6):
                ms[0, b, i] = cm[b]
            for i in range(6):
                hm[b, i] = 0.0
                tau_m_old[b, i] = 0.0
        for k in range(nf):
            off = fibre_offset(lay, k)
            sig0, _ = fibre_stress(lay[4], lay[6], 0.0 - eps0[k], p, off)
            if nb_f == 0:
                tau_f_old[k, 0] = max(0.0, sig0)
            for b in range(nb_f):
                o = off + lay[5] + branch_offset(b) + (1 if b > 0 else 0)
                r = 1.0 if b == 0 else p[off + lay[5] + branch_offset(b)]
                gf[k, b] = p[o]
                af[k, b], bf[k, b], cf[k, b] = branch_constants(p[o], p[o + 1], dt)
                tau_f_old[k, b] = max(0.0, r * sig0)  # eq. (8) at E = 0
                hf[k, b] = 0.0  # eq. (9)
        for i in range(6):
            e[i] = 0.0
            e_prev[i] = 0.0
            e_prev2[i] = 0.0
            e_prev3[i] = 0.0
        for c in range(n_ch):
            out[s, 0, c] = 0.0
        if full:
            for i in range(6):
                strain[s, 0, i] = 0.0
            for k in range(nf):
                tot = 0.0
                for b in range(nbf1):
                    tot += tau_f_old[k, b]
                tension[s, 0, k] = tot
        if dout is not None:
            start_sensitivities(sens, p, lay, eps0, tau_f_old)
            for c in range(n_ch):
                for j in range(n_p):
                    dout[s, 0, c, j] = 0.0
        good = True
        total_iter = 0
        for n in range(1, n_t):
            Pmax = pmax[n]
            for b in range(nb_m):
                for i in range(6):
                    qm[b, i] = gm[b] * (am[b] * hm[b, i] - bm[b] * tau_m_old[b, i])
            for j in range(n_fb):  # every fibre branch, (family, branch) flattened: no inner loop per family
                qf1[j] = gf1[j] * (af1[j] * hf1[j] - bf1[j] * tau_f_old1[j])
            if n >= 3:  # quadratic extrapolation of the last three states as the initial guess
                for i in range(6):
                    e[i] = 3.0 * (e_prev[i] - e_prev2[i]) + e_prev3[i]
            elif n == 2:
                for i in range(6):
                    e[i] = 2.0 * e_prev[i] - e_prev2[i]
            if prescribed:
                _set_targets(kinds, targets_all, n, e)
            tol = RTOL * Pmax
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
            fresh = False  # the tensions in tau_f are those of the current e
            while True:
                J = composite_stress_tangent(e, p, lay, M, phi_f, phi_m, bulk, eps0, ms, fs, R, D, True, ws)
                fresh = True
                if J > 0.0:
                    for li in range(n_loaded):  # the dead loads (written here: a call costs more than the work)
                        i = loaded[li]
                        cii = 1.0 + 2.0 * e[i]
                        R[i] -= values[n, i] / np.sqrt(cii)
                        D[i, i] += values[n, i] * cii**-1.5
                    if prescribed:
                        tol = RTOL * max(Pmax, _fix(kinds, R, D))
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
                            pot_old = _potential(e_old, p, lay, M, phi_f, phi_m, bulk, eps0, ms, fs, kinds,
                                                 values, n, ws)  # fmt: skip
                            have_pot_old = True
                        pot = _potential(e, p, lay, M, phi_f, phi_m, bulk, eps0, ms, fs, kinds, values, n, ws)
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
                    _set_targets(kinds, targets_all, n, e)
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
                    fresh = False
                    converged = True
                    break
            if not converged:
                good = False
                break
            if not fresh or stress_needed:
                if stress_needed:  # the stress (and every tension) at e
                    composite_stress_tangent(e, p, lay, M, phi_f, phi_m, bulk, eps0, ms, fs, R, D,
                                             dout is not None, ws)  # fmt: skip
                else:
                    _tensions(e, p, lay, M, eps0, fs, scr[6])
            _observe(channels, kinds, values, n, e, R, lengths, obs)
            if dout is not None:
                if not sensitivity_step(sens, e, p, lay, M, phi_f, phi_m, bulk, eps0, kinds, values, n, dt, lengths,
                                        channels,
                                        am, bm, cm, gm, af, bf, cf, gf, hm, hf, tau_m_old, tau_f_old, tau_m, tau_f,
                                        R, D, scr):  # fmt: skip
                    good = False
                    break
                for c in range(n_ch):
                    for j in range(n_p):
                        dout[s, n, c, j] = sens[8][c, j]
            for b in range(nb_m):  # eq. (7), the matrix branches
                for i in range(6):
                    hm[b, i] = am[b] * hm[b, i] + bm[b] * (tau_m[b, i] - tau_m_old[b, i])
                    tau_m_old[b, i] = tau_m[b, i]
            for j in range(n_fb):  # eq. (7), the fibre branches
                hf1[j] = af1[j] * hf1[j] + bf1[j] * (tau_f1[j] - tau_f_old1[j])
            for j in range(nf * nbf1):
                tau_f_old1[j] = tau_f1[j]
            for i in range(6):
                e_prev3[i] = e_prev2[i]
                e_prev2[i] = e_prev[i]
                e_prev[i] = e[i]
            for c in range(n_ch):
                out[s, n, c] = obs[c]
            if full:
                for i in range(6):
                    strain[s, n, i] = e[i]
                for k in range(nf):
                    tot = 0.0
                    for b in range(nbf1):
                        tot += tau_f[k, b]
                    tension[s, n, k] = tot
        ok[s] = good
        iterations[s] = total_iter
        if not good:
            for n in range(n_t):
                for c in range(n_ch):
                    out[s, n, c] = np.nan
                    if dout is not None:
                        for j in range(n_p):
                            dout[s, n, c, j] = np.nan
            if full:
                for n in range(n_t):
                    for i in range(6):
                        strain[s, n, i] = np.nan
                    for k in range(nf):
                        tension[s, n, k] = np.nan


@kernel
def _needs_stress(channels):
    for c in range(channels.shape[0]):
        if channels[c, 0] != 0:
            return True
    return False


@kernel
def _potential(e, p, lay, M, phi_f, phi_m, bulk, eps0, ms, fs, kinds, values, n, ws):
    """The incremental potential of the step: the composite's minus the work of the dead loads; its gradient is R."""
    w = composite_energy(e, p, lay, M, phi_f, phi_m, bulk, eps0, ms, fs, ws)
    for i in range(3):
        if kinds[i] == 1:
            w -= values[n, i] * (np.sqrt(1.0 + 2.0 * e[i]) - 1.0)
    return w
