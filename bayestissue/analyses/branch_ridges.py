r"""Flat directions of a Prony series whose further branches sample both a relative modulus and a viscous fraction.

A law with :math:`N` Prony branches (:mod:`~bayestissue.mechanics.laws.prony`) has the relaxation modulus

.. math:: G(t) = k \sum_{i=1}^N r_i\left[1 + \frac{\gamma_i}{1 - \gamma_i} e^{-t/t_i}\right],
          \qquad r_1 = 1,\ t_i = (1 - \gamma_i)/\beta_i,

with :math:`k` the law's modulus. A test sees :math:`G` only through its equilibrium value :math:`k\sum_i r_i` and, per
branch, an amplitude :math:`k r_i\gamma_i/(1 - \gamma_i)` and a time :math:`t_i`: :math:`2N + 1` numbers, against the
:math:`3N` parameters :math:`k, \gamma_1, \beta_1` and :math:`r_i, \gamma_i, \beta_i` (:math:`i \ge 2`). Each
further branch whose :math:`r_i` and :math:`\gamma_i` are both sampled adds one direction along which the likelihood
is flat (exactly so in continuous time; the time-discrete update of eq. (5) leaves it flat to the data's precision:
on the synthetic tendon relaxation the least-squares cost is 2126.54 with :math:`\gamma_2` free or fixed,
examples/README.md); a fixed :math:`k` or :math:`\gamma_1` takes one such direction away. On such a ridge the
samplers crawl, the marginals of :math:`k, \gamma_i, r_i` are the prior's ridge, and the evidence of a branch count
measures the ridge's length in the prior as much as the data. Fixing each further branch's :math:`\gamma_i` (at any
value in the box) leaves the :math:`2N + 1` the data identify.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["BranchRidges", "branch_ridges"]


@dataclass(frozen=True)
class BranchRidges:
    """One law's (the matrix's or a fibre family's) branches: ``pairs`` the (relative modulus, viscous fraction)
    names of the further branches with both sampled, ``flat`` the flat directions they make."""

    pairs: tuple[tuple[str, str], ...]
    flat: int

    def note(self) -> str:
        fix = ", ".join(f"{g} = 0.75" for _, g in self.pairs)
        both = ", ".join(f"{r} and {g}" for r, g in self.pairs)
        return (
            f"note: {both} are both sampled: {self.flat} flat direction(s) of the likelihood (a Prony branch shows a "
            "test only its amplitude and time); the samplers crawl along them and a branch-count evidence measures "
            "their length in the prior. Fix each further branch's viscous fraction, e.g. [parameters] fixed = "
            f"{{ {fix} }} (bayestissue.analyses.branch_ridges; examples/tendon_relaxation.toml)"
        )


def _blocks(tissue) -> list[tuple[str, ...]]:
    """The parameter names of each law with its branches: the matrix's, then each fibre family's."""
    names = tissue.param_names
    n_fibre = sum(len(tissue.family_parameters(k)) for k in range(1, tissue.n_fibres + 1))
    blocks = [names[: len(names) - n_fibre]]
    blocks += [tissue.family_parameters(k) for k in range(1, tissue.n_fibres + 1)]
    return [b for b in blocks if b]


def branch_ridges(tissue, sampled) -> list[BranchRidges]:
    """Per law of ``tissue`` (a :class:`~bayestissue.mechanics.tissue.TissueConfig`) with flat directions, given the
    ``sampled`` parameter names (the rest fixed or tied): the module docstring's count. Roles come from the laws'
    specifications; a further branch's parameters follow its relative modulus in the order
    :math:`r_i, \\gamma_i, \\beta_i` (:mod:`~bayestissue.mechanics.laws.prony`)."""
    sampled = set(sampled)
    role = {p.name: p.role for p in tissue.parameters}
    out = []
    for block in _blocks(tissue):
        pairs = tuple(
            (r, g)
            for r, g in zip(block, block[1:], strict=False)
            if role[r] == "relative_modulus" and role[g] == "viscous_fraction" and {r, g} <= sampled
        )
        if not pairs:
            continue
        first_gamma = next(n for n in block if role[n] == "viscous_fraction")
        moduli = [n for n in block if role[n] == "modulus"]
        taken = (first_gamma not in sampled) + (not any(n in sampled for n in moduli))
        flat = max(0, len(pairs) - taken)
        if flat:
            out.append(BranchRidges(pairs, flat))
    return out
