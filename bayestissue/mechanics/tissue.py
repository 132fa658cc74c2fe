"""Tissue composition and its constitutive laws: which laws, their parameters (specifications, names, order) and checks.

The composite of docs/model.md: a matrix law with volume fraction ``phi_matrix``, a volumetric penalty with bulk
modulus ``bulk_kpa`` and ``n_f`` tension-only fibre families with volume fractions ``phi_fibres``, unit directions
``directions`` and slack strains ``eps0`` (paper eq. (4)), each family following the fibre law; either law may carry a
Prony series of relaxing branches (:mod:`~bayestissue.mechanics.laws`). The paper's model is the default: a
Mooney-Rivlin matrix (elastic) and the linear fibre with one branch (the paper's Kelvin fibre), whose parameters, in
the paper's order, are ``mu, kappa`` then ``ginf_k, gamma_k, beta_k`` for each family k (Table 1 of docs/model.md).

Parameter order (the kernels' layout, :attr:`TissueConfig.layout`): the matrix law's, the matrix branches' (suffix
``_m``), then for each family k the fibre law's and its branches' (suffix k; ``_k`` after a name ending in a digit).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from bayestissue._validation import ValidationError, check_positive, check_unit_vector
from bayestissue.mechanics.laws import FibreLaw, LawParameter, LinearFibre, MatrixLaw, MooneyRivlin
from bayestissue.mechanics.laws.prony import (
    branch_order,
    branch_parameter_count,
    branch_parameters,
    check_branches,
)
from bayestissue.paper import PAPER_BULK_KPA, PAPER_DIRECTIONS_PRINTED, PAPER_PHI_FIBRES, PAPER_PHI_MATRIX

__all__ = [
    "TissueConfig",
    "PAPER_TISSUE",
    "param_names",
    "parse_parameters",
    "check_parameters",
]


def _suffixed_name(name: str, suffix: str) -> str:
    """A fibre family's or the matrix branches' name: ``ginf`` + ``2`` -> ``ginf2``, ``k1`` + ``2`` -> ``k1_2``."""
    sep = "_" if name[-1].isdigit() and suffix[:1].isdigit() else ""
    return f"{name}{sep}{suffix}"


def _suffixed(p: LawParameter, suffix: str) -> LawParameter:
    """A fibre family's or the matrix branches' copy of ``p`` (:func:`_suffixed_name`)."""
    return p.renamed(_suffixed_name(p.name, suffix))


@dataclass(frozen=True)
class TissueConfig:
    """Fixed inputs of the composite: fibre directions, volume fractions, bulk modulus and slack strains.

    Parameters
    ----------
    directions : (n_f, 3) array_like
        Fibre directions; each must be a unit vector within 1 % (the paper's printed v2, v3 have |v| = 0.9974)
        and is normalised. Empty (``n_f = 0``) for a matrix-only, isotropic material.
    phi_fibres : (n_f,) array_like
        Volume fraction of each fibre family, in [0, 1].
    phi_matrix : float
        Volume fraction of the matrix; ``phi_matrix + sum(phi_fibres)`` must be 1 within 1e-6.
    bulk_kpa : float
        Bulk modulus K of the volumetric penalty, kPa (paper: 1000 kPa, Section 3.2).
    eps0 : (n_f,) array_like, optional
        Slack Green strain per fibre (paper: 0).
    preset : str
        The preset the composition started from (:mod:`bayestissue.mechanics.presets`); it names the default
        parameter boxes of a calibration.
    second_branch : tuple of int
        Families (1-based) given a second Kelvin branch by
        :func:`~bayestissue.mechanics.branches.with_second_branch`; their second branches are the last
        ``len(second_branch)`` families (provenance; the directions and fractions already include them).
    matrix, fibre : MatrixLaw, FibreLaw
        The laws (:mod:`bayestissue.mechanics.laws`; default the paper's Mooney-Rivlin and linear fibre).
    matrix_branches, fibre_branches : int
        Prony branches of each law (default 0 and 1: an elastic matrix, the paper's Kelvin fibre).
    """

    directions: np.ndarray
    phi_fibres: np.ndarray
    phi_matrix: float
    bulk_kpa: float = 1000.0
    eps0: np.ndarray | None = field(default=None)
    preset: str = "slug"
    second_branch: tuple = ()
    matrix: MatrixLaw = field(default_factory=MooneyRivlin)
    fibre: FibreLaw = field(default_factory=LinearFibre)
    matrix_branches: int = 0
    fibre_branches: int = 1

    def __post_init__(self):
        d = np.asarray(self.directions, dtype=float)
        if d.size == 0:  # matrix only (isotropic): no fibre family
            d = d.reshape(0, 3)
        if d.ndim != 2 or d.shape[1] != 3:
            raise ValidationError("tissue.directions", d.tolist(), "an (n_f, 3) list of unit vectors (or [])")
        nf = d.shape[0]
        d = np.array([check_unit_vector(f"tissue.directions[{k}]", d[k]) for k in range(nf)]).reshape(nf, 3)
        phi = np.asarray(self.phi_fibres, dtype=float).reshape(-1)
        if phi.shape != (nf,):
            raise ValidationError("tissue.phi_fibres", phi.tolist(), f"{nf} values (one per fibre direction)")
        for k, p in enumerate(phi):
            if not (np.isfinite(p) and 0.0 <= p <= 1.0):
                raise ValidationError(f"tissue.phi_fibres[{k}]", float(p), "a volume fraction in [0, 1]")
        pm = float(self.phi_matrix)
        if not (np.isfinite(pm) and 0.0 <= pm <= 1.0):
            raise ValidationError("tissue.phi_matrix", self.phi_matrix, "a volume fraction in [0, 1]")
        total = pm + phi.sum()
        if abs(total - 1.0) > 1e-6:
            raise ValidationError(
                "tissue volume fractions",
                f"phi_matrix + sum(phi_fibres) = {total:.6g}",
                "a sum of 1 (within 1e-6)",
            )
        check_positive("tissue.bulk_kpa", self.bulk_kpa)
        eps0 = np.zeros(nf) if self.eps0 is None else np.asarray(self.eps0, dtype=float).reshape(-1)
        if eps0.shape != (nf,) or not np.all(np.isfinite(eps0)):
            raise ValidationError("tissue.eps0", eps0.tolist(), f"{nf} finite slack strains")
        for name, val in (("directions", d), ("phi_fibres", phi), ("eps0", eps0)):
            val.setflags(write=False)
            object.__setattr__(self, name, val)
        object.__setattr__(self, "second_branch", tuple(int(k) for k in self.second_branch))
        object.__setattr__(self, "phi_matrix", pm)
        object.__setattr__(self, "bulk_kpa", float(self.bulk_kpa))
        if not isinstance(self.matrix, MatrixLaw):
            raise ValidationError("tissue.matrix", self.matrix, "a matrix law (bayestissue.mechanics.laws)")
        if not isinstance(self.fibre, FibreLaw):
            raise ValidationError("tissue.fibre", self.fibre, "a fibre law (bayestissue.mechanics.laws)")
        object.__setattr__(self, "matrix_branches", check_branches(self.matrix_branches, "tissue.matrix_branches"))
        object.__setattr__(self, "fibre_branches", check_branches(self.fibre_branches, "tissue.fibre_branches"))

    @property
    def n_fibres(self) -> int:
        return self.directions.shape[0]

    @property
    def parameters(self) -> tuple[LawParameter, ...]:
        """The specification of every material parameter, in the kernels' order (module docstring)."""
        specs = list(self.matrix.parameters()) + list(branch_parameters(self.matrix_branches, "_m"))
        fibre = self.fibre.parameters()
        for k in range(1, self.n_fibres + 1):
            specs += [_suffixed(p, str(k)) for p in fibre]
            specs += list(branch_parameters(self.fibre_branches, str(k)))
        return tuple(specs)

    @property
    def label_groups(self) -> tuple[tuple[tuple[tuple[str, ...], ...], bool], ...]:
        """Terms the data cannot tell apart by label, by parameter name (:meth:`Law.label_groups`): the matrix law's,
        its branches', and each fibre family's law and branches."""
        groups = list(self.matrix.label_groups()) + list(branch_order(self.matrix_branches, "_m"))
        for k in range(1, self.n_fibres + 1):
            for terms, exchangeable in self.fibre.label_groups():
                terms = tuple(tuple(_suffixed_name(n, str(k)) for n in t) for t in terms)
                groups.append((terms, exchangeable))
            groups += branch_order(self.fibre_branches, str(k))
        return tuple(groups)

    @property
    def param_names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.parameters)

    @property
    def layout(self) -> np.ndarray:
        """The kernels' description of the laws: matrix code, its parameter count, option and branches; fibre code,
        its parameter count, option and branches; the number of families (int64, 9 entries)."""
        m, f = self.matrix, self.fibre
        return np.array(
            [m.code, m.n_parameters, m.kernel_options(), self.matrix_branches,
             f.code, f.n_parameters, f.kernel_options(), self.fibre_branches, self.n_fibres],
            dtype=np.int64,
        )  # fmt: skip

    @property
    def n_parameters(self) -> int:
        m = self.matrix.n_parameters + branch_parameter_count(self.matrix_branches)
        return m + self.n_fibres * (self.fibre.n_parameters + branch_parameter_count(self.fibre_branches))

    def components(self) -> tuple[str, ...]:
        """``"matrix"`` or ``"fibre"`` for each parameter (where a preset's box for a role applies)."""
        n_m = self.matrix.n_parameters + branch_parameter_count(self.matrix_branches)
        return ("matrix",) * n_m + ("fibre",) * (self.n_parameters - n_m)

    def family_parameters(self, k: int) -> tuple[str, ...]:
        """The names of fibre family ``k``'s parameters (1-based), its law's then its branches'."""
        start = self.matrix.n_parameters + branch_parameter_count(self.matrix_branches)
        stride = self.fibre.n_parameters + branch_parameter_count(self.fibre_branches)
        return self.param_names[start + (k - 1) * stride : start + k * stride]

    def modulus_indices(self) -> list[int]:
        """Positions of the moduli (role ``modulus``): what a stiffness scale multiplies (the stress is linear in
        them at fixed exponents)."""
        return [i for i, p in enumerate(self.parameters) if p.role == "modulus"]

    @property
    def is_paper_model(self) -> bool:
        """The paper's laws: a Mooney-Rivlin matrix without branches, the linear fibre with one branch."""
        return (self.matrix, self.fibre, self.matrix_branches, self.fibre_branches) == (
            MooneyRivlin(), LinearFibre(), 0, 1)  # fmt: skip


#: The paper's composition: three fibre families of 0.2 each, matrix 0.4, K = 1000 kPa, eps0 = 0 (docs/model.md).
PAPER_TISSUE = TissueConfig(
    directions=PAPER_DIRECTIONS_PRINTED,
    phi_fibres=PAPER_PHI_FIBRES,
    phi_matrix=PAPER_PHI_MATRIX,
    bulk_kpa=PAPER_BULK_KPA,
)


def param_names(n_fibres: int = 3) -> tuple[str, ...]:
    """The paper's parameter names for ``n_fibres`` families: ``mu, kappa, ginf1, gamma1, beta1, ..., beta<n>``."""
    return tuple(["mu", "kappa"] + [f"{k}{j}" for j in range(1, n_fibres + 1) for k in ("ginf", "gamma", "beta")])


def _admissible(p: LawParameter, col: np.ndarray) -> tuple[np.ndarray, str]:
    """Where the kernels can evaluate a parameter's values, and what that is in words (from its specification)."""
    if p.role == "viscous_fraction":  # the discrete update divides by c = 1 - gamma exp(-beta dt / 2)
        return (col >= 0) & (col < 1), "a value in [0, 1)"
    if p.role == "relaxation_rate":
        return col > 0, "a rate > 0 (1/s)"
    if p.role == "dispersion":
        return (col >= 0) & (col <= 1.0 / 3.0), "a dispersion in [0, 1/3]"
    if p.role == "recruitment_stretch":
        return col >= 1, "a stretch >= 1"
    if p.scale == "log" and p.role == "modulus":
        return col >= 0, f"a modulus >= 0 ({p.unit})"
    if p.scale == "log":
        return col > 0, f"a value > 0 ({p.unit})"
    return np.isfinite(col), "a finite number"


def check_parameters(params, specs) -> np.ndarray:
    """Check material parameters row by row against their specifications (``specs``: ``TissueConfig.parameters``);
    return them as a float array of the same shape.

    Raises
    ------
    ValidationError naming the row, the parameter and the value (moduli >= 0, gamma in [0, 1), beta > 0, ...).
    """
    names = tuple(s.name for s in specs)
    p = np.asarray(params, dtype=float)
    p2 = np.atleast_2d(p)
    if p2.ndim != 2 or p2.shape[1] != len(names):
        raise ValidationError(
            "params",
            f"array of shape {p.shape}",
            f"shape (n_sets, {len(names)}) in the order {names}",
        )
    for j, spec in enumerate(specs):
        col = p2[:, j]
        good, expected = _admissible(spec, col)
        bad = ~(good & np.isfinite(col))
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            field_name = spec.name if p.ndim == 1 else f"params[{i}].{spec.name}"
            raise ValidationError(field_name, float(col[i]), expected)
    return p


def parse_parameters(text: str, specs, *, base: np.ndarray | None = None) -> np.ndarray:
    """Parse ``"mu=2.18,kappa=2.91,..."`` into a parameter vector, starting from ``base`` (default: each parameter's
    initial value, :attr:`LawParameter.initial`) for the names not given. Unknown names raise a ValidationError listing
    the known ones."""
    names = tuple(s.name for s in specs)
    if base is None:
        base = [s.initial for s in specs]
    values = np.array(base, dtype=float)
    given = set()
    for item in filter(None, (s.strip() for s in text.split(","))):
        key, sep, val = item.partition("=")
        key = key.strip()
        if not sep:
            raise ValidationError("--params", item, "name=value pairs separated by commas")
        if key in given:
            raise ValidationError("--params", text, "each parameter once", f"{key} given twice")
        given.add(key)
        if key not in names:
            raise ValidationError("--params", key, f"one of the parameter names {', '.join(names)}")
        try:
            values[names.index(key)] = float(val)
        except ValueError:
            raise ValidationError(f"--params {key}", val, "a number") from None
    return check_parameters(values, specs)
