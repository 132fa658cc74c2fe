"""What every constitutive law declares: its parameters, each with a specification, and its place in the kernels.

A law is one small class (STYLE.md, after sfepy's one class per hyperelastic term) carrying its equations in the
docstring, a parameter specification per parameter and the code by which the compiled kernels dispatch to it. Every
consumer reads the specifications, never the names: priors (log-uniform on a ``"log"`` scale, uniform on a
``"linear"`` one), boxes and initial values, units, the moduli a stiffness scale multiplies (``role ==
"modulus"``), the sign a value may take.

Matrix laws (isotropic, hyperelastic, isochoric part; the volumetric penalty is the tissue's) and fibre laws (a 1-D
stress of the fibre strain, tension-only) are each a subclass of :class:`MatrixLaw` or :class:`FibreLaw`;
viscoelasticity is not a law of its own but a Prony series wrapped around either
(:mod:`~bayestissue.mechanics.laws.prony`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

from bayestissue._validation import ValidationError

__all__ = ["ROLES", "FibreLaw", "Law", "LawParameter", "MatrixLaw"]

#: What a parameter does, for the consumers that treat kinds of parameters alike (a stiffness scale multiplies the
#: moduli; plots group by role). ``relative_modulus`` scales a law's own moduli (a Prony branch's share).
ROLES = (
    "modulus",
    "exponent",
    "relative_modulus",
    "viscous_fraction",
    "relaxation_rate",
    "dispersion",
    "recruitment_stretch",
)


@dataclass(frozen=True)
class LawParameter:
    """The specification of one material parameter.

    Parameters
    ----------
    name : the parameter's name in configurations, tables and results (unique within a tissue).
    unit : ``"kPa"``, ``"1"``, ``"1/s"``.
    lower, upper : the default box (finite; a preset may move it).
    scale : ``"log"`` (positive; log-uniform prior, log steps) or ``"linear"`` (uniform prior).
    role : one of :data:`ROLES`.
    initial : the default starting value (inside the box).
    description : one line for ``docs/laws.md``.
    """

    name: str
    unit: str
    lower: float
    upper: float
    scale: str
    role: str
    initial: float
    description: str = ""

    def __post_init__(self):
        if self.scale not in ("log", "linear"):
            raise ValidationError(f"parameter {self.name} scale", self.scale, "'log' or 'linear'")
        if self.role not in ROLES:
            raise ValidationError(f"parameter {self.name} role", self.role, f"one of {ROLES}")
        lo, hi, x0 = float(self.lower), float(self.upper), float(self.initial)
        if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
            raise ValidationError(f"parameter {self.name} box", (lo, hi), "finite bounds with lower < upper")
        if self.scale == "log" and lo <= 0:
            raise ValidationError(f"parameter {self.name} box", (lo, hi), "a positive box on a log scale")
        if not lo <= x0 <= hi:
            raise ValidationError(f"parameter {self.name} initial", x0, f"a value in [{lo}, {hi}]")

    @property
    def sign(self) -> str:
        """``"positive"`` (a log scale), ``"non-negative"`` or ``"any"`` (from the box)."""
        if self.scale == "log":
            return "positive"
        return "non-negative" if self.lower >= 0 else "any"

    def renamed(self, name: str) -> LawParameter:
        """The same specification under another name (a term's or a fibre family's index)."""
        return LawParameter(name, self.unit, self.lower, self.upper, self.scale, self.role, self.initial,
                            self.description)  # fmt: skip


class Law:
    """A constitutive law: its registry name, kernel code, parameters and references (subclasses fill them)."""

    #: the name in experiment files (``[tissue] matrix = "..."``, ``fibre = "..."``)
    name: ClassVar[str] = ""
    #: the integer the compiled kernels dispatch on (:mod:`bayestissue.mechanics.laws.dispatch`)
    code: ClassVar[int] = -1
    #: one line for docs/laws.md
    title: ClassVar[str] = ""
    #: the literature, with DOI
    reference: ClassVar[str] = ""
    #: the options the experiment file may give (``terms``, ``recruitment``) with their defaults
    options: ClassVar[dict] = {}

    def __init__(self, **options):
        unknown = sorted(set(options) - set(self.options))
        if unknown:
            raise ValidationError(
                f"tissue {unknown[0]}", options[unknown[0]], f"no such option for the {self.name} law",
                f"its options: {', '.join(sorted(self.options)) or 'none'}",
            )  # fmt: skip
        self.settings = {**self.options, **options}

    def parameters(self) -> tuple[LawParameter, ...]:
        """The law's parameters in kernel order."""
        raise NotImplementedError

    @property
    def n_parameters(self) -> int:
        return len(self.parameters())

    def label_groups(self) -> tuple[tuple[tuple[tuple[str, ...], ...], bool], ...]:
        """Terms of the law the data cannot tell apart by label, each group as ``(terms, exchangeable)``: per term its
        parameter names with the key by which the terms are ordered first, and whether permuting whole terms leaves
        the stress unchanged (:class:`bayestissue.inference.ordering.OrderedGroup`). None by default."""
        return ()

    def kernel_options(self) -> int:
        """An integer option the kernels read (e.g. the number of Ogden terms); 0 by default."""
        return 0

    def __repr__(self) -> str:
        opts = ", ".join(f"{k}={v!r}" for k, v in self.settings.items())
        return f"{type(self).__name__}({opts})"

    def __eq__(self, other) -> bool:
        return type(self) is type(other) and self.settings == other.settings

    def __hash__(self) -> int:
        return hash((type(self).__name__, tuple(sorted(self.settings.items()))))


class MatrixLaw(Law):
    """An isotropic hyperelastic law of the isochoric deformation, :math:`W(\\bar C)`, scaled by the matrix volume
    fraction; the tissue adds the volumetric penalty :math:`\\tfrac{K}{2}(J - 1)^2`."""

    def energy_reference(self, C, params):
        """The isochoric strain energy density :math:`W(\\bar C)` (kPa) of a (3, 3) right Cauchy-Green tensor,
        written independently of the kernels with operations that accept complex numbers (the complex-step check of
        the stress, tests/mechanics/test_laws.py)."""
        raise NotImplementedError


class FibreLaw(Law):
    """A fibre stress :math:`\\sigma(\\varepsilon)` of the fibre strain :math:`\\varepsilon = H : E` (tension only),
    with :math:`H = \\kappa I + (1 - 3\\kappa) M` the structure tensor of the family's direction
    :math:`M = v \\otimes v` (:math:`\\kappa = 0` without dispersion).
    The stress of a family of volume fraction :math:`\\phi` is :math:`S = \\phi\\, \\sigma\\, H`."""

    def energy_reference(self, strain, params):
        """The fibre strain energy :math:`w(\\varepsilon)` (kPa) of the fibre strain ``strain`` (an array, complex
        allowed), independently of the kernels."""
        raise NotImplementedError
