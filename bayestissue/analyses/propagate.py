"""Stereological uncertainty carried into the calibration: a "cut" posterior over the replicate table.

The stereology gives bootstrap replicates :math:`\\xi_r` of the fixed inputs (fibre directions and
volume fractions; ``data/stereology_replicates.csv``). The cut posterior (Plummer 2015,
doi:10.1007/s11222-014-9503-z) does not let the mechanical data update :math:`\\xi`; it averages the
posteriors given each replicate,

.. math:: p_{cut}(\\theta \\mid y) = \\frac1R \\sum_{r=1}^{R} p(\\theta \\mid y, \\xi_r),

so each replicate is calibrated on its own (independent tasks, fanned out) and the draws are pooled
in equal shares. The width of a central interval with and without the stereological uncertainty
measures how much of the parameter uncertainty it explains.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from bayestissue._validation import ValidationError, check_interval
from bayestissue.mechanics import TissueConfig

__all__ = ["replicate_tissues", "half_angles_deg", "pool_draws", "interval_width", "width_ratio"]


def replicate_tissues(replicates: dict, *, base: TissueConfig) -> list[TissueConfig]:
    """One :class:`~bayestissue.mechanics.TissueConfig` per replicate row.

    Parameters
    ----------
    replicates : dict from :func:`bayestissue.io.stereology_files.read_replicates` with ``directions``
        (n, 3, 3), ``phi_fibres`` (n, 3) and ``phi_matrix`` (n,).
    base : the bulk modulus and slack strains are taken from it.
    """
    try:
        D = np.asarray(replicates["directions"], dtype=float)
        phi = np.asarray(replicates["phi_fibres"], dtype=float)
        pm = np.asarray(replicates["phi_matrix"], dtype=float)
    except KeyError as exc:
        raise ValidationError("replicates", sorted(replicates), "keys directions, phi_fibres, phi_matrix") from exc
    if D.ndim != 3 or D.shape[1:] != (3, 3) or phi.shape != (D.shape[0], 3) or pm.shape != (D.shape[0],):
        raise ValidationError("replicates", (D.shape, phi.shape, pm.shape), "(n,3,3), (n,3), (n,) arrays")
    out = []
    for r in range(D.shape[0]):
        total = pm[r] + phi[r].sum()  # the table rounds: renormalise so the fractions sum to 1
        out.append(
            TissueConfig(
                directions=D[r] / np.linalg.norm(D[r], axis=1, keepdims=True),
                phi_fibres=phi[r] / total,
                phi_matrix=pm[r] / total,
                bulk_kpa=base.bulk_kpa,
                eps0=base.eps0,
            )
        )
    return out


def half_angles_deg(directions: np.ndarray) -> np.ndarray:
    """In-plane angle between the x axis and fibre families 2 and 3, averaged: ``(n,)`` degrees.

    ``directions`` (n, 3, 3) or (3, 3); the angle of :math:`v_k` is :math:`\\arctan(|v_y| / |v_x|)`.
    """
    D = np.asarray(directions, dtype=float)
    D = D[None] if D.ndim == 2 else D
    ang = np.degrees(np.arctan2(np.abs(D[:, 1:, 1]), np.abs(D[:, 1:, 0])))
    return ang.mean(axis=1)


def pool_draws(draws: Sequence[np.ndarray], *, n_per: int | None = None, rng=None) -> np.ndarray:
    """Pool per-replicate posterior draws in equal shares (the mixture :math:`\\frac1R\\sum_r p_r`).

    ``n_per`` draws are taken from each replicate without replacement (default: the smallest count).
    """
    rng = np.random.default_rng(rng)
    arrays = [np.asarray(d, dtype=float) for d in draws if d is not None]
    if not arrays:
        raise ValidationError("draws", "no replicate draws", "at least one (n, p) array")
    p = {a.shape[1] for a in arrays}
    if len(p) != 1:
        raise ValidationError("draws", [a.shape for a in arrays], "arrays with the same number of columns")
    n = min(a.shape[0] for a in arrays) if n_per is None else int(n_per)
    if n < 1 or n > min(a.shape[0] for a in arrays):
        raise ValidationError("n_per", n_per, f"an integer in [1, {min(a.shape[0] for a in arrays)}]")
    return np.concatenate([a[rng.choice(a.shape[0], n, replace=False)] for a in arrays])


def interval_width(draws: np.ndarray, *, level: float = 0.9) -> np.ndarray:
    """Width of the central ``level`` interval of each column."""
    check_interval("level", level, 0.0, 1.0, closed=(False, False))
    d = np.asarray(draws, dtype=float)
    a = (1 - level) / 2
    return np.quantile(d, 1 - a, axis=0) - np.quantile(d, a, axis=0)


def width_ratio(base: np.ndarray, pooled: np.ndarray, *, level: float = 0.9) -> np.ndarray:
    """Ratio of central-interval widths, pooled (with stereological uncertainty) over base (without)."""
    wb = interval_width(base, level=level)
    wp = interval_width(pooled, level=level)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(wb > 0, wp / wb, np.inf)
