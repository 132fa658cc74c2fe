r"""Cells that fill the tissue without interpenetrating: a tessellation of the tissue by the cells' axes.

Real smooth muscle cells are packed and deform around each other; none passes through another. The phantom
(:func:`~bayestissue.stereology.micrographs.phantom.make_phantom`, ``packing="tessellation"``) builds them in three
steps:

1. **Axes.** Straight segments of length :math:`2a` (the cell length, 72 um by default) with Watson-drawn directions
   are placed by random sequential adsorption: a candidate is kept when its closest distance to every earlier axis is
   at least ``min_axis_gap_um`` (segment-to-segment distance, :func:`segment_distances`; only the axes binned near
   it are measured, :class:`AxisIndex`) and at most ``max_in_cavity`` of it runs in a sinus. Axes are added until
   their length in tissue :math:`\ell` is what spindles of the nominal shape need for the SMC fraction,
   :math:`\ell = V_V(\mathrm{SMC})\,V_\mathrm{tissue} / (2\pi b^2/3)` (the mean cross-section of a prolate
   spindle along its axis), so that the cells are as thick as the nominal spindles on average.
2. **Tessellation.** Every tissue voxel goes to the axis nearest to its centre (a Voronoi tessellation of the
   segments, found with a k-d tree on points every ``voxel/2`` along the axes); it belongs to that cell when it also
   lies inside the cell's spindle profile
   :math:`d < c\, b \sqrt{1 - (s/a)^2}`, with :math:`d` the distance to the axis, :math:`s` the position along it
   and :math:`b` the equatorial semi-axis (3 um). Where two spindles would overlap, the tessellation splits the
   contested voxels between them: the cells flatten against each other instead of passing through.
3. **Seams and fraction.** Wherever two cells share a face (6-neighbours) the voxel of the later one becomes collagen
   (a one-voxel endomysium), except the voxels holding an axis. (Seams at every edge and corner contact as well,
   26-neighbours, take so much of the tissue that 58.9 % SMC is out of reach once the cells are as thin as the
   spindles: 0.534 at most with 1108 axes, against 0.683 with face seams, measured while preparing this module.)
   The width factor :math:`c` is found by bisection so that the SMC voxels are ``smc_fraction`` of the tissue; if
   even wide cells cannot reach it, the phantom refuses the fraction.

Every voxel a cell's axis passes through is that cell's (forced, :func:`traversed_voxels`; no other axis is nearer
than ``min_axis_gap_um`` - 0.87 voxel, and seams spare these voxels), so each axis lies inside its own voxels
wherever it is in tissue: the full axis is both the truth and what an image can show (sinus crossings excepted,
where no cell is).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

__all__ = ["AxisIndex", "carve_seams", "segment_distances", "place_axes", "tessellate", "traversed_voxels"]


def segment_distances(p0, d0, P1, D1) -> np.ndarray:
    """Closest distance between the segment ``p0 + t d0`` (t in [0, 1]) and each segment ``P1[k] + u D1[k]``.

    The clamped closed form of the 2x2 least-squares problem for (t, u) (Lumelsky 1985, Inf. Process. Lett.
    21:55-61), vectorised over ``k``; parallel segments take t = 0 and clamp u.
    """
    P1, D1 = np.atleast_2d(P1), np.atleast_2d(D1)
    r = p0[None, :] - P1
    a = float(d0 @ d0)
    e = np.einsum("ij,ij->i", D1, D1)
    b = D1 @ d0
    c = r @ d0
    f = np.einsum("ij,ij->i", D1, r)
    denom = a * e - b * b
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(denom > 1e-12 * a * e, (b * f - c * e) / denom, 0.0)
    t = np.clip(t, 0.0, 1.0)
    u = np.clip((b * t + f) / e, 0.0, 1.0)
    t = np.clip((b * u - c) / a, 0.0, 1.0)
    closest = (p0[None, :] + t[:, None] * d0[None, :]) - (P1 + u[:, None] * D1)
    return np.linalg.norm(closest, axis=1)


class AxisIndex:
    """The placed axes (starts, vectors, mixture components), binned on a grid of ``cell`` um: each axis is listed in
    every bin within ``cell`` of a point sampled every ``cell / 2`` along it, so that the axes a candidate can come
    within ``gap <= cell / 2`` of are among those listed in the bins of its own sample points."""

    def __init__(self, cell: float):
        self.cell, self.bins, self.n = cell, {}, 0
        self._p, self._d = np.empty((64, 3)), np.empty((64, 3))
        self.components = []
        r = np.arange(-1, 2)
        self._near = np.stack(np.meshgrid(r, r, r, indexing="ij"), axis=-1).reshape(-1, 3)

    @property
    def starts(self) -> np.ndarray:
        return self._p[: self.n]

    @property
    def vectors(self) -> np.ndarray:
        return self._d[: self.n]

    def _keys(self, p0, d) -> np.ndarray:
        m = max(2, int(np.ceil(2 * np.linalg.norm(d) / self.cell)) + 1)
        pts = p0 + np.linspace(0.0, 1.0, m)[:, None] * d
        return np.floor(pts / self.cell).astype(np.int64)

    def add(self, p0, d, component: int) -> None:
        k = self.n
        self.components.append(component)
        if k == len(self._p):
            self._p, self._d = np.concatenate([self._p, self._p]), np.concatenate([self._d, self._d])
        self._p[k], self._d[k] = p0, d
        self.n += 1
        keys = np.unique((self._keys(p0, d)[:, None, :] + self._near[None]).reshape(-1, 3), axis=0)
        for key in map(tuple, keys):
            self.bins.setdefault(key, []).append(k)

    def nearest(self, p0, d) -> float:
        """Closest distance from the segment to the listed axes (inf if none is listed near it)."""
        ids = {k for key in map(tuple, self._keys(p0, d)) for k in self.bins.get(key, ())}
        if not ids:
            return np.inf
        ids = np.fromiter(ids, dtype=int)
        return float(segment_distances(p0, d, self._p[ids], self._d[ids]).min())


def place_axes(index, n, draw, upper, a, gap, in_cavity, max_in_cavity, rng, *, max_attempts=200_000) -> int:
    """Random sequential adsorption of ``n`` more axes into ``index`` (an :class:`AxisIndex` with ``cell >= 2 gap``):
    centre uniform in the block dilated by ``a``, direction and component from ``draw(rng)``, kept when at least
    ``gap`` from every other axis (only those binned near it are measured) and at most ``max_in_cavity`` of it in a
    sinus (``in_cavity(p0, p1)``). Returns how many were placed: fewer than ``n`` when the attempts ran out."""
    placed = attempts = 0
    while placed < n and attempts < max_attempts:
        attempts += 1
        centre = rng.uniform(size=3) * (upper + 2 * a) - a
        axis, comp = draw(rng)
        p0, d = centre - a * axis, 2 * a * axis
        if in_cavity(p0, p0 + d) > max_in_cavity or index.nearest(p0, d) < gap:
            continue
        index.add(p0, d, comp)
        placed += 1
    return placed


def traversed_voxels(p0, d, shape, voxel) -> np.ndarray:
    """``(m, 3)`` indices (x, y, z) of every voxel the segment ``p0 -> p0 + d`` passes through inside the block:
    the segment is cut at each crossing of a voxel face and each piece's midpoint names its voxel (exact, unlike
    sampling at a step, which misses a voxel whose corner the segment only grazes)."""
    ts = [np.array([0.0, 1.0])]
    for ax in range(3):
        if d[ax] != 0:
            lo, hi = sorted((p0[ax] / voxel, (p0[ax] + d[ax]) / voxel))
            planes = np.arange(np.ceil(lo), np.floor(hi) + 1) * voxel
            ts.append((planes - p0[ax]) / d[ax])
    t = np.unique(np.clip(np.concatenate(ts), 0.0, 1.0))
    mid = p0 + (0.5 * (t[1:] + t[:-1]))[:, None] * d
    ijk = np.floor(mid / voxel).astype(int)
    inside = np.all((ijk >= 0) & (ijk < np.array(shape[::-1])), axis=1)
    return ijk[inside]


def _pair_views(shape, offset) -> tuple[tuple[slice, ...], tuple[slice, ...]]:
    """Index tuples ``(first, second)`` such that ``x[second]`` is ``x[first]`` shifted by ``offset`` (z, y, x)."""
    first, second = [], []
    for n, d in zip(shape, offset, strict=True):
        first.append(slice(max(0, -d), n - max(0, d)))
        second.append(slice(max(0, d), n - max(0, -d)))
    return tuple(first), tuple(second)


def carve_seams(cell_ids: np.ndarray, protected: np.ndarray | None = None) -> int:
    """Wherever two different cells share a face (6-neighbours), the voxel of the later cell (higher id) becomes
    free (a one-voxel endomysium), unless ``protected`` (the voxels holding an axis). Returns the voxels freed."""
    seam = np.zeros(cell_ids.shape, dtype=bool)
    for offset in ((1, 0, 0), (0, 1, 0), (0, 0, 1)):  # each neighbour pair once
        first, second = _pair_views(cell_ids.shape, offset)
        a, b = cell_ids[first], cell_ids[second]
        touch = (a > 0) & (b > 0) & (a != b)
        seam[first] |= touch & (a > b)
        seam[second] |= touch & (b > a)
    if protected is not None:
        seam &= ~protected
    cell_ids[seam] = 0
    return int(seam.sum())


def tessellate(starts, vectors, b, tissue, voxel, target, *, tol=0.002):
    """Cell ids of the tissue voxels for the axes ``starts + t vectors`` (module docstring, steps 2-3).

    Parameters
    ----------
    starts, vectors : (n, 3) axis segments (x, y, z) in um.
    b : nominal equatorial semi-axis (um). tissue : (nz, ny, nx) bool, the non-sinus voxels. voxel : edge (um).
    target : SMC voxels wanted, as a fraction of the tissue voxels.

    Returns
    -------
    cell_ids (int32, 0 = not a cell), the width factor c, and the SMC fraction of the tissue reached (None for the
    last two and the largest reachable fraction in place of the ids if ``target`` cannot be reached).
    """
    shape = tissue.shape
    n = len(starts)
    lengths = np.linalg.norm(vectors, axis=1)
    step = voxel / 2
    pts, owner, along = [], [], []
    for k in range(n):
        m = max(2, int(np.ceil(lengths[k] / step)) + 1)
        t = np.linspace(0.0, 1.0, m)
        pts.append(starts[k] + t[:, None] * vectors[k])
        owner.append(np.full(m, k))
        along.append(2 * t - 1)  # s / a in [-1, 1]
    pts, owner, along = np.concatenate(pts), np.concatenate(owner), np.concatenate(along)
    tree = cKDTree(pts)
    iz, iy, ix = np.nonzero(tissue)
    centres = (np.column_stack([ix, iy, iz]) + 0.5) * voxel
    dist, nearest = tree.query(centres, k=1)
    cell_of = owner[nearest]
    profile = b * np.sqrt(np.clip(1.0 - along[nearest] ** 2, 0.0, None))
    # every voxel an axis passes through is that cell's whatever its width
    protected = np.zeros(shape, dtype=bool)
    axis_ids = np.zeros(shape, dtype=np.int32)
    for k in range(n):
        ijk = traversed_voxels(starts[k], vectors[k], shape, voxel)
        protected[ijk[:, 2], ijk[:, 1], ijk[:, 0]] = True
        axis_ids[ijk[:, 2], ijk[:, 1], ijk[:, 0]] = k + 1
    protected &= tissue
    n_tissue = int(tissue.sum())

    def build(c):
        ids = np.zeros(shape, dtype=np.int32)
        keep = dist < c * profile
        ids[iz[keep], iy[keep], ix[keep]] = cell_of[keep] + 1
        ids[protected] = axis_ids[protected]
        carve_seams(ids, protected)
        return ids, np.count_nonzero(ids) / n_tissue

    lo, hi = 0.0, 4.0
    ids, frac = build(hi)
    if frac < target:
        return None, None, frac
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        ids_mid, f_mid = build(mid)
        if f_mid < target:
            lo = mid
        else:
            hi, ids, frac = mid, ids_mid, f_mid
        if frac - target < tol and frac >= target:
            break
    return ids, hi, frac
