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

__all__ = ["reference_stress", "reference_simulate", "reference_simulate_experiment"]


def reference_stress(E, mu, kappa, phi_m, bulk, directions, phi_f, tension_trial):
    """Full 3x3 second Piola-Kirchhoff stress at Green strain ``E`` (3x3, symmetric).

    ``tension_trial(eps) -> tau`` maps the (n_f,) fibre strains to the fibre tensions (eqs. (5)-(6)).
    Returns (S (3, 3), tau (n_f,)).
    """
    E = np.asarray(E, dtype=float)
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


def reference_simulate(params, directions, phi_f, phi_m, bulk, load, dt, length_x, *, tol=1e-10):
    """Integrate one uniaxial test step by step with ``scipy.optimize.root`` on the six equations
    :math:`S(E) - P_{11}/\\sqrt{C_{11}}\\, e_1 \\otimes e_1 = 0` (docs/model.md). Slack strains are zero.

    Returns the x-displacement (mm) at every step of ``load`` (NaN from the first step that fails).
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
    iu = np.triu_indices(3)
    x = np.zeros(6)
    u = np.full(len(load), np.nan)
    u[0] = 0.0
    for n in range(1, len(load)):
        q = gamma * (ea * h - eh * tau_old)

        def trial(eps, q=q):
            return np.maximum(0.0, (ginf * eps + q) / c)

        def residual(x, P=load[n], trial=trial):
            E = np.zeros((3, 3))
            E[iu] = x
            E = E + np.triu(E, 1).T
            S, _ = reference_stress(E, mu, kappa, phi_m, bulk, directions, phi_f, trial)
            S[0, 0] -= P / np.sqrt(1.0 + 2.0 * E[0, 0])
            return S[iu]

        sol = root(residual, x, method="lm", tol=tol)
        if not sol.success:
            break
        x = sol.x
        E = np.zeros((3, 3))
        E[iu] = x
        E = E + np.triu(E, 1).T
        _, tau = reference_stress(E, mu, kappa, phi_m, bulk, directions, phi_f, trial)
        h = ea * h + eh * (tau - tau_old)
        tau_old = tau
        u[n] = (np.sqrt(1.0 + 2.0 * E[0, 0]) - 1.0) * length_x
    return u


def reference_simulate_experiment(experiment, params, *, tol=1e-10):
    """:func:`reference_simulate` on an :class:`~bayestissue.mechanics.experiment.Experiment`'s tissue,
    load history, step and specimen length (displacement at every simulation step)."""
    t = experiment.tissue
    return reference_simulate(
        params,
        t.directions,
        t.phi_fibres,
        t.phi_matrix,
        t.bulk_kpa,
        experiment.nominal_stress_kpa(),
        experiment.dt_s,
        experiment.specimen_mm[0],
        tol=tol,
    )
