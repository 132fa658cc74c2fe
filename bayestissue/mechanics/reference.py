r"""A straightforward NumPy implementation of the stress and of one uniaxial step, written independently of the
compiled kernels: full 3x3 tensors, ``numpy.linalg`` and :func:`scipy.optimize.root`.

It serves as the independent implementation the kernels are checked against (tests) and as the baseline of the
speed benchmark (``benchmarks/bench_forward.py``). Same equations as docs/model.md:

.. math::

    S = \phi_m\left[\mu J^{-2/3}(I - \tfrac{I_1}{3}C^{-1}) + \kappa J^{-4/3}(I_1 I - C - \tfrac23 I_2 C^{-1})\right]
        + K (J-1) J C^{-1} + \sum_k \phi_k \tau_k v_k \otimes v_k .
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import root

__all__ = [
    "reference_complex_step",
    "reference_laws_simulate",
    "reference_simulate",
    "reference_simulate_experiment",
    "reference_stress",
]


def reference_stress(E, mu, kappa, phi_m, bulk, directions, phi_f, tension_trial):
    """Full 3x3 second Piola-Kirchhoff stress at Green strain ``E`` (3x3, symmetric).

    ``tension_trial(eps) -> tau`` maps the (n_f,) fibre strains to the fibre tensions (eqs. (5)-(6)).
    Returns (S (3, 3), tau (n_f,)).
    """
    E = np.asarray(E)
    E = E.astype(np.result_type(E.dtype, float))  # complex stays complex (complex-step derivatives)
    I = np.eye(3)
    C = I + 2.0 * E
    Ci = np.linalg.inv(C)
    J = np.sqrt(np.linalg.det(C))
    I1 = np.trace(C)
    I2 = 0.5 * (I1**2 - np.trace(C @ C))
    S = phi_m * (mu * J ** (-2 / 3) * (I - I1 / 3 * Ci) + kappa * J ** (-4 / 3) * (I1 * I - C - 2 / 3 * I2 * Ci))
    S = S + bulk * (J - 1.0) * J * Ci
    v = np.asarray(directions, dtype=float)
    eps = np.einsum("ki,ij,kj->k", v, E, v)
    tau = tension_trial(eps)
    S = S + np.einsum("k,ki,kj->ij", np.asarray(phi_f) * tau, v, v)
    return S, tau


_IU = np.triu_indices(3)


def _symmetric(x) -> np.ndarray:
    """The symmetric 3x3 tensor whose upper triangle (row by row: 11, 12, 13, 22, 23, 33) is ``x``."""
    E = np.zeros((3, 3), dtype=np.asarray(x).dtype)
    E[_IU] = x
    return E + np.triu(E, 1).T


def _solve_checked(residual, x0, tol, scale):
    """``scipy.optimize.root`` of ``residual`` from ``x0``, accepted only where the residual is below 1e-8 ``scale``.

    Where a fibre's tension switches on (reloading from slack) Levenberg-Marquardt can stop short of a root from the
    last state and still report success: the residual is checked, and Powell's method from ``x0`` and
    Levenberg-Marquardt from the reference state (0) are tried next. A trial point with det C < 0 gives NaN, which
    fails that attempt. Returns the solution object, or None."""
    for start, method in ((x0, "lm"), (x0, "hybr"), (0.0 * x0, "lm")):
        with np.errstate(invalid="ignore", over="ignore"):
            sol = root(residual, start, method=method, tol=tol)
            if sol.success and np.max(np.abs(residual(sol.x))) <= 1e-8 * scale:
                return sol
    return None


def reference_simulate(params, directions, phi_f, phi_m, bulk, load, dt, length_x, *, tol=1e-10, stretch_control=False):
    """Integrate one uniaxial test step by step with ``scipy.optimize.root`` on the six equations
    :math:`S(E) - P_{11}/\\sqrt{C_{11}}\\, e_1 \\otimes e_1 = 0` (docs/model.md). Slack strains are zero.

    With ``stretch_control`` ``load`` is the prescribed stretch: :math:`E_{11} = (\\lambda^2 - 1)/2` is fixed and the
    five equations :math:`S_{ij} = 0`, :math:`ij \\ne 11`, are solved for the other components.

    Returns the x-displacement (mm) at every step of ``load`` -- under stretch control the nominal stress
    :math:`P_{11} = \\lambda S_{11}` (kPa) -- NaN from the first step that fails.
    """
    p = np.asarray(params, dtype=float)
    nf = len(phi_f)
    mu, kappa = p[0], p[1]
    ginf, gamma, beta = p[2::3][:nf], p[3::3][:nf], p[4::3][:nf]
    eh = np.exp(-0.5 * beta * dt)
    ea = eh**2
    c = 1.0 - gamma * eh
    tau_old = np.zeros(nf)
    h = np.zeros(nf)
    x = np.zeros(6)
    free = slice(1, 6) if stretch_control else slice(0, 6)  # the upper triangle's first entry is E11
    u = np.full(len(load), np.nan)
    u[0] = 0.0
    for n in range(1, len(load)):
        q = gamma * (ea * h - eh * tau_old)
        P = 0.0 if stretch_control else load[n]
        if stretch_control:
            x[0] = 0.5 * (load[n] ** 2 - 1.0)

        def trial(eps, q=q):
            return np.maximum(0.0, (ginf * eps + q) / c)

        def residual(xf, P=P, trial=trial, x=x):
            E = _symmetric(np.r_[x[:1], xf] if stretch_control else xf)
            S, _ = reference_stress(E, mu, kappa, phi_m, bulk, directions, phi_f, trial)
            S[0, 0] -= P / np.sqrt(1.0 + 2.0 * E[0, 0])
            return S[_IU][free]

        sol = _solve_checked(residual, x[free], tol, max(1.0, abs(P)))
        if sol is None:
            break
        x[free] = sol.x
        E = _symmetric(x)
        S, tau = reference_stress(E, mu, kappa, phi_m, bulk, directions, phi_f, trial)
        h = ea * h + eh * (tau - tau_old)
        tau_old = tau
        u[n] = load[n] * S[0, 0] if stretch_control else (np.sqrt(1.0 + 2.0 * E[0, 0]) - 1.0) * length_x
    return u


def reference_simulate_experiment(experiment, params, *, tol=1e-10):
    """:func:`reference_simulate` on an :class:`~bayestissue.mechanics.experiment.Experiment`'s tissue,
    load history, step and specimen length: the displacement (force control) or the nominal stress (stretch
    control) at every simulation step."""
    t = experiment.tissue
    return reference_simulate(
        params,
        t.directions,
        t.phi_fibres,
        t.phi_matrix,
        t.bulk_kpa,
        experiment.prescribed(),
        experiment.dt_s,
        experiment.specimen_mm[0],
        tol=tol,
        stretch_control=experiment.controls == "stretch",
    )


def reference_complex_step(experiment, params, j: int, *, h: float = 1e-30, max_iter: int = 60) -> np.ndarray:
    r"""Complex-step derivative :math:`du_n/dp_j \approx \mathrm{Im}\, u_n(p + i h e_j) / h` at every step
    (Squire & Trapp 1998, doi:10.1137/S003614459631241X): exact to round-off, no subtractive cancellation. Under
    stretch control the observable is the nominal stress :math:`P_{11} = \lambda S_{11}` (kPa) with :math:`E_{11}`
    prescribed and the other five components solved.

    Every step of the test is solved in complex arithmetic with the same equations as :func:`reference_simulate`
    (full 3x3 tensors, :func:`reference_stress`, the Kelvin update of eqs. (5)-(9) including the slack strains
    :math:`\varepsilon_0` and :math:`\tau^0 = \max(0, -g_\infty\varepsilon_0)`); the tension-only switch is taken
    on the real part. Each step: the real equations by :func:`scipy.optimize.root`, then a chord iteration in
    complex arithmetic (Newton with the real Jacobian by central differences at that solution) until the update is
    below 1e-12 (real part, strain units) and below 1e-10 of the imaginary part or 1e-16 h (round-off floors: about
    1e-16, 1e-13 and 1e-18 h). Independent of the compiled kernels; slow (tests only).
    """
    tissue = experiment.tissue
    directions, phi_f = np.asarray(tissue.directions, float), np.asarray(tissue.phi_fibres, float)
    eps0 = np.asarray(tissue.eps0, float)
    load, dt, length_x = experiment.prescribed(), experiment.dt_s, experiment.specimen_mm[0]
    stretch = experiment.controls == "stretch"  # E11 prescribed, five equations, P11 = lambda S11 observed
    free = slice(1, 6) if stretch else slice(0, 6)
    m = free.stop - free.start
    p = np.asarray(params, dtype=complex).copy()
    p[j] += 1j * h
    nf = len(phi_f)
    mu, kappa = p[0], p[1]
    ginf, gamma, beta = p[2::3][:nf], p[3::3][:nf], p[4::3][:nf]
    eh = np.exp(-0.5 * beta * dt)
    ea = eh**2
    c = 1.0 - gamma * eh
    tau_old = np.where((-ginf * eps0).real > 0.0, -ginf * eps0, 0.0)
    hist = np.zeros(nf, dtype=complex)
    x = np.zeros(6, dtype=complex)
    du = np.zeros(len(load))
    for n in range(1, len(load)):
        q = gamma * (ea * hist - eh * tau_old)
        if stretch:
            x[0] = 0.5 * (load[n] ** 2 - 1.0)

        def trial(eps, q=q):
            pre = (ginf * (eps - eps0) + q) / c
            return np.where(pre.real > 0.0, pre, 0.0)

        def residual(xf, P=0.0 if stretch else load[n], trial=trial, x11=x[0]):
            E = _symmetric(np.r_[x11, xf] if stretch else xf)
            S, tau = reference_stress(E, mu, kappa, tissue.phi_matrix, tissue.bulk_kpa, directions, phi_f, trial)
            S[0, 0] -= P / np.sqrt(1.0 + 2.0 * E[0, 0])
            return S[_IU][free], tau, S[0, 0]

        xf = x[free]

        def real_residual(xr, residual=residual):
            return residual(xr)[0].real

        real = _solve_checked(real_residual, xf.real, 1e-12, max(1.0, abs(load[n])))
        if real is None:
            raise RuntimeError(f"complex-step reference: step {n}: no real solution found")
        xf = real.x + 1j * xf.imag
        jac = np.empty((m, m))
        for k in range(m):
            dx = np.zeros(m)
            dx[k] = 1e-7
            jac[:, k] = (residual(xf.real + dx)[0].real - residual(xf.real - dx)[0].real) / 2e-7
        for _ in range(max_iter):
            step = np.linalg.solve(jac, residual(xf)[0])
            xf = xf - step
            tol_imag = max(1e-10 * np.abs(xf.imag).max(), 1e-16 * h)
            if np.abs(step.real).max() < 1e-12 and np.abs(step.imag).max() <= tol_imag:
                break
        else:
            raise RuntimeError(f"complex-step reference: step {n} did not converge")
        x[free] = xf
        _, tau, s11 = residual(xf)
        hist = ea * hist + eh * (tau - tau_old)
        tau_old = tau
        if stretch:
            du[n] = (load[n] * s11).imag / h
        else:
            du[n] = ((np.sqrt(1.0 + 2.0 * x[0]) - 1.0) * length_x).imag / h
    return du


def _derivative(f, x, h=1e-30):
    """:math:`f'(x)` by complex step (exact to round-off)."""
    return f(x + 1j * h).imag / h


def _iso_stress(law, p_law, phi_m, E):
    """Voigt isochoric stress :math:`\\phi_m \\partial W/\\partial E` of ``law`` (complex step of its energy)."""
    out = np.empty(6)
    for j, (a, b) in enumerate(((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))):
        dE = np.zeros((3, 3))
        dE[a, b] = dE[b, a] = 1.0
        out[j] = _derivative(lambda t, dE=dE: phi_m * law.energy_reference(np.eye(3) + 2.0 * (E + t * dE), p_law),
                             0.0) / (1.0 if a == b else 2.0)  # fmt: skip
    return out


def _branches(p, start, n):
    """(r, gamma, beta) of ``n`` Prony branches whose parameters start at ``start``."""
    out, i = [], start
    for b in range(n):
        r = 1.0 if b == 0 else p[i]
        i += 0 if b == 0 else 1
        out.append((r, p[i], p[i + 1]))
        i += 2
    return out


def reference_laws_simulate(experiment, params, *, tol=1e-11) -> np.ndarray:
    """Integrate ``experiment`` step by step, independently of the compiled kernels, for any of its tissue's laws
    and load case: the stresses by complex-step derivatives of each law's NumPy energy
    (:meth:`~bayestissue.mechanics.laws.base.MatrixLaw.energy_reference`), the Prony branches of
    :mod:`~bayestissue.mechanics.laws.prony` written out in NumPy, the free strain components by
    :func:`scipy.optimize.root`. Returns the observed channels ``(n_steps + 1, n_ch)`` on the simulation grid (kPa or
    mm, before a channel's area factor); NaN from a step that fails. Slow: tests only."""
    t = experiment.tissue
    p = np.asarray(params, dtype=float)
    kinds, values = experiment.load_case.prescribe(experiment.prescribed(), experiment.controls)
    chans = experiment.channels
    dt, lengths = experiment.dt_s, np.asarray(experiment.specimen_mm, float)
    n_m = t.matrix.n_parameters
    mb = _branches(p, n_m, t.matrix_branches)
    nb_par = 0 if t.matrix_branches == 0 else 2 + 3 * (t.matrix_branches - 1)
    f0 = n_m + nb_par
    n_fp = t.fibre.n_parameters
    stride = n_fp + (0 if t.fibre_branches == 0 else 2 + 3 * (t.fibre_branches - 1))
    fams = []
    for k in range(t.n_fibres):
        fp = p[f0 + k * stride : f0 + k * stride + n_fp]
        kap = fp[2] if t.fibre.name == "hgo" else 0.0
        v = t.directions[k]
        H = kap * np.eye(3) + (1.0 - 3.0 * kap) * np.outer(v, v)
        fams.append((fp, H, _branches(p, f0 + k * stride + n_fp, t.fibre_branches)))

    def consts(br):
        """Per branch: r, gamma, a = exp(-beta dt), b = exp(-beta dt / 2), c = 1 - gamma b (eq. (5))."""
        r, g, be = (np.array([x[i] for x in br], dtype=float) for i in range(3))
        return r, g, np.exp(-be * dt), np.exp(-0.5 * be * dt), 1.0 - g * np.exp(-0.5 * be * dt)

    mc = consts(mb)
    fc = [consts(br) for _, _, br in fams]
    nbm, nbf = t.matrix_branches, t.fibre_branches
    hm = np.zeros((nbm, 3, 3))
    tm_old = np.zeros((nbm, 3, 3))
    hf = np.zeros((t.n_fibres, max(nbf, 1)))
    tf_old = np.zeros_like(hf)
    for k, (fp, _, _) in enumerate(fams):  # eq. (8): tau^0 = max(0, r sigma(-eps0))
        s0 = _derivative(lambda x, fp=fp: t.fibre.energy_reference(x, fp), -t.eps0[k])
        tf_old[k, :] = np.maximum(0.0, (fc[k][0] if nbf else np.ones(1)) * s0)

    def stress(x, qm, qf):
        E = _symmetric(x)
        C = np.eye(3) + 2.0 * E
        J = np.sqrt(np.linalg.det(C))
        S_iso = _symmetric(_iso_stress(t.matrix, p[:n_m], t.phi_matrix, E)[[0, 3, 4, 1, 5, 2]])
        tm = [(mc[0][b] * S_iso + qm[b]) / mc[4][b] for b in range(nbm)]
        S = sum(tm) if nbm else S_iso.copy()
        S = S + t.bulk_kpa * (J - 1.0) * J * np.linalg.inv(C)
        taus = np.zeros_like(hf)
        for k, (fp, H, _) in enumerate(fams):
            sig = _derivative(lambda y, fp=fp: t.fibre.energy_reference(y, fp), np.sum(H * E) - t.eps0[k])
            if nbf == 0:
                taus[k, 0] = max(0.0, sig)
            else:
                taus[k] = np.maximum(0.0, (fc[k][0] * sig + qf[k]) / fc[k][4])
            S = S + t.phi_fibres[k] * taus[k].sum() * H
        return S, tm, taus

    voigt = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))
    up = [0, 3, 4, 1, 5, 2]  # Voigt -> the upper triangle's row order of _symmetric
    out = np.full((values.shape[0], len(chans)), np.nan)
    out[0] = 0.0
    x = np.zeros(6)  # upper triangle order
    free = [i for i in range(6) if kinds[i] < 2]
    cols = [up[i] for i in free]
    for n in range(1, values.shape[0]):
        qm = [mc[1][b] * (mc[2][b] * hm[b] - mc[3][b] * tm_old[b]) for b in range(nbm)]
        qf = np.zeros_like(hf)
        for k in range(t.n_fibres):
            if nbf:
                qf[k] = fc[k][1] * (fc[k][2] * hf[k] - fc[k][3] * tf_old[k])
        for i in range(6):
            if kinds[i] == 2:
                x[up[i]] = 0.5 * (values[n, i] ** 2 - 1.0)
            elif kinds[i] == 3:
                x[up[i]] = values[n, i]

        def residual(xf, n=n, qm=qm, qf=qf):
            xx = x.copy()
            xx[cols] = xf
            S, _, _ = stress(xx, qm, qf)
            r = np.array([S[a, b] for a, b in voigt])
            for i in range(3):
                if kinds[i] == 1:
                    r[i] -= values[n, i] / np.sqrt(1.0 + 2.0 * xx[up[i]])
            return r[free]

        if free:
            sol = _solve_checked(residual, x[cols], tol, max(1.0, np.abs(values[n]).max()))
            if sol is None:
                break
            x[cols] = sol.x
        S, tm, taus = stress(x, qm, qf)
        for b in range(nbm):
            hm[b] = mc[2][b] * hm[b] + mc[3][b] * (tm[b] - tm_old[b])
            tm_old[b] = tm[b]
        for k in range(t.n_fibres):
            if nbf:
                hf[k] = fc[k][2] * hf[k] + fc[k][3] * (taus[k] - tf_old[k])
            tf_old[k] = taus[k]
        E = _symmetric(x)
        for ch, c in enumerate(chans):
            i = c.axis
            lam = values[n, i] if kinds[i] == 2 else np.sqrt(1.0 + 2.0 * E[i, i])
            if c.kind == 0:
                out[n, ch] = (lam - 1.0) * lengths[i]
            elif c.kind == 1:
                out[n, ch] = lam * S[i, i]
            else:
                out[n, ch] = S[0, 1] + 2.0 * E[0, 1] * S[1, 1]
    return out
