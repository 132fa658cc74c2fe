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

import numpy as np

from bayestissue._validation import ValidationError, check_interval
from bayestissue.mechanics import TissueConfig
from bayestissue.workflows.cut import pool_draws, replicate_tissue

__all__ = ["replicate_tissues", "half_angles_deg", "pool_draws", "interval_width", "width_ratio"]


def replicate_tissues(replicates: dict, *, base: TissueConfig) -> list[TissueConfig]:
    """One :class:`~bayestissue.mechanics.TissueConfig` per replicate row.

    Parameters
    ----------
    replicates : dict from :func:`bayestissue.io.stereology_files.read_replicates` with ``directions``
        (n, 3, 3), ``phi_fibres`` (n, 3) and ``phi_matrix`` (n,).
    base : the laws, bulk modulus and slack strains are taken from it
        (:func:`bayestissue.workflows.cut.replicate_tissue`: the fractions renormalised to sum 1).
    """
    try:
        D = np.asarray(replicates["directions"], dtype=float)
        phi = np.asarray(replicates["phi_fibres"], dtype=float)
        pm = np.asarray(replicates["phi_matrix"], dtype=float)
    except KeyError as exc:
        raise ValidationError("replicates", sorted(replicates), "keys directions, phi_fibres, phi_matrix") from exc
    if D.ndim != 3 or D.shape[1:] != (3, 3) or phi.shape != (D.shape[0], 3) or pm.shape != (D.shape[0],):
        raise ValidationError("replicates", (D.shape, phi.shape, pm.shape), "(n,3,3), (n,3), (n,) arrays")
    return [replicate_tissue(base, replicates, r) for r in range(D.shape[0])]


def half_angles_deg(directions: np.ndarray) -> np.ndarray:
    """In-plane angle between the x axis and fibre families 2 and 3, averaged: ``(n,)`` degrees.

    ``directions`` (n, 3, 3) or (3, 3); the angle of :math:`v_k` is :math:`\\arctan(|v_y| / |v_x|)`.
    """
    D = np.asarray(directions, dtype=float)
    D = D[None] if D.ndim == 2 else D
    ang = np.degrees(np.arctan2(np.abs(D[:, 1:, 1]), np.abs(D[:, 1:, 0])))
    return ang.mean(axis=1)


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
