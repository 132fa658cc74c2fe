r"""Rose of directions on an equal-area partition of the upper hemisphere, and the Lambert
projection.

The paper (Section 2.5.3) split the upper hemisphere into ``n`` parallels x ``n`` meridians of equal
area, summed the line length per cell and took the three cells with the largest length as the
preferential directions, for n = 8 and 15 (Figs. 6-8). Here band ``b`` (counted from the equator, b
= 0 ... n-1) holds :math:`b/n \le z < (b+1)/n`, i.e. :math:`\sin\epsilon \in [b/n, (b+1)/n)`;
equivalently the colatitude boundaries are :math:`\cos\theta_k = 1 - k/n` counted from the pole.
Meridian ``j`` holds azimuths :math:`[360 j/n, 360 (j+1)/n)`. All :math:`n^2` cells have area
:math:`2\pi/n^2`.

Lambert azimuthal equal-area projection about the pole z: :math:`r = 2\sin(\theta/2) = \sqrt{2(1 -
z)}`, so the band circles :math:`\cos\theta_k = 1 - k/n` are at :math:`r_k = \sqrt{2k/n}` and the
equator (elevation 0) is the rim :math:`r = \sqrt 2`.

A mode on the equator is split between two antipodal cells (its lines with z slightly below 0 are
flipped), and polar cells are thin slivers, so the top cells are refined by the length-weighted
principal axis of their lines (not the cell centre), and cells whose axis lies within ``merge_deg``
of an already chosen direction are merged into it (see :func:`preferential_directions`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bayestissue._validation import ValidationError, check_interval
from bayestissue.stereology.axial import axial_angle, orientation_tensor, principal_axes
from bayestissue.stereology.lines import azimuth_elevation, to_upper_hemisphere

__all__ = [
    "EqualAreaRose",
    "rose_of_directions",
    "cell_index",
    "lambert_project",
    "lambert_ring_radii",
    "preferential_directions",
    "directions_vs_n",
]


def _check_n(n, field: str = "n", meaning: str = "parallels = meridians") -> int:
    if isinstance(n, bool) or not float(n).is_integer() or int(n) < 1:
        raise ValidationError(field, n, f"an integer >= 1 ({meaning})")
    return int(n)


def cell_index(directions, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Band (from the equator) and meridian index of each axis in the n x n equal-area partition."""
    n = _check_n(n)
    u = to_upper_hemisphere(directions)
    band = np.minimum(np.floor(u[..., 2] * n).astype(int), n - 1)
    az, _ = azimuth_elevation(u)
    mer = np.minimum(np.floor(az / 360.0 * n).astype(int), n - 1)
    return band, mer


def lambert_project(directions, *, upper: bool = True) -> np.ndarray:
    r"""Lambert azimuthal equal-area coordinates (X, Y) = r (cos az, sin az), :math:`r = \sqrt{2(1 - z)}`.

    ``upper=True`` maps axes to the upper hemisphere first (disc of radius sqrt 2); ``upper=False``
    keeps the given signs, so vectors slightly below the equator land just outside the rim (the full
    sphere fills r <= 2), which keeps an equatorial axis and its cone on one side of the plot.
    """
    u = to_upper_hemisphere(directions) if upper else np.asarray(directions, dtype=float)
    u = u / np.linalg.norm(u, axis=-1, keepdims=True)
    r = np.sqrt(np.clip(2.0 * (1.0 - u[..., 2]), 0.0, None))
    az = np.arctan2(u[..., 1], u[..., 0])
    return np.stack([r * np.cos(az), r * np.sin(az)], axis=-1)


def lambert_ring_radii(n: int) -> np.ndarray:
    r"""Radii :math:`\sqrt{2k/n}`, k = 0 ... n, of the band boundaries in the Lambert projection."""
    n = _check_n(n)
    return np.sqrt(2.0 * np.arange(n + 1) / n)


@dataclass(frozen=True)
class EqualAreaRose:
    """Total line length per cell of the n x n equal-area partition.

    Attributes
    ----------
    n : parallels = meridians. lengths : (n, n) um, [band from the equator, meridian].
    band, meridian : (n_lines,) cell of each line. directions, weights : the lines' axes and
        lengths.
    """

    n: int
    lengths: np.ndarray
    band: np.ndarray
    meridian: np.ndarray
    directions: np.ndarray
    weights: np.ndarray

    @property
    def azimuth_edges(self) -> np.ndarray:
        """(n + 1,) meridian edges in degrees."""
        return np.linspace(0.0, 360.0, self.n + 1)

    def cell_centres(self) -> tuple[np.ndarray, np.ndarray]:
        """(n, n) azimuth and elevation (degrees) of the cell centres (equal-area midpoints)."""
        az = 360.0 * (np.arange(self.n) + 0.5) / self.n
        el = np.degrees(np.arcsin((np.arange(self.n) + 0.5) / self.n))
        return np.meshgrid(az, el)[0], np.meshgrid(az, el)[1]


