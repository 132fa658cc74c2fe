r"""Viscoelastic, tension-only fibres: the 3-parameter Kelvin (standard linear solid) law of paper eqs. (5)-(9).

Continuous form (docs/model.md): :math:`\tau = \sigma + \gamma h`,
:math:`h(t) = \int_0^t e^{-\beta (t-s)} \dot\tau(s)\, ds`, :math:`\sigma = g_\infty (\varepsilon - \varepsilon_0)`,
with the fibre strain :math:`\varepsilon = E : (v \otimes v)`. Instantaneous modulus :math:`g_\infty / (1-\gamma)`,
equilibrium modulus :math:`g_\infty`, relaxation rate :math:`\beta`.

Time-discrete update over a step :math:`\Delta t` (paper eqs. (5)-(7)):

.. math::

    c = 1 - \gamma e^{-\beta \Delta t / 2}, \qquad
    \tilde\tau^{n+1} = \frac{1}{c}\left[\sigma^{n+1} + \gamma\left(e^{-\beta\Delta t} h^n
        - e^{-\beta\Delta t/2} \tau^n\right)\right], \qquad
    \tau^{n+1} = \max(0, \tilde\tau^{n+1}),

.. math:: h^{n+1} = e^{-\beta\Delta t} h^n + e^{-\beta \Delta t/2} (\tau^{n+1} - \tau^n),

with :math:`\tau^0 = \max(0, \sigma(u^0))`, :math:`h^0 = 0` (eqs. (8)-(9)). The fibre stress is
:math:`S_f = \sum_k \phi_k \tau_k\, v_k \otimes v_k` and its consistent tangent

.. math:: \frac{\partial S_f}{\partial E} = \sum_k \phi_k \frac{g_{\infty,k}}{c_k} [\tilde\tau_k > 0]\,
          M_k \otimes M_k, \qquad M_k = v_k \otimes v_k,

the switch :math:`[\tilde\tau > 0]` being the tension-only rule (eq. (6)); at :math:`\tilde\tau = 0` exactly the
zero (compression) branch is taken.

References: Rohan, Cimrman & Kochova (2012), paper eqs. (5)-(9) (file 000_317b62b3cdfd70d7.txt).
"""

from __future__ import annotations

import numpy as np

from bayestissue.mechanics._jit import kernel

__all__ = [
    "KelvinFibres",
    "fibre_structure",
    "kelvin_step_constants",
    "fibre_stress_tangent",
    "fibre_tension",
    "fibre_energy",
    "kelvin_history_update",
]


def fibre_structure(directions) -> np.ndarray:
    """(n_f, 3) unit directions -> (n_f, 6) Voigt components of the structure tensors ``M_k = v_k (x) v_k``."""
    v = np.asarray(directions, dtype=float)
    return np.stack(
        [
            v[:, 0] ** 2,
            v[:, 1] ** 2,
            v[:, 2] ** 2,
            v[:, 0] * v[:, 1],
            v[:, 0] * v[:, 2],
            v[:, 1] * v[:, 2],
        ],
        axis=1,
    )


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


class KelvinFibres:
    """One Kelvin fibre driven through the compiled update of eqs. (5)-(9) (for checks and plots).

    Parameters
    ----------
    ginf, gamma, beta : float
        Equilibrium modulus (kPa), viscous fraction (1, in [0, 1)) and relaxation rate (1/s).
    eps0 : float
        Slack strain.
    """

    def __init__(self, ginf: float, gamma: float, beta: float, *, eps0: float = 0.0):
        self.ginf, self.gamma, self.beta, self.eps0 = (
            float(ginf),
            float(gamma),
            float(beta),
            float(eps0),
        )

    def strain_for_constant_tension(self, tension_kpa: float, time_s) -> np.ndarray:
        r"""Strain history that holds the discrete tension at ``tension_kpa`` from the first step on.

        At each step of the uniform grid ``time_s`` (``time_s[0] = 0``: unloaded) eq. (5) is inverted for the
        strain (the trial tension is affine in it), the compiled kernel evaluates the tension there and eq. (7)
        updates the history. The closed form it converges to as dt -> 0 is
        :math:`\varepsilon(t) = (\tau_0/g_\infty)(1 - \gamma e^{-\beta t})` (docs/model.md).
        """
        t = np.asarray(time_s, dtype=float)
        dt = t[1] - t[0]
        M = np.array([[1.0, 0.0, 0.0, 0.0, 0.0, 0.0]])
        ginf, eps0 = np.array([self.ginf]), np.array([self.eps0])
        ea, eh, c = np.empty(1), np.empty(1), np.empty(1)
        kelvin_step_constants(np.array([self.gamma]), np.array([self.beta]), dt, ea, eh, c)
        tau_old = np.array([max(0.0, -self.ginf * self.eps0)])
        h, tau, q, e = np.zeros(1), np.empty(1), np.empty(1), np.zeros(6)
        eps = np.zeros_like(t)
        for n in range(1, t.size):
            q[0] = self.gamma * (ea[0] * h[0] - eh[0] * tau_old[0])
            e[0] = eps[n] = self.eps0 + (c[0] * tension_kpa - q[0]) / self.ginf
            fibre_tension(e, M, ginf, eps0, c, q, tau)
            kelvin_history_update(tau, tau_old, h, ea, eh)
            tau_old[:] = tau
        return eps
