r"""Flat directions of relaxing branches: the parameters a relaxation test cannot see apart.

A law with :math:`N` Prony branches (:mod:`~bayestissue.mechanics.laws.prony`) has the relaxation modulus

.. math:: G(t) = k \sum_{i=1}^N r_i\left[1 + \frac{\gamma_i}{1 - \gamma_i} e^{-t/t_i}\right],
          \qquad r_1 = 1,\ t_i = (1 - \gamma_i)/\beta_i,

with :math:`k` the law's modulus (its moduli together: the elastic law's shape is the same in every branch). A test
sees :math:`G` only through its equilibrium value :math:`k\sum_i r_i` and, per branch, an amplitude
:math:`k r_i\gamma_i/(1 - \gamma_i)` and a time :math:`t_i`: :math:`2N + 1` numbers, against the :math:`3N`
parameters :math:`k, \gamma_1, \beta_1` and :math:`r_i, \gamma_i, \beta_i` (:math:`i \ge 2`). The same holds for the
two-branch fibre of :mod:`~bayestissue.mechanics.branches` (``[tissue] second_branch``: two linear Kelvin families on
one direction, moduli :math:`g_a, g_b`), whose relaxation modulus is :math:`\sum_{j=a,b} g_j[1 + \gamma_j/(1 -
\gamma_j) e^{-t/t_j}]`: five numbers, six parameters.

The count, given which parameters are sampled (the rest fixed or tied): the rank :math:`R` of the Jacobian of those
numbers with respect to the sampled parameters, taken by complex step at a generic point, and
:math:`n_{sampled} - R` flat directions. With every parameter sampled that is one per further branch; a fixed
:math:`k`, :math:`\gamma_1` or a further branch's :math:`\gamma_i` or :math:`\beta_i` takes one away. The likelihood
is exactly flat along them in continuous time; the time-discrete update of eq. (5) leaves it flat to the data's
precision (on the synthetic tendon relaxation the least-squares cost is 2126.54 with :math:`\gamma_2` free or fixed,
docs/verification.md). On such a ridge the samplers crawl, the marginals of :math:`k, \gamma_i, r_i` are the prior's
ridge, and the evidence of a branch count measures the ridge's length in the prior as much as the data. Fixing a
further branch's :math:`\gamma_i` (at any value in the box) leaves the numbers the data identify.

A second branch on a fibre law with parameters other than moduli (an exponent) is not counted: there the two
families' elastic shapes differ and no such ridge follows from the relaxation modulus alone.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bayestissue.mechanics.laws.prony import branch_parameter_count

__all__ = ["BranchRidges", "branch_ridges"]


@dataclass(frozen=True)
class BranchRidges:
    """One law's (the matrix's or a fibre family's, with its second branch if it has one) flat directions:
    ``pairs`` the (modulus or relative modulus, viscous fraction) names of the further branches with every parameter
    sampled, ``flat`` the flat directions (module docstring)."""

    pairs: tuple[tuple[str, str], ...]
    flat: int

    def note(self) -> str:
        fix = ", ".join(f"{g} = 0.75" for _, g in self.pairs[: self.flat])
        both = ", ".join(f"{r} and {g}" for r, g in self.pairs)
        return (
            f"note: {both} are both sampled: {self.flat} flat direction(s) of the likelihood (a relaxing branch shows "
            "a test only its amplitude and time); the samplers crawl along them and a branch-count evidence measures "
            "their length in the prior. Fix a further branch's viscous fraction for each, e.g. [parameters] fixed = "
            f"{{ {fix} }} (bayestissue.analyses.branch_ridges; examples/tendon_relaxation.toml)"
        )


@dataclass(frozen=True)
class _Law:
    """One elastic law's moduli and its branches ``(relative modulus or None, viscous fraction, rate)``."""

    moduli: tuple[str, ...]
    branches: tuple[tuple[str | None, str, str], ...]


