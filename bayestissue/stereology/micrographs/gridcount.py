r"""Point-grid counting on systematically sampled sections (the Cavalieri/Delesse estimator).

A square grid of test points with spacing ``d`` and a uniform random offset in :math:`[0, d)^2`
(independent for every section) is laid on each sampled section; every point takes the label of
the pixel it falls in. Counts per section and component are the point-count table of the
stereology files, and the volume fraction of a component in the reference space (tissue without
cavities) is the ratio of sums (paper eq. 1),

.. math:: \widehat{V_V}(\mathrm{SMC}, \mathrm{ref}) = \frac{\sum_i Q_i}{\sum_i P_i},

with :math:`Q_i` the SMC points and :math:`P_i` the SMC + ECM points of section *i*. Sections are
sampled by SURS: every ``period``-th section from a uniform random start (paper Section 2.5.1:
every sixth of 72; Gundersen & Jensen 1987, J. Microsc. 147:229,
doi:10.1111/j.1365-2818.1987.tb02837.x).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bayestissue._validation import ValidationError, check_positive
from bayestissue.io.stereology_files import write_point_counts
from bayestissue.stereology.micrographs.phantom import CAVITY, ECM, SMC

__all__ = ["COMPONENTS", "GridCounts", "grid_points", "count_points", "write_grid_counts"]

#: Component names in the order of their codes (CAVITY, ECM, SMC).
COMPONENTS = ("cavity", "ecm", "smc")


@dataclass
class GridCounts:
    """Point counts of the sampled sections.

    Attributes
    ----------
    section : (m,) index of each sampled section in the stack.
    counts : (m, 3) int points per component, columns :data:`COMPONENTS` (cavity, ecm, smc).
    points : list of m (k_i, 2) arrays of the (row, col) pixel positions of the counted points.
    spacing_px : grid spacing in pixels.
    """

    section: np.ndarray
    counts: np.ndarray
    points: list
    spacing_px: float

    def column(self, name: str) -> np.ndarray:
        """Counts of one component (``cavity``, ``ecm`` or ``smc``)."""
        return self.counts[:, COMPONENTS.index(name)]

    def volume_fractions(self) -> dict[str, float]:
        """Ratio estimates: SMC and ECM of the tissue (eq. 1), cavity of all points."""
        tot = self.counts.sum(axis=0).astype(float)
        tissue = tot[ECM] + tot[SMC]
        if tissue == 0:
            raise ValidationError("point counts", "no point on tissue", "SMC or ECM points")
        return {
            "smc_tissue": tot[SMC] / tissue,
            "ecm_tissue": tot[ECM] / tissue,
            "cavity_total": tot[CAVITY] / tot.sum(),
        }


def grid_points(shape, spacing_px: float, *, valid=None, rng=None) -> np.ndarray:
    """Points of a square grid with a uniform random offset, inside ``shape`` (and ``valid``).

    Returns
    -------
    (k, 2) float ndarray of (row, col) positions in pixels.
    """
    rng = np.random.default_rng(rng)
    d = check_positive("grid_spacing", spacing_px)
    H, W = shape[:2]
    if d >= max(H, W):
        raise ValidationError("grid_spacing", spacing_px, f"less than the image size {H} x {W} px (in pixels)")
    off = rng.uniform(0, d, size=2)
    rr, cc = np.meshgrid(np.arange(off[0], H, d), np.arange(off[1], W, d), indexing="ij")
    pts = np.column_stack([rr.ravel(), cc.ravel()])
    if valid is not None:
        v = np.asarray(valid, dtype=bool)
        ij = np.minimum(np.floor(pts).astype(int), [H - 1, W - 1])
        pts = pts[v[ij[:, 0], ij[:, 1]]]
    return pts


def count_points(labels, *, spacing_px: float, sections=None, valid=None, rng=None) -> GridCounts:
    """Count the grid points on each sampled section by component.

    Parameters
    ----------
    labels : (n, H, W) segmented stack (CAVITY / ECM / SMC codes).
    spacing_px : grid spacing in pixels (grid spacing in um / pixel size).
    sections : indices of the sampled sections (default: all; a SURS sample comes from
        :func:`bayestissue.stereology.sections.surs_indices`).
    valid : optional (H, W) bool field (e.g. the registered common field).
    rng : seed or Generator (grid offsets).

    Returns
    -------
    GridCounts
    """
    rng = np.random.default_rng(rng)
    lab = np.asarray(labels)
    if lab.ndim != 3:
        raise ValidationError("labels", f"shape {lab.shape}", "a segmented stack (n, H, W)")
    idx = np.arange(lab.shape[0]) if sections is None else np.asarray(sections, dtype=int)
    if idx.size == 0 or idx.min() < 0 or idx.max() >= lab.shape[0]:
        raise ValidationError("sections", idx.tolist(), f"indices in [0, {lab.shape[0] - 1}]")
    counts, points = [], []
    for i in idx:
        pts = grid_points(lab.shape[1:], spacing_px, valid=valid, rng=rng)
        ij = np.floor(pts).astype(int)
        hits = lab[i][ij[:, 0], ij[:, 1]]
        counts.append(np.bincount(hits, minlength=3)[:3])
        points.append(pts)
    return GridCounts(section=idx, counts=np.array(counts, dtype=int), points=points, spacing_px=spacing_px)


def write_grid_counts(path: str | Path, grid: GridCounts, *, pixel_um: float, meta: dict | None = None) -> Path:
    """Write the counts as the stereology point-count table (``io.stereology_files`` format).

    Columns ``section, cavity_points, ecm_points, smc_points``; comment lines carry
    ``grid_spacing_um`` and ``excluded: cavity`` (the reference space is the tissue).
    """
    pixel_um = check_positive("pixel_um", pixel_um)
    m = {"grid_spacing_um": grid.spacing_px * pixel_um, "excluded": "cavity"}
    m.update(meta or {})
    return write_point_counts(path, grid.section, grid.counts, COMPONENTS, meta=m)
