r"""A richer fibre law: two Kelvin branches per fibre family (a two-term generalised Maxwell / Prony fibre).

The paper's fibre (eqs. (5)-(9), :mod:`bayestissue.mechanics.fibres`) has one relaxation time. Its first guess at why
T1 and T2 disagree was that "the model of the fibres should be enhanced": a law with one time constant cannot relax
fast during a ramp of minutes and slowly during a creep of twenty minutes at once. Here a family k may carry a
*second branch*: two fibre populations on the same direction :math:`v_k`, each with half the family's volume fraction
and its own Kelvin law, each tension-only on its own (eq. (6) per branch):

.. math:: S_{f,k} = \tfrac{\phi_k}{2} (\tau_{k,a} + \tau_{k,b})\, v_k \otimes v_k,

each :math:`\tau_{k,i}` following eqs. (5)-(9) with :math:`(g_{\infty,i}, \gamma_i, \beta_i)`. The halves are no
extra parameter: only :math:`\phi g_\infty` enters the stress, so the split is absorbed in the moduli. Under a fibre
strain :math:`\varepsilon > 0` held from :math:`t = 0` (continuous limit of the update) each branch relaxes as

.. math:: \tau_i(t) = g_{\infty,i}\, \varepsilon \left[1 + \frac{\gamma_i}{1 - \gamma_i}
          e^{-t / t_i}\right], \qquad t_i = \frac{1 - \gamma_i}{\beta_i},

(from :math:`\tau = \sigma + \gamma h`, :math:`\dot h = -\beta h + \dot\tau`, :math:`\tau(0^+) = \sigma / (1 -
\gamma)`), so the family's relaxation modulus is the two-term Prony series of a generalised Maxwell model (Fung,
*Biomechanics*, 2nd ed. 1993, Sec. 7.6; Holzapfel, *Nonlinear Solid Mechanics* 2000, Sec. 6.10): an equilibrium
modulus :math:`\tfrac{\phi}{2}(g_a + g_b)` and two relaxation times. One set of parameters can then give a fast
branch (:math:`t_b` of seconds, relaxed within a ramp of minutes: the ramp sees a nearly elastic, relaxed fibre) and a
slow one (:math:`t_a` of tens of minutes: the creep sees it flow). With equal branches the family is the paper's
fibre exactly; with :math:`g_{\infty,b} = 0` it is the paper's fibre with half the fraction.

Implementation: the second branch is one more fibre family of the compiled kernel with the same direction (the
consistent tangent, the exact sensitivities and the failure contract carry over unchanged). Families keep their
numbers; the second branch of the j-th listed family is family :math:`n_f + j`, so its parameters are
``ginf<n_f + j>, gamma<n_f + j>, beta<n_f + j>``.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from bayestissue._validation import ValidationError
from bayestissue.mechanics.tissue import TissueConfig

__all__ = ["with_second_branch", "branch_relaxation", "second_branch_ties"]


def with_second_branch(tissue: TissueConfig, families) -> TissueConfig:
    """``tissue`` with a second Kelvin branch on each listed family (1-based, as in ``ginf<k>``).

    Each listed family keeps half its volume fraction; the other half goes to a new family with the same direction
    and slack strain, appended in the order listed (module docstring).

    Raises
    ------
    ValidationError
        If a family number is not in 1..n_f, is listed twice, or the tissue already has second branches.
    """
    given = list(families)
    nf = tissue.n_fibres
    if not all(isinstance(k, (int, float, np.integer, np.floating)) and float(k).is_integer() for k in given):
        raise ValidationError("tissue.second_branch", given, f"fibre family numbers in 1..{nf}")
    fams = [int(k) for k in given]
    if tissue.second_branch:
        raise ValidationError("tissue.second_branch", list(tissue.second_branch), "second branches added once")
    for k in fams:
        if not 1 <= k <= nf:
            raise ValidationError("tissue.second_branch", fams, f"fibre family numbers in 1..{nf}")
    if len(set(fams)) != len(fams):
        raise ValidationError("tissue.second_branch", fams, "each family once")
    if not fams:
        return tissue
    idx = np.array(fams) - 1
    phi = np.array(tissue.phi_fibres, dtype=float)
    phi[idx] *= 0.5
    eps0 = np.zeros(nf) if tissue.eps0 is None else np.array(tissue.eps0, dtype=float)
    return replace(
        tissue,
        directions=np.vstack([tissue.directions, tissue.directions[idx]]),
        phi_fibres=np.concatenate([phi, phi[idx]]),
        eps0=np.concatenate([eps0, eps0[idx]]),
        second_branch=tuple(fams),
    )


def second_branch_ties(tied, tissue: TissueConfig) -> tuple[tuple[str, str], ...]:
    """Ties between fibre laws carried over to the second branches of ``tissue`` (made by :func:`with_second_branch`):
    if ``ginf3`` takes ``ginf2`` and both families have second branches, the second branch of 3 takes the second
    branch of 2. ``tied`` are pairs (name, target); families are found from the tissue's parameter specifications,
    not from the names."""
    n_base = tissue.n_fibres - len(tissue.second_branch)
    branch = {k: n_base + 1 + j for j, k in enumerate(tissue.second_branch)}
    where = {n: (k, i) for k in range(1, tissue.n_fibres + 1) for i, n in enumerate(tissue.family_parameters(k))}
    out = list(tied)
    for name, target in tied:
        if name not in where or target not in where:
            continue
        (k, i), (t, j) = where[name], where[target]
        if k in branch and t in branch:
            out.append((tissue.family_parameters(branch[k])[i], tissue.family_parameters(branch[t])[j]))
    return tuple(out)


def branch_relaxation(time_s, strain: float, ginf, gamma, beta) -> np.ndarray:
    r"""Continuous-limit tension :math:`\sum_i \tau_i(t)` of Kelvin branches under a fibre strain held from t = 0
    (module docstring); ``ginf, gamma, beta`` one value per branch."""
    t = np.asarray(time_s, dtype=float)[:, None]
    g, c, b = (np.atleast_1d(np.asarray(v, dtype=float)) for v in (ginf, gamma, beta))
    return np.sum(g * strain * (1.0 + c / (1.0 - c) * np.exp(-b * t / (1.0 - c))), axis=1)