def _law(block, n: int, role) -> _Law | None:
    """The law of one block of names (the law's parameters, then its ``n`` branches'), or None without branches."""
    if n == 0:
        return None
    m = branch_parameter_count(n)
    own, br = block[: len(block) - m], block[len(block) - m :]
    rest = [tuple(br[2 + 3 * i : 5 + 3 * i]) for i in range(n - 1)]
    moduli = tuple(x for x in own if role[x] == "modulus")
    return _Law(moduli, ((None, br[0], br[1]), *rest))


def _groups(tissue) -> list[list[_Law]]:
    """The laws whose relaxation a test sees as one modulus: the matrix; each fibre family, with its second branch
    (:mod:`~bayestissue.mechanics.branches`) where it has one and its law has moduli only."""
    role = {p.name: p.role for p in tissue.parameters}
    fams = [_law(tissue.family_parameters(k), tissue.fibre_branches, role) for k in range(1, tissue.n_fibres + 1)]
    n_fibre = sum(len(tissue.family_parameters(k)) for k in range(1, tissue.n_fibres + 1))
    matrix = _law(tissue.param_names[: len(tissue.param_names) - n_fibre], tissue.matrix_branches, role)
    n_base = tissue.n_fibres - len(tissue.second_branch)
    linear = all(p.role == "modulus" for p in tissue.fibre.parameters())
    groups = [[matrix]] + [[f] for f in fams[:n_base]]
    for j, k in enumerate(tissue.second_branch):
        second = fams[n_base + j]
        if linear:
            groups[k].append(second)
        else:
            groups.append([second])
    return [[law for law in g if law is not None] for g in groups if any(law is not None for law in g)]


def _numbers(group: list[_Law], value: dict) -> list:
    """Equilibrium modulus, then each branch's amplitude and time (module docstring), from ``value`` by name (the
    law's moduli enter as one scale per law, named by the law's first modulus)."""
    eq, out = 0.0, []
    for law in group:
        k = value[law.moduli[0]] if law.moduli else 1.0
        for r, g, b in law.branches:
            share = k * (value[r] if r else 1.0)
            eq = eq + share
            out += [share * value[g] / (1.0 - value[g]), (1.0 - value[g]) / value[b]]
    return [eq, *out]


def _flat(group: list[_Law], sampled: set) -> int:
    """Sampled parameters of ``group`` minus the rank of the Jacobian of its numbers (complex step, generic point)."""
    names = []
    for law in group:
        if any(m in sampled for m in law.moduli):
            names.append(law.moduli[0])
        names += [x for br in law.branches for x in br if x is not None and x in sampled]
    if not names:
        return 0
    every = [m for law in group for m in law.moduli[:1]] + [x for law in group for br in law.branches for x in br if x]
    value = {x: 0.1 + 0.8 * ((0.618034 * (i + 1)) % 1.0) for i, x in enumerate(every)}  # distinct, in (0.1, 0.9)
    jac = np.empty((1 + 2 * sum(len(law.branches) for law in group), len(names)))
    for j, x in enumerate(names):
        v = dict(value)
        v[x] = value[x] + 1e-30j
        jac[:, j] = np.imag(np.asarray(_numbers(group, v))) / 1e-30
    return len(names) - int(np.linalg.matrix_rank(jac))


def _further(group: list[_Law]) -> list[tuple[str, str, str]]:
    """Every branch but the group's first as (its modulus: relative, or a second branch's law modulus; viscous
    fraction; rate)."""
    out = []
    for i, law in enumerate(group):
        out += [(r or law.moduli[0], g, b) for j, (r, g, b) in enumerate(law.branches) if i or j]
    return out


def branch_ridges(tissue, sampled) -> list[BranchRidges]:
    """Per law group of ``tissue`` (a :class:`~bayestissue.mechanics.tissue.TissueConfig`) with flat directions,
    given the ``sampled`` parameter names (the rest fixed or tied): the module docstring's count. Roles and the
    branches' layout come from the laws' specifications (:mod:`~bayestissue.mechanics.laws.prony`)."""
    sampled = set(sampled)
    out = []
    for group in _groups(tissue):
        flat = _flat(group, sampled)
        if not flat:
            continue
        out.append(BranchRidges(tuple((r, g) for r, g, b in _further(group) if {r, g, b} <= sampled), flat))
    return out
