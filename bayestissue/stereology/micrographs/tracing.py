r"""Tracing smooth muscle cells through a registered stack: link, split, principal axes.

1. The SMC mask of the registered stack is a 3-D image with anisotropic voxels
   ``spacing_um = (section thickness, pixel, pixel)``. Cells are traced on the profile cores:
   every section's mask eroded by ``core_px`` pixels (4-neighbour). Where neighbouring cells
   touch or their blurred rims merge in the segmentation (at 1 um pixels a cleft or endomysium
   below the resolution), the merged profile would be traced as one cell along the mean of the
   two directions; the cores keep them apart where they touch over a short stretch (crossing
   cells, tapered ends, blur bridging a cleft of about a pixel), not where they lie side by side
   along their length. The erosion shortens the tapered tips, which are given back (step 5).
2. Cells are separated in one of two ways.

   ``"profiles"`` (default): the 2-D profiles of every section are linked to those of the next
   section when they overlap (after growing by ``link_reach_um``), are each other's best match
   and, when both are elongated, have in-plane axes within ``max_angle_deg`` (the paper's manual
   tracing followed the centres of gravity of each cell from micrograph to micrograph, Section
   2.5.3). Profiles of different cells stacked in neighbouring sections are not merged as they
   would be by 3-D connectivity when the section thickness is close to the cell diameter.

   ``"watershed"``: 3-D watershed of the negated Euclidean distance transform (anisotropic
   spacing) from its h-maxima (Soille 2003, Morphological Image Analysis, Ch. 6 and 9), which
   splits touching cells at their necks.

   Each linked group / watershed region is one traced cell (one ``cell_id``).
3. A traced cell is approximated by straight pieces: a region longer than ``piece_length_um`` is
   cut by k-means on its voxel coordinates into about ``extent / piece_length_um`` pieces. Each
   piece becomes a segment through its centroid :math:`\bar{\mathbf x}` along its principal
   axis :math:`\mathbf e_1` (top eigenvector of the voxel covariance), spanning the extent of
   the voxel centres along :math:`\mathbf e_1` plus one voxel projected on it,

   .. math:: \ell = \max_v \mathbf e_1\cdot\mathbf x_v - \min_v \mathbf e_1\cdot\mathbf x_v
             + \sum_k |e_{1k}|\, s_k .

4. Merged cells (``length_from_volume``): a region that is not line-like (linearity
   :math:`\sqrt{\lambda_2/\lambda_1} \ge` ``max_linearity``: crossing or side-by-side cells that
   could not be separated) gets the length its volume implies,
   :math:`L = V / \bar A`, with :math:`\bar A` the median volume / length of the line-like regions
   of the same stack (the mean cross-section of one cell, measured; needs >= 5 such regions). Its
   pieces (about :math:`L / ` ``piece_length_um`` of them, by k-means) keep their own directions
   and are scaled about their midpoints to add up to :math:`L`.

5. Tips (``core_px > 0``): every pixel of the profiles before erosion goes to the nearest core
   of its section (within ``core_px + 3`` pixels, :func:`skimage.segmentation.expand_labels`);
   the two outermost end points of a traced cell move outward along its principal axis
   :math:`\mathbf e_1` to where these pixels end. A 72 x 6 um spindle lying in a section plane
   is traced 64 um long from its cores alone and 70 um with its tips, as from its profile.

The pieces form the line system of the paper (Section 2.5.2: lines through the centres of gravity
of the cells), from which :math:`L_V = \sum \ell / V` (eq. 2) and the rose of directions follow.
Coordinates are ``(x, y, z) = (column, row, section)`` centres in um.

6. End correction (``end_correction=True``; off by default, see below): a cell lying in the section
   plane is seen only where a plane cuts it, and a plane at distance :math:`h` from its axis shows
   a profile shortened by :math:`s = \sqrt{1 - h^2/b^2}` (b the cell's radius). With planes every
   :math:`T \le 2b` and :math:`h \sim U[0, T/2]` the traced length is :math:`2a\,E[s]`: 0.867 of
   it for T = 5 um, b = 3 um (0.85 measured on voxel spindles). For any elevation of the axis the
   expected deficit per tip :math:`\Delta(a, b, \varphi, T)` follows from the section of a
   prolate spheroid (:func:`tip_deficit`), and the two outermost ends of every line-like cell are
   moved out by it (:func:`end_corrected_length`). The radius b is measured, not assumed: the
   median over the line-like cells of :math:`\sqrt{5\lambda_\perp}`, :math:`\lambda_\perp` the
   variance of a cell's full-profile voxels across its axis in the section plane
   (``radius_um`` overrides it). The cross-section :math:`\bar A` of step 4 is then taken per
   unit of the corrected length. On an isolated in-plane 72 x 6 um spindle (5 um planes, 20
   offsets) the traced length goes from 0.85 to 1.02 of the truth (core_px=0). In the pipeline it
   does not help consistently (default phantom, seeds 1-6: L_V errors -16, -22, -29, -27, -39, -7 %
   without, +22, +4, -10, -1, -24, +32 % with; the separable phantom -19, -20, -25, -12, -23, -7 %
   without, +11, +4, -1, +23, +4, +28 % with): most of the length there comes from the volume rule
   of step 4 with :math:`\bar A` measured on cell fragments about 16 um long (cut by sinuses, the
   field edge or the linking), whose cut ends are not tapered tips but are corrected as tips, and
   the seed-to-seed spread of :math:`\bar A` dominates (figures/micrographs_validation.md).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
from scipy import ndimage
from scipy.cluster.vq import kmeans2
from skimage.morphology import h_maxima
from skimage.segmentation import expand_labels, watershed

from bayestissue._validation import ValidationError, check_positive
from bayestissue.stereology.micrographs.tip_correction import _in_plane_radius, end_corrected_length

__all__ = ["TracedCells", "trace_cells", "fit_segment"]


@dataclass
class TracedCells:
    """Result of :func:`trace_cells`.

    Attributes
    ----------
    labels : (n, H, W) int32 traced regions (0 = background; the profile cores when ``core_px >
        0``), ids = cell ids.
    segments_um : (k, 2, 3) straight pieces, end points (x, y, z) in um.
    cell_id : (k,) traced cell of each piece.
    spacing_um : (dz, dy, dx) voxel size in um.
    volume_um3 : probed volume (valid field area x number of sections x thickness).
    """

    labels: np.ndarray
    segments_um: np.ndarray
    cell_id: np.ndarray
    spacing_um: tuple[float, float, float]
    volume_um3: float

    @property
    def lengths_um(self) -> np.ndarray:
        """Length of every piece (um)."""
        return np.linalg.norm(self.segments_um[:, 1] - self.segments_um[:, 0], axis=1)

    @property
    def directions(self) -> np.ndarray:
        """Unit axis of every piece, (k, 3) (x, y, z)."""
        d = self.segments_um[:, 1] - self.segments_um[:, 0]
        n = np.linalg.norm(d, axis=1, keepdims=True)
        return d / np.where(n > 0, n, 1.0)

    def length_density(self) -> float:
        r""":math:`L_V = \sum \ell / V` in um^-2 (paper eq. 2)."""
        return float(self.lengths_um.sum() / self.volume_um3)


def fit_segment(points_um: np.ndarray, spacing_um) -> np.ndarray:
    """Straight segment through a voxel cloud along its principal axis (module docstring).

    Parameters
    ----------
    points_um : (m, 3) voxel centres (x, y, z) in um; spacing_um : (dx, dy, dz) voxel size.

    Returns
    -------
    (2, 3) end points in um.
    """
    p = np.asarray(points_um, dtype=float)
    c = p.mean(axis=0)
    if len(p) < 2:
        e1 = np.array([1.0, 0.0, 0.0])
    else:
        w, V = np.linalg.eigh(np.cov((p - c).T))
        e1 = V[:, -1]
    t = (p - c) @ e1
    pad = 0.5 * float(np.abs(e1) @ np.asarray(spacing_um, dtype=float))
    return np.array([c + (t.min() - pad) * e1, c + (t.max() + pad) * e1])


def _profile_stats(lab2d: np.ndarray, n: int):
    """Area, centroid (row, col), axis angle (rad) and elongation of each 2-D profile 1..n."""
    idx = np.arange(1, n + 1)
    area = ndimage.sum_labels(np.ones_like(lab2d), lab2d, idx)
    rr, cc = np.indices(lab2d.shape)
    mr = ndimage.mean(rr, lab2d, idx)
    mc = ndimage.mean(cc, lab2d, idx)
    srr = ndimage.mean(rr * rr, lab2d, idx) - mr**2
    scc = ndimage.mean(cc * cc, lab2d, idx) - mc**2
    src = ndimage.mean(rr * cc, lab2d, idx) - mr * mc
    theta = 0.5 * np.arctan2(2 * src, scc - srr)  # angle of the long axis from the column axis
    tr, det = srr + scc, srr * scc - src**2
    disc = np.sqrt(np.maximum(tr**2 / 4 - det, 0))
    l1, l2 = tr / 2 + disc, np.maximum(tr / 2 - disc, 1e-9)
    return area, theta, np.sqrt(l1 / l2)


def _link_profiles(
    mask: np.ndarray,
    min_overlap: float,
    max_angle_deg: float,
    elongated: float,
    reach_px: int,
):
    """Label 2-D profiles per section and link them across sections into 3-D cells.

    Profiles a (section i) and b (section i + 1) are linked when they are each other's best
    partner by overlap / smaller area (both dilated by ``reach_px``: thin cell ends and oblique
    cells shift between sections), that ratio is at least ``min_overlap``, and, if both are
    elongated (axis ratio > ``elongated``), their in-plane axes differ by less than
    ``max_angle_deg``. Linked profiles form one cell (union-find).
    """
    n_sec = mask.shape[0]
    labs, grown, offsets, stats = [], [], [0], []
    disk = ndimage.iterate_structure(ndimage.generate_binary_structure(2, 1), max(reach_px, 1))
    for i in range(n_sec):
        lab, n = ndimage.label(mask[i])
        labs.append(lab)
        stats.append(_profile_stats(lab, n))
        offsets.append(offsets[-1] + n)
        if reach_px > 0:  # grey dilation grows every profile (ties go to the larger label)
            lab = ndimage.grey_dilation(lab, footprint=disk)
        grown.append(lab)
    parent = np.arange(offsets[-1] + 1)

    def find(x):
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    max_angle = np.deg2rad(max_angle_deg)
    for i in range(n_sec - 1):
        a, b = grown[i], grown[i + 1]
        both = (a > 0) & (b > 0)
        if not both.any():
            continue
        pairs, counts = np.unique(np.stack([a[both], b[both]]), axis=1, return_counts=True)
        area_a, th_a, el_a = stats[i]
        area_b, th_b, el_b = stats[i + 1]
        area_a = np.bincount(a.ravel(), minlength=len(area_a) + 1)[1:].astype(float)
        area_b = np.bincount(b.ravel(), minlength=len(area_b) + 1)[1:].astype(float)
        score = counts / np.minimum(area_a[pairs[0] - 1], area_b[pairs[1] - 1])
        dth = np.abs(th_a[pairs[0] - 1] - th_b[pairs[1] - 1]) % np.pi
        dth = np.minimum(dth, np.pi - dth)
        oriented = (el_a[pairs[0] - 1] > elongated) & (el_b[pairs[1] - 1] > elongated)
        ok = (score >= min_overlap) & (~oriented | (dth <= max_angle))
        best_a = np.full(len(area_a) + 1, -1.0)
        best_b = np.full(len(area_b) + 1, -1.0)
        np.maximum.at(best_a, pairs[0], np.where(ok, score, -1.0))
        np.maximum.at(best_b, pairs[1], np.where(ok, score, -1.0))
        for k in np.flatnonzero(ok):
            pa, pb = pairs[0, k], pairs[1, k]
            if score[k] == best_a[pa] and score[k] == best_b[pb]:
                ra, rb = find(offsets[i] + pa), find(offsets[i + 1] + pb)
                if ra != rb:
                    parent[max(ra, rb)] = min(ra, rb)
    roots = np.array([find(x) for x in range(len(parent))])
    _, cell = np.unique(roots, return_inverse=True)
    out = np.zeros(mask.shape, dtype=np.int32)
    for i in range(n_sec):
        lab = labs[i]
        out[i] = np.where(lab > 0, cell[offsets[i] + lab], 0)
    return out


def _pieces(pts: np.ndarray, dxyz, piece_length_um: float, rng, k: int | None = None):
    """Cut a voxel cloud into ``k`` straight pieces (default: about ``piece_length_um`` long)."""
    seg = fit_segment(pts, dxyz)
    length = float(np.linalg.norm(seg[1] - seg[0]))
    if k is None:
        k = int(np.ceil(length / piece_length_um))
    if k <= 1 or len(pts) < 4 * k:
        return [seg]
    t = (pts - pts.mean(axis=0)) @ (seg[1] - seg[0]) / length
    qs = np.quantile(t, (np.arange(k) + 0.5) / k)
    init = pts[[int(np.argmin(np.abs(t - q))) for q in qs]]
    with warnings.catch_warnings():  # an empty cluster is dropped below
        warnings.filterwarnings("ignore", "One of the clusters is empty", UserWarning)
        _, part = kmeans2(pts, init, minit="matrix", iter=20, seed=rng)
    return [fit_segment(pts[part == j], dxyz) for j in range(k) if (part == j).sum() >= 2]


#: 4-neighbour structuring element in the section plane of a (section, row, column) stack.
_IN_PLANE = ndimage.generate_binary_structure(3, 1) & np.array([0, 1, 0], bool)[:, None, None]


def _extend_ends(pieces, core_pts, full_pts):
    r"""Move the outermost end points of a cell's pieces outward along the cell's principal axis
    :math:`\mathbf e_1` (of ``core_pts``) to where ``full_pts`` (the profiles before erosion,
    nearest to this cell) end: the tips the erosion took."""
    seg = fit_segment(core_pts, (1.0, 1.0, 1.0))
    e1 = (seg[1] - seg[0]) / max(float(np.linalg.norm(seg[1] - seg[0])), 1e-12)
    tc, tf = core_pts @ e1, full_pts @ e1
    lo_ext, hi_ext = max(0.0, tc.min() - tf.min()), max(0.0, tf.max() - tc.max())
    ends = np.array(pieces).reshape(-1, 3)
    t = ends @ e1
    lo, hi = int(np.argmin(t)), int(np.argmax(t))
    ends[lo] -= lo_ext * e1
    ends[hi] += hi_ext * e1
    return list(ends.reshape(-1, 2, 3))


def _correct_ends(pieces, core_pts, radius_um: float, thickness_um: float):
    r"""Move the outermost end points of a cell's pieces outward along its principal axis
    :math:`\mathbf e_1` by the expected tip deficit :math:`\Delta` each (:func:`tip_deficit`,
    :func:`end_corrected_length`), so that the pieces add up to the end-corrected length."""
    seg = fit_segment(core_pts, (1.0, 1.0, 1.0))
    e1 = (seg[1] - seg[0]) / max(float(np.linalg.norm(seg[1] - seg[0])), 1e-12)
    ell = _length(pieces)
    half = 0.5 * (end_corrected_length(ell, radius_um, e1[2], thickness_um) - ell)
    ends = np.array(pieces).reshape(-1, 3)
    t = ends @ e1
    ends[int(np.argmin(t))] -= half * e1
    ends[int(np.argmax(t))] += half * e1
    return list(ends.reshape(-1, 2, 3))


def _length(pieces) -> float:
    """Total length of a cell's straight pieces (each a (2, 3) array of end points, um)."""
    return sum(float(np.linalg.norm(q[1] - q[0])) for q in pieces)