def rose_of_directions(directions, weights=None, *, n: int) -> EqualAreaRose:
    """Sum line lengths (``weights``, um) per cell of the n x n equal-area partition (paper Section
    2.5.3)."""
    n = _check_n(n)
    d = to_upper_hemisphere(directions)
    w = np.ones(len(d)) if weights is None else np.asarray(weights, dtype=float)
    if w.shape != (len(d),) or np.any(w < 0) or not np.all(np.isfinite(w)):
        raise ValidationError("weights", f"shape {w.shape}", f"({len(d)},) finite lengths >= 0")
    band, mer = cell_index(d, n)
    L = np.zeros((n, n))
    np.add.at(L, (band, mer), w)
    return EqualAreaRose(n, L, band, mer, d, w)


def preferential_directions(rose: EqualAreaRose, *, k: int = 3, merge_deg: float = 20.0) -> list[dict]:
    """The top-``k`` cells of the rose as preferential directions, each refined by its lines'
    principal axis.

    Cells are visited by decreasing length; the direction of a cell is the principal axis of the
    length-weighted orientation tensor of its lines (bin-free within the cell). A cell whose axis
    lies within ``merge_deg`` (axial angle) of an already chosen direction is merged into it
    (lengths added, axis refitted): this joins the two antipodal halves of an equatorial mode and
    the within-mode neighbours of a spread-out family. The default 20 degrees is half the smallest
    angle between the paper's directions (v2 and v3 are 40 degrees apart), so distinct families are
    never merged. ``merge_deg = 0`` gives the paper's literal top-k cells, which for modes near the
    equator can repeat one family.

    Returns
    -------
    list of k dicts, ranked by merged length: ``rank``, ``band``, ``meridian`` (of the first cell),
    ``n_cells`` merged, ``length_um``, ``share`` (of the total length), ``cell_azimuth`` /
    ``cell_elevation`` (centre of the first cell, degrees), ``azimuth`` / ``elevation`` (degrees)
    and ``vector`` (3,) of the principal axis.
    """
    check_interval("merge_deg", merge_deg, 0.0, 90.0)
    k = _check_n(k, "k (--top)", "directions to report")
    n = rose.n
    order = np.argsort(-rose.lengths, axis=None, kind="stable")
    caz, cel = rose.cell_centres()
    chosen: list[dict] = []
    total = rose.weights.sum()
    for flat in order:
        b, m = divmod(int(flat), n)
        if rose.lengths[b, m] <= 0:
            break
        idx = np.flatnonzero((rose.band == b) & (rose.meridian == m))
        axis = principal_axes(orientation_tensor(rose.directions[idx], rose.weights[idx]))[1][:, 0]
        hit = [c for c in chosen if axial_angle(axis, c["vector"]) < merge_deg] if merge_deg > 0 else []
        if hit:
            c = hit[0]
            c["_idx"] = np.concatenate([c["_idx"], idx])
            c["n_cells"] += 1
        elif len(chosen) < k:
            c = {"rank": len(chosen) + 1, "band": b, "meridian": m, "n_cells": 1, "_idx": idx}
            c["cell_azimuth"], c["cell_elevation"] = float(caz[b, m]), float(cel[b, m])
            chosen.append(c)
        else:
            continue
        i = c["_idx"]
        c["vector"] = principal_axes(orientation_tensor(rose.directions[i], rose.weights[i]))[1][:, 0]
        c["length_um"] = float(rose.weights[i].sum())
    chosen.sort(key=lambda c: -c["length_um"])  # rank by the (merged) length
    for r, c in enumerate(chosen, start=1):
        c["rank"] = r
        c.pop("_idx")
        c["share"] = c["length_um"] / total
        c["vector"] = to_upper_hemisphere(c["vector"])
        az, el = azimuth_elevation(c["vector"])
        c["azimuth"], c["elevation"] = float(az), float(el)
    return chosen


def directions_vs_n(directions, weights=None, *, ns=range(6, 21), k: int = 3, merge_deg: float = 20.0):
    """Top-``k`` directions for each number of parallels/meridians in ``ns`` (how much the answer
    depends on n).

    Returns dict n -> list of dicts as :func:`preferential_directions`.
    """
    return {
        int(n): preferential_directions(rose_of_directions(directions, weights, n=n), k=k, merge_deg=merge_deg)
        for n in ns
    }
