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

__all__ = ["reference_stress", "reference_simulate", "reference_simulate_experiment", "reference_complex_step"]


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
