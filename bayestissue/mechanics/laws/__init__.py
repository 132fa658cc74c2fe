"""Constitutive laws as plug-ins: one module per law, registered here by name.

Matrix laws (isochoric, hyperelastic): :class:`MooneyRivlin` (the paper's), :class:`NeoHookean`, :class:`Ogden`
(N terms), :class:`Yeoh`. Fibre laws (tension only): :class:`LinearFibre` (the paper's; with one Prony branch its
Kelvin fibre), :class:`ExponentialFibre` (Holzapfel-Gasser-Ogden with dispersion and recruitment). Viscoelasticity:
a Prony series of N branches around either (:mod:`~bayestissue.mechanics.laws.prony`).

A new law is one module (a subclass of :class:`~bayestissue.mechanics.laws.base.MatrixLaw` or
:class:`~bayestissue.mechanics.laws.base.FibreLaw` with its parameters, its equations in the docstring and its
kernels) plus its entry here and its branch in :mod:`~bayestissue.mechanics.laws.dispatch`; ``docs/laws.md`` is
generated from this registry (:func:`laws_markdown`) and ``tests/mechanics/test_laws.py`` runs the law-level checks on
every registered law.
"""

from __future__ import annotations

from bayestissue._validation import ValidationError, check_known_keys
from bayestissue.mechanics.laws.base import FibreLaw, Law, LawParameter, MatrixLaw
from bayestissue.mechanics.laws.dispatch import FIBRE_CODES, MATRIX_CODES
from bayestissue.mechanics.laws.hgo import ExponentialFibre
from bayestissue.mechanics.laws.linear_fibre import LinearFibre
from bayestissue.mechanics.laws.mooney_rivlin import MooneyRivlin
from bayestissue.mechanics.laws.neo_hookean import NeoHookean
from bayestissue.mechanics.laws.ogden import Ogden
from bayestissue.mechanics.laws.prony import MAX_BRANCHES, branch_parameters
from bayestissue.mechanics.laws.yeoh import Yeoh

__all__ = [
    "FIBRE_LAWS",
    "MATRIX_LAWS",
    "ExponentialFibre",
    "FibreLaw",
    "Law",
    "LawParameter",
    "LinearFibre",
    "MatrixLaw",
    "MooneyRivlin",
    "NeoHookean",
    "Ogden",
    "Yeoh",
    "fibre_law",
    "laws_markdown",
    "matrix_law",
]

#: Matrix laws by the name experiment files use (``[tissue] matrix = "ogden"``).
MATRIX_LAWS: dict[str, type[MatrixLaw]] = {cls.name: cls for cls in (MooneyRivlin, NeoHookean, Ogden, Yeoh)}
#: Fibre laws by name (``[tissue] fibre = "hgo"``).
FIBRE_LAWS: dict[str, type[FibreLaw]] = {cls.name: cls for cls in (LinearFibre, ExponentialFibre)}

for _table, _codes in ((MATRIX_LAWS, MATRIX_CODES), (FIBRE_LAWS, FIBRE_CODES)):
    if sorted(c.code for c in _table.values()) != sorted(_codes):  # a law without its branch in the dispatch
        raise RuntimeError(f"law codes {sorted(c.code for c in _table.values())} != dispatch codes {_codes}")


def _make(table: dict, kind: str, name, options: dict) -> Law:
    if not isinstance(name, str):
        raise ValidationError(f"tissue {kind}", name, f"a law name, one of {sorted(table)}")
    check_known_keys(f"tissue {kind}", {name: None}, table)
    return table[name](**options)


def matrix_law(name: str, **options) -> MatrixLaw:
    """The matrix law ``name`` with its options (``terms`` for Ogden); unknown names get the nearest valid one."""
    return _make(MATRIX_LAWS, "matrix", name, options)


def fibre_law(name: str, **options) -> FibreLaw:
    """The fibre law ``name`` with its options (``recruitment`` for the exponential fibre)."""
    return _make(FIBRE_LAWS, "fibre", name, options)


def _rows(params) -> list[str]:
    return [
        f"| `{p.name}` | {p.unit} | [{p.lower:g}, {p.upper:g}] | {p.scale} | {p.role} | {p.initial:g} | "
        f"{p.description} |"
        for p in params
    ]


def laws_markdown() -> str:
    """``docs/laws.md``: every registered law with its equation's module, options and parameters."""
    head = "| parameter | unit | default box | prior scale | role | initial | meaning |\n|---|---|---|---|---|---|---|"
    lines = [
        "# Constitutive laws",
        "",
        "<!-- Generated from bayestissue/mechanics/laws/__init__.py (laws_markdown); tests/mechanics/test_laws.py "
        "keeps it equal. -->",
        "",
        'Chosen in an experiment file\'s `[tissue]` table: `matrix = "<name>"` (with `terms = N` for Ogden), '
        '`fibre = "<name>"` (with `recruitment = true` for the exponential fibre), `matrix_branches = N` and '
        "`fibre_branches = N` for a Prony series of N relaxing branches (0: elastic; the paper's model is "
        "`mooney_rivlin`, `linear`, 0 and 1). Boxes are the defaults at the scale of soft tissue in kPa; a "
        "preset (`docs/presets.md`) moves the moduli's and rates' boxes, `[parameters] bounds` any box. A "
        "`log` prior scale is log-uniform on the box, `linear` uniform. The equations are in each law's module "
        "docstring. Fibre family k's parameters carry the suffix k (`ginf2`, `k1_2` where the name ends in a "
        "digit).",
        "",
        "Terms that the data cannot tell apart by label (the terms of an Ogden law, the branches of a Prony series) "
        "are ordered by the prior: Ogden terms by decreasing exponent (`alpha1 > alpha2 > ...`), branches by "
        "decreasing rate (`beta1 > beta1_2 > ...`: branch 1 the fastest). The prior is the box prior restricted "
        "to that labelling and renormalised (`bayestissue.inference.ordering.OrderedGroup`); the evidence of "
        "a law is unchanged, its marginals describe one term each, and the nested sampler explores one copy of "
        "each mode instead of n!.",
    ]
    for title, table in (("Matrix laws", MATRIX_LAWS), ("Fibre laws", FIBRE_LAWS)):
        lines += ["", f"## {title}"]
        for name, cls in table.items():
            law = cls()
            opts = ", ".join(f"`{k} = {str(v).lower()}`" for k, v in cls.options.items()) or "none"
            lines += ["", f"### `{name}`: {cls.title}", "", f"Module `{cls.__module__}`; options: {opts}; "
                      f"{cls.reference}.", "", head, *_rows(law.parameters())]  # fmt: skip
    lines += [
        "",
        "## Prony branches (`matrix_branches`, `fibre_branches`)",
        "",
        f"Up to {MAX_BRANCHES} branches (module `bayestissue.mechanics.laws.prony`). The matrix's carry the suffix "
        "`_m`, fibre family k's the suffix k; two branches of family 2:",
        "",
        head,
        *_rows(branch_parameters(2, "2")),
    ]
    return "\n".join(lines) + "\n"