def _points(labels, sl, lab_id, dxyz) -> np.ndarray:
    """Voxel centres (x, y, z) in um of region ``lab_id`` (bounding box ``sl``)."""
    zz, yy, xx = np.nonzero(labels[sl] == lab_id)
    return np.column_stack(
        [
            (xx + sl[2].start + 0.5) * dxyz[0],
            (yy + sl[1].start + 0.5) * dxyz[1],
            (zz + sl[0].start + 0.5) * dxyz[2],
        ]
    )


def _linearity(pts: np.ndarray) -> float:
    """sqrt(lambda_2 / lambda_1) of the point covariance: 0 for a line, 1 for a disc or ball."""
    if len(pts) < 3:
        return 0.0
    w = np.linalg.eigvalsh(np.cov(pts.T))
    return float(np.sqrt(max(w[1], 0.0) / max(w[2], 1e-12)))


def trace_cells(
    smc_mask,
    *,
    spacing_um,
    valid=None,
    method: str = "profiles",
    min_overlap: float = 0.2,
    max_angle_deg: float = 25.0,
    elongated: float = 2.0,
    link_reach_um: float = 2.0,
    core_px: int = 1,
    length_from_volume: bool = True,
    max_linearity: float = 0.4,
    h_um: float = 0.75,
    min_volume_um3: float = 20.0,
    piece_length_um: float = 15.0,
    end_correction: bool = False,
    radius_um: float | None = None,
    rng=0,
) -> TracedCells:
    """Label, split and fit the muscle cells of a registered, segmented stack.

    Parameters
    ----------
    smc_mask : (n, H, W) bool, SMC pixels of the registered sections.
    spacing_um : (section thickness, pixel, pixel) in um.
    valid : optional (H, W) bool common field (outside it nothing is traced).
    core_px : in-plane erosion of every section's SMC mask before tracing (module docstring,
        step 1); 0 traces the segmented profiles as they are. On the validation phantoms (1 um
        pixels) 1 pixel cut the runs with a direction error above 10 degrees from 4 to 2 of 16
        (seeds 1-8 of the default and the separable phantom, 80 x 120 x 120 um); it costs
        length where grazed profiles are thinner than 3 pixels (an isolated in-plane cell: 81 %
        of its length traced, 85 % without the erosion).
    h_um : dynamic of the h-maxima markers in um: distance maxima less than ``h_um`` above their
        surroundings do not start a cell (suppresses over-splitting along a cell).
    min_volume_um3 : smaller regions are dropped (noise, cell tips cut by the field edge); measured
        on the cores when ``core_px > 0`` (20 um^3 of cores is about 40 um^3 of profile).
    piece_length_um : longest straight piece; longer or branched regions are cut (module
        docstring). Short pieces follow branched (merged) regions and keep more length; pieces
        shorter than about 3 section thicknesses lose the elevation of oblique cells.
    end_correction : move the ends of every line-like cell out by the expected grazing deficit
        (module docstring, step 6); radius_um : cell radius for it (default: measured).
    length_from_volume, max_linearity : length of merged (non line-like) regions from their
        volume (module docstring, step 4); False keeps the extent of their k-means pieces.
    rng : seed or Generator for the k-means cuts.

    Returns
    -------
    TracedCells

    Raises
    ------
    ValidationError for a non-3-D mask, bad spacing or an empty SMC mask.
    """
    rng = np.random.default_rng(rng)
    mask = np.asarray(smc_mask, dtype=bool)
    if mask.ndim != 3:
        raise ValidationError("smc_mask", f"shape {mask.shape}", "a 3-D stack (n, H, W)")
    sp = np.asarray(spacing_um, dtype=float)
    if sp.shape != (3,) or not np.all(np.isfinite(sp)) or np.any(sp <= 0):
        raise ValidationError("spacing_um", spacing_um, "three positive sizes (dz, dy, dx) in um")
    h_um = check_positive("h_um", h_um)
    piece_length_um = check_positive("piece_length_um", piece_length_um)
    if valid is not None:
        v = np.asarray(valid, dtype=bool)
        mask = mask & v[None]
        area = float(v.sum()) * sp[1] * sp[2]
    else:
        area = float(mask.shape[1] * mask.shape[2]) * sp[1] * sp[2]
    if not mask.any():
        raise ValidationError("smc_mask", "no SMC voxel", "a segmentation with smooth muscle", "nothing to trace")
    volume = area * mask.shape[0] * sp[0]
    core_px = int(core_px)
    if core_px < 0:
        raise ValidationError("core_px", core_px, "a non-negative number of pixels")
    full = mask
    if core_px > 0:
        mask = ndimage.binary_erosion(mask, structure=_IN_PLANE, iterations=core_px)
        if not mask.any():
            raise ValidationError(
                "smc_mask", f"no SMC pixel left after eroding by core_px={core_px}",
                "profiles wider than 2 core_px + 1 pixels", "lower core_px",
            )  # fmt: skip

    if method == "profiles":
        reach = int(round(link_reach_um / sp[1])) + core_px  # the cores are core_px smaller
        labels = _link_profiles(mask, min_overlap, max_angle_deg, elongated, reach)
    elif method == "watershed":
        dist = ndimage.distance_transform_edt(mask, sampling=sp)
        markers, _ = ndimage.label(h_maxima(dist, h_um))
        labels = watershed(-dist, markers, mask=mask).astype(np.int32)
    else:
        raise ValidationError("method", method, "'profiles' or 'watershed'")

    dxyz = sp[::-1]  # (dx, dy, dz)
    if core_px > 0:  # every full-profile pixel to its nearest core (within the erosion + 3 px)
        grown = np.stack(
            [np.where(f, expand_labels(lab, distance=core_px + 3), 0) for lab, f in zip(labels, full, strict=True)]
        )
        grown_objects = ndimage.find_objects(grown)
    min_vox = min_volume_um3 / float(np.prod(sp))
    segments, ids = [], []
    objects = ndimage.find_objects(labels)
    keep = np.zeros(len(objects) + 1, dtype=bool)

    # a region's core and full-profile voxel centres are made when needed: kept for every region at once they would
    # be a float64 copy of the SMC voxels' coordinates, twice (the largest memory of the pipeline)
    def core(lab_id):
        return _points(labels, objects[lab_id - 1], lab_id, dxyz)

    def full(lab_id, pts=None):
        if core_px == 0:
            return core(lab_id) if pts is None else pts
        return _points(grown, grown_objects[lab_id - 1], lab_id, dxyz)

    def points(lab_id):
        pts = core(lab_id)
        return pts, full(lab_id, pts)

    regions = []  # (id, voxel count, extent, linearity, axis) of each region kept
    for lab_id, sl in enumerate(objects, start=1):
        if sl is None:
            continue
        pts = _points(labels, sl, lab_id, dxyz)
        if len(pts) < min_vox:
            continue
        keep[lab_id] = True
        seg = fit_segment(pts, dxyz)
        L = float(np.linalg.norm(seg[1] - seg[0]))
        regions.append((lab_id, len(pts), L, _linearity(pts), (seg[1] - seg[0]) / max(L, 1e-12)))
    vox_um3 = float(np.prod(sp))
    # cell radius, measured on the full profiles of the line-like regions (step 6)
    radius = radius_um
    if end_correction and radius is None:
        bs = [_in_plane_radius(full(lab_id), e1) for lab_id, _, _, lin, e1 in regions if lin < max_linearity]
        bs = [b for b in bs if np.isfinite(b)]
        radius = float(np.median(bs)) if bs else None
    corrected = bool(end_correction and radius is not None)

    def line_pieces(pts, full_pts):
        """Straight pieces of one cell, tips restored from the full profile, ends corrected (step 6)."""
        pieces = _pieces(pts, dxyz, piece_length_um, rng)
        if core_px > 0:
            pieces = _extend_ends(pieces, pts, full_pts)
        return _correct_ends(pieces, pts, radius, sp[0]) if corrected else pieces

    traced = {lab_id: line_pieces(*points(lab_id)) for lab_id, _, _, lin, _ in regions if lin < max_linearity}
    # cross-section of a single cell, measured on the simple (line-like) regions
    # with the end correction: per unit of the corrected length (tips and grazed ends included),
    # so that volume / area is a whole length; without it: per unit of the cores' extent
    simple = [
        n_vox * vox_um3 / (_length(traced[lab_id]) if corrected else L)
        for lab_id, n_vox, L, *_ in regions
        if lab_id in traced
    ]
    area = float(np.median(simple)) if length_from_volume and len(simple) >= 5 else None
    for lab_id, n_vox, L, _, _ in regions:
        if lab_id in traced:
            pieces = traced[lab_id]
        elif area is None:
            pieces = line_pieces(*points(lab_id))
        else:  # merged cells: length = volume / cross-section, spread over the pieces
            pts, full_pts = points(lab_id)
            L_est = max(n_vox * vox_um3 / area, L)
            k = max(int(np.ceil(L / piece_length_um)), int(round(L_est / piece_length_um)))
            pieces = _pieces(pts, dxyz, piece_length_um, rng, k)
            scale = L_est / _length(pieces)
            mids = [q.mean(axis=0) for q in pieces]
            pieces = [m + scale * (q - m) for q, m in zip(pieces, mids, strict=True)]
            if core_px > 0 and not corrected:
                pieces = _extend_ends(pieces, pts, full_pts)
        segments.extend(pieces)
        ids.extend([lab_id] * len(pieces))
    labels[~keep[labels]] = 0
    if not segments:
        raise ValidationError(
            "smc_mask",
            "no region above min_volume_um3",
            f"SMC regions of at least {min_volume_um3} um^3",
            "lower min_volume_um3 or check the segmentation",
        )
    return TracedCells(
        labels=labels,
        segments_um=np.array(segments),
        cell_id=np.array(ids, dtype=int),
        spacing_um=tuple(float(x) for x in sp),
        volume_um3=volume,
    )
