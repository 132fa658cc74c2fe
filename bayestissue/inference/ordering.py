r"""Ordered label groups: terms of one law whose labels the data cannot tell apart, and the prior that keeps one
labelling of them.

An Ogden law's terms and a Prony series' branches enter the stress symmetrically, so the likelihood has one copy of
each mode per labelling of the terms: ``n!`` for ``n`` terms. A sampler sees label-switching modes and each marginal
mixes the terms. The remedy is an identifiability constraint (Jasra, Holmes & Stephens 2005, Stat Sci 20:50,
doi:10.1214/088342305000000016): the prior is the box prior restricted to the region where the terms' keys decrease,
renormalised. With the keys independent and identically distributed on the box, that region holds :math:`1/n!` of
the prior mass whatever the other parameters, so the density there is :math:`n!` times the box prior's and the
evidence of a likelihood symmetric in the terms is unchanged.

The functions take an *index* (:func:`order_index`): per group in force, the keys' positions among the sampled
parameters and, for an exchangeable group, the positions of every term's parameters. :class:`ParameterSet
<bayestissue.inference.parameters.ParameterSet>` holds the groups and calls them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bayestissue._validation import ValidationError

__all__ = [
    "OrderedGroup",
    "canonical",
    "folded",
    "groups_in_force",
    "in_order",
    "order_index",
    "order_statistics",
    "relabelling",
    "sort_keys",
    "swapped",
]


@dataclass(frozen=True)
class OrderedGroup:
    """Terms of one law whose labels the data cannot tell apart (Ogden terms, Prony branches), ordered by a key.

    The likelihood has one copy of each mode per labelling of the terms (``n!`` for ``n`` terms): samplers see
    label-switching modes and marginals mix the terms. The prior is restricted to one labelling, the terms' keys
    strictly decreasing (``terms[0][0] > terms[1][0] > ...``), and renormalised: with the keys independent and
    identically distributed on the box, the ordered region holds ``1/n!`` of the prior mass, so the density there is
    ``n!`` times the box prior's (Jasra, Holmes & Stephens 2005, Stat Sci 20:50, doi:10.1214/088342305000000016;
    the nested sampler's bijective transform onto the region: :func:`order_statistics`).

    Parameters
    ----------
    terms : per term its parameter names, the key first (e.g. ``(("alpha1", "mu1"), ("alpha2", "mu2"))``).
    exchangeable : permuting whole terms leaves the likelihood unchanged (Ogden terms), so a point of another
        labelling can be relabelled (:func:`canonical`); False where the terms differ in form
        (a Prony series' first branch carries no relative modulus): only the prior's restriction applies.
    """

    terms: tuple[tuple[str, ...], ...]
    exchangeable: bool = True

    def __post_init__(self):
        terms = tuple(tuple(t) for t in self.terms)
        if len(terms) < 2 or not all(terms) or (self.exchangeable and len({len(t) for t in terms}) != 1):
            raise ValidationError("ordered group", terms, "two or more terms of equally many parameter names")
        object.__setattr__(self, "terms", terms)

    @property
    def keys(self) -> tuple[str, ...]:
        return tuple(t[0] for t in self.terms)

    @property
    def text(self) -> str:
        """``"alpha1 > alpha2"``."""
        return " > ".join(self.keys)


def groups_in_force(groups, by_name) -> tuple[OrderedGroup, ...]:
    """The groups that apply to parameters ``by_name`` (name -> ParameterSpec): a term with a fixed or tied
    parameter leaves its group; a group keeps at least two terms whose keys (and, if exchangeable, every parameter of
    a term) have the same box and prior, or is dropped (its keys would no longer be identically distributed)."""
    out = []
    for g in groups:
        if not isinstance(g, OrderedGroup):
            raise ValidationError("ordered", g, "an OrderedGroup")
        unknown = sorted({n for t in g.terms for n in t} - set(by_name))
        if unknown:
            raise ValidationError("ordered group parameter names", unknown, f"names among {list(by_name)}")
        terms = tuple(t for t in g.terms if all(not by_name[n].fixed and by_name[n].tied_to is None for n in t))
        if len(terms) < 2:
            continue

        def same(names):
            return len({(by_name[n].lower, by_name[n].upper, by_name[n].prior) for n in names}) == 1

        columns = zip(*terms, strict=True) if g.exchangeable else [[t[0] for t in terms]]
        if all(same(c) for c in columns):
            out.append(OrderedGroup(terms, g.exchangeable))
    return tuple(out)


def order_index(groups, names) -> tuple[tuple[np.ndarray, np.ndarray | None], ...]:
    """Per group: the keys' positions in ``names`` (the sampled parameters) and, for an exchangeable group, the
    ``(n_terms, term_size)`` positions of its terms (None otherwise)."""
    names = list(names)
    out = []
    for g in groups:
        keys = np.array([names.index(k) for k in g.keys])
        terms = np.array([[names.index(n) for n in t] for t in g.terms]) if g.exchangeable else None
        out.append((keys, terms))
    return tuple(out)


def in_order(theta: np.ndarray, index) -> np.ndarray:
    """Whether every group's keys decrease strictly; ``theta.shape[:-1]``."""
    ok = np.ones(theta.shape[:-1], dtype=bool)
    for keys, _ in index:
        ok &= np.all(np.diff(theta[..., keys], axis=-1) < 0.0, axis=-1)
    return ok


def order_statistics(q: np.ndarray, index) -> np.ndarray:
    r"""Unit-cube coordinates ``q`` with each group's keys replaced by the order statistics of as many uniforms, a
    bijection of the cube onto the ordered region: :math:`v_1 = q_1^{1/n}`, :math:`v_k = v_{k-1} q_k^{1/(n-k+1)}` (the
    largest of ``n`` uniforms has CDF :math:`v^n`; given it, the other ``n - 1`` are uniforms below it). Through a
    monotone box CDF's inverse they are the restricted prior's keys; a nested sampler then sees one labelling, not
    ``n!`` copies of each mode."""
    if not index:
        return q
    q = np.array(q, dtype=float, copy=True)
    for keys, _ in index:
        n = keys.size
        v = np.ones(q.shape[:-1])
        for k, j in enumerate(keys):
            v = v * q[..., j] ** (1.0 / (n - k))
            q[..., j] = v
    return q


def sort_keys(draws: np.ndarray, index) -> np.ndarray:
    """Box-prior draws ``(n, n_sampled)`` made draws of the restricted prior: each group's keys sorted decreasing (the
    other parameters are independent of the keys)."""
    for keys, _ in index:
        draws[:, keys] = -np.sort(-draws[:, keys], axis=1)
    return draws


def _permutations(t2: np.ndarray, index) -> np.ndarray:
    """``(n_sets, n_sampled)`` positions: row ``i`` of :func:`canonical` is ``t2[i, perm[i]]``. The terms of each
    exchangeable group are sorted by decreasing key (stable); other positions map to themselves."""
    perm = np.tile(np.arange(t2.shape[-1]), (t2.shape[0], 1))
    for keys, terms in index:
        if terms is None:
            continue
        order = np.argsort(-t2[:, keys], axis=1, kind="stable")  # (n_sets, n_terms): term k takes term order[k]
        perm[:, terms.ravel()] = terms[order].reshape(t2.shape[0], -1)
    return perm


def relabelling(theta: np.ndarray, index) -> np.ndarray:
    """The positions ``perm`` with ``canonical(theta) == theta[perm]`` for one point ``theta`` (n_sampled,)."""
    return _permutations(np.atleast_2d(theta), index)[0]


def canonical(theta: np.ndarray, index) -> np.ndarray:
    """``theta`` (..., n_sampled) with the terms of each exchangeable group permuted so that their keys decrease (a
    point of another labelling has the same likelihood); other groups are left as they are."""
    theta = np.asarray(theta, dtype=float)
    t2 = theta.reshape(-1, theta.shape[-1])
    return np.take_along_axis(t2, _permutations(t2, index), axis=1).reshape(theta.shape)


def swapped(x: np.ndarray, swap) -> np.ndarray:
    """``x`` ``(n, d)`` with the column groups ``swap = (a, b)`` exchanged: the permutation :math:`P` of two
    exchangeable parameter groups (the full model's fibre families 2 and 3, mirror images about the loading axis)."""
    a, b = (list(g) for g in swap)
    out = np.array(x, dtype=float, copy=True)
    out[:, a], out[:, b] = x[:, b], x[:, a]
    return out


def folded(x: np.ndarray, swap) -> np.ndarray:
    """``x`` ``(n, d)`` folded onto one copy of the exchange ``swap = (a, b)``: the rows with
    :math:`x_{a_0} < x_{b_0}` swapped (:func:`swapped`), so that the first group's leading parameter is not smaller
    than the second's (ties left as they are)."""
    x = np.asarray(x, dtype=float)
    return np.where((x[:, swap[0][0]] < x[:, swap[1][0]])[:, None], swapped(x, swap), x)
