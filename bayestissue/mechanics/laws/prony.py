r"""Viscoelasticity as a Prony series: N parallel relaxing branches around any elastic law (fibre or matrix).

Each branch :math:`i` is the paper's standard linear solid (eqs. (5)-(9)) driven by a share of the elastic law's
stress :math:`\sigma_e` (a fibre's 1-D stress, or the matrix's isochoric stress tensor): with relative modulus
:math:`r_i` (:math:`r_1 = 1`), viscous fraction :math:`\gamma_i` and rate :math:`\beta_i`,

.. math:: \tau_i = r_i \sigma_e + \gamma_i h_i, \qquad h_i(t) = \int_0^t e^{-\beta_i (t - s)}\, \dot\tau_i(s)\, ds,
          \qquad S = \sum_i \tau_i,

a generalised Maxwell (QLV) model: under a held strain each branch relaxes from :math:`r_i\sigma_e/(1 - \gamma_i)` to
:math:`r_i\sigma_e` with the time :math:`t_i = (1 - \gamma_i)/\beta_i`, so the relaxation modulus is the Prony series

.. math:: G(t) = \sum_i r_i\left[1 + \frac{\gamma_i}{1 - \gamma_i} e^{-t/t_i}\right] G_e

(Fung 1993 Sec. 7.6; Simo 1987, doi:10.1016/0045-7825(87)90107-1; Holzapfel 1996,
doi:10.1002/(SICI)1097-0207(19960830)39:16<3903::AID-NME34>3.0.CO;2-C). The time-discrete update of each branch is
the paper's (eqs. (5)-(7)), so that one branch on the linear fibre is the paper's Kelvin fibre to the bit:

.. math:: a = e^{-\beta\Delta t},\ b = e^{-\beta\Delta t/2},\ c = 1 - \gamma b, \qquad
          \tau^{n+1} = \frac{r\,\sigma_e^{n+1} + q}{c},\ q = \gamma(a h^n - b \tau^n), \qquad
          h^{n+1} = a h^n + b (\tau^{n+1} - \tau^n);

a fibre branch carries tension only, :math:`\tau = \max(0, \cdot)` on each branch (eq. (6)); a matrix branch is a
tensor and is not clipped. Two branches of relative moduli 1 and r on the linear fibre are the two-branch fibre of
:mod:`~bayestissue.mechanics.branches` (two half-fraction families on one direction) with
:math:`g_a = 2 g_\infty`, :math:`g_b = 2 r g_\infty`. Zero branches: the elastic law alone (a fibre clipped at zero).

Parameters of the branches, in kernel order after the law's own: :math:`\gamma_1, \beta_1`, then
:math:`r_i, \gamma_i, \beta_i` for :math:`i = 2..N`.
"""

from __future__ import annotations

import numpy as np

from bayestissue._validation import ValidationError
from bayestissue.mechanics._jit import kernel
from bayestissue.mechanics.laws.base import LawParameter

__all__ = [
    "MAX_BRANCHES",
    "branch_constants",
    "branch_offset",
    "branch_parameter_count",
    "branch_order",
    "branch_parameters",
    "check_branches",
]

#: Most branches a law may carry.
MAX_BRANCHES = 5


def check_branches(n, field: str) -> int:
    """``n`` as a number of branches in 0..MAX_BRANCHES (a ValidationError naming ``field`` otherwise)."""
    if isinstance(n, bool) or not isinstance(n, int | np.integer) or not 0 <= int(n) <= MAX_BRANCHES:
        raise ValidationError(field, n, f"a number of Prony branches in 0..{MAX_BRANCHES}")
    return int(n)


@kernel
def branch_parameter_count(n):
    """Parameters of ``n`` branches: 2 for the first, 3 for each further one."""
    return 0 if n == 0 else 2 + 3 * (n - 1)


def branch_parameters(n: int, suffix: str, *, rates=(1e-5, 2.5)) -> tuple[LawParameter, ...]:
    """The specifications of ``n`` branches, named ``gamma<suffix>``, ``beta<suffix>`` for the first and
    ``rel<suffix>_<i>``, ``gamma<suffix>_<i>``, ``beta<suffix>_<i>`` for branch i = 2..n (the paper's boxes for
    gamma and beta; ``rates`` the box of beta)."""
    lo, hi = rates
    out = []
    for i in range(1, n + 1):
        tag = suffix if i == 1 else f"{suffix}_{i}"
        if i > 1:
            out.append(LawParameter(f"rel{tag}", "1", 0.01, 100.0, "log", "relative_modulus", 1.0,
                                    f"modulus of branch {i} relative to branch 1"))  # fmt: skip
        out += [
            LawParameter(f"gamma{tag}", "1", 0.1, 0.95, "linear", "viscous_fraction", 0.75,
                         f"viscous fraction of branch {i}"),
            LawParameter(f"beta{tag}", "1/s", lo, hi, "log", "relaxation_rate", 1.25 if i == 1 else 0.0125,
                         f"relaxation rate of branch {i}"),
        ]  # fmt: skip
    return tuple(out)


def branch_order(n: int, suffix: str) -> tuple[tuple[tuple[tuple[str, ...], ...], bool], ...]:
    """The label group of ``n`` branches (as :meth:`~bayestissue.mechanics.laws.base.Law.label_groups`): ordered by
    decreasing rate, branch 1 the fastest. Not exchangeable by a permutation of the parameters (branch 1 carries no
    relative modulus: exchanging it with branch i rescales the law's moduli by :math:`r_i`), so only the prior's
    restriction applies."""
    if n < 2:
        return ()
    return ((tuple((f"beta{suffix}" if i == 1 else f"beta{suffix}_{i}",) for i in range(1, n + 1)), False),)


@kernel
def branch_offset(i):
    """Position of branch ``i``'s first parameter among its law's branch parameters (``r`` for i >= 1, else gamma)."""
    return 0 if i == 0 else 2 + 3 * (i - 1)


@kernel
def branch_constants(gamma, beta, dt):
    """``(a, b, c)`` of eq. (5): :math:`b = e^{-\\beta\\Delta t/2}`, :math:`a = b^2`, :math:`c = 1 - \\gamma b`."""
    b = np.exp(-0.5 * beta * dt)
    return b * b, b, 1.0 - gamma * b
