"""Tissue composition and the model's parameters: names, units, the paper's Table 1 and checks.

The composite of docs/model.md: a Mooney-Rivlin matrix with volume fraction ``phi_matrix``, a volumetric penalty with
bulk modulus ``bulk_kpa`` and ``n_f`` viscoelastic, tension-only fibre families with volume fractions ``phi_fibres``,
unit directions ``directions`` and slack strains ``eps0`` (paper eq. (4)). The material parameters, in the paper's
order, are ``mu, kappa`` then ``ginf_k, gamma_k, beta_k`` for each fibre family k = 1..n_f (Table 1 of docs/model.md).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from bayestissue._validation import ValidationError, check_positive, check_unit_vector
from bayestissue.paper import (
    KIND_INITIAL,
    PAPER_BULK_KPA,
    PAPER_DIRECTIONS_PRINTED,
    PAPER_PHI_FIBRES,
    PAPER_PHI_MATRIX,
    param_kind,
)

__all__ = [
    "TissueConfig",
    "PAPER_TISSUE",
    "param_names",
    "modulus_indices",
    "parse_parameters",
    "check_parameters",
]


def modulus_indices(names) -> list[int]:
    """Positions of the moduli (``mu``, ``kappa``, ``ginf<k>``) among parameter ``names``: what a stiffness scale
    multiplies."""
    return [i for i, n in enumerate(names) if param_kind(n) in ("mu", "kappa", "ginf")]


def param_names(n_fibres: int = 3) -> tuple[str, ...]:
    """Parameter names in the paper's order: ``mu, kappa, ginf1, gamma1, beta1, ..., beta<n_fibres>``."""
    names = ["mu", "kappa"]
    for k in range(1, n_fibres + 1):
        names += [f"ginf{k}", f"gamma{k}", f"beta{k}"]
    return tuple(names)


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
    """

    directions: np.ndarray
    phi_fibres: np.ndarray
    phi_matrix: float
    bulk_kpa: float = 1000.0
    eps0: np.ndarray | None = field(default=None)
    preset: str = "slug"
    second_branch: tuple = ()

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

    @property
    def n_fibres(self) -> int:
        return self.directions.shape[0]

    @property
    def param_names(self) -> tuple[str, ...]:
        return param_names(self.n_fibres)


#: The paper's composition: three fibre families of 0.2 each, matrix 0.4, K = 1000 kPa, eps0 = 0 (docs/model.md).
PAPER_TISSUE = TissueConfig(
    directions=PAPER_DIRECTIONS_PRINTED,
    phi_fibres=PAPER_PHI_FIBRES,
    phi_matrix=PAPER_PHI_MATRIX,
    bulk_kpa=PAPER_BULK_KPA,
)


def check_parameters(params, names: tuple[str, ...]) -> np.ndarray:
    """Check material parameters row by row; return them as a float array of the same shape.

    Moduli (mu, kappa, ginf_k) must be >= 0, gamma_k in [0, 1) (the discrete Kelvin update divides by
    c = 1 - gamma exp(-beta dt / 2)) and beta_k > 0.

    Raises
    ------
    ValidationError naming the row, the parameter and the value.
    """
    p = np.asarray(params, dtype=float)
    p2 = np.atleast_2d(p)
    if p2.ndim != 2 or p2.shape[1] != len(names):
        raise ValidationError(
            "params",
            f"array of shape {p.shape}",
            f"shape (n_sets, {len(names)}) in the order {names}",
        )
    for j, name in enumerate(names):
        col = p2[:, j]
        kind = param_kind(name)
        if kind == "gamma":
            bad = ~((col >= 0) & (col < 1))
            expected = "a value in [0, 1)"
        elif kind == "beta":
            bad = ~(col > 0)
            expected = "a rate > 0 (1/s)"
        else:
            bad = ~(col >= 0)
            expected = "a modulus >= 0 (kPa)"
        bad |= ~np.isfinite(col)
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            field_name = name if p.ndim == 1 else f"params[{i}].{name}"
            raise ValidationError(field_name, float(col[i]), expected)
    return p


def parse_parameters(text: str, names: tuple[str, ...], *, base: np.ndarray | None = None) -> np.ndarray:
    """Parse ``"mu=2.18,kappa=2.91,..."`` into a parameter vector, starting from ``base`` (default: the paper's
    initial guess, the same for every fibre family) for the names not given. Unknown names raise a ValidationError
    listing the known ones."""
    if base is None:
        base = [KIND_INITIAL[param_kind(n)] for n in names]
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
    return check_parameters(values, names)
