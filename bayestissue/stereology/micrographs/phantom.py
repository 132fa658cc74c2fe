"""Synthetic smooth-muscle tissue in 3-D with known ground truth (the micrograph pipeline's test).

The phantom is a voxel volume of three components, coded ``0 = cavity`` (haemocoelic sinus), ``1 =
ECM`` (collagen matrix) and ``2 = SMC`` (smooth muscle cells), plus a cell-id volume. Cells are
elongated (Kochova & Tonar 2014: about 72 um long with 3 um semi-axes), their axes drawn from a mixture
of three Watson distributions; by default they tessellate the tissue without interpenetrating
(:mod:`~bayestissue.stereology.micrographs.packing`), the older ``packing="overlap"`` places rigid
prolate spindles that may interpenetrate. Cavities are the high part of a smooth random field. The
truth (voxel volume fractions, every cell's axis segment clipped to the volume, its length) is
returned with the volume, so that every estimate of the pipeline can be compared with what it
estimates.

Array order is ``(z, y, x)``; vectors and points are ``(x, y, z)`` in micrometres, the origin at the
corner of voxel ``(0, 0, 0)`` (voxel centres at ``(i + 1/2) * voxel_um``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from bayestissue._validation import (
    ValidationError,
    check_interval,
    check_positive,
    check_unit_vector,
)
from bayestissue.paper import PAPER_DIRECTIONS
from bayestissue.stereology.micrographs.geometry import (
    clip_segment_to_box,
    ellipsoid_voxels,
    midpoints,
    mixture_axes,
    tissue_length,
)
from bayestissue.stereology.micrographs.packing import AxisIndex, carve_seams, place_axes, tessellate

__all__ = [
    "CAVITY",
    "ECM",
    "SMC",
    "PhantomOptions",
    "TissuePhantom",
    "make_phantom",
]

#: Component codes used by the phantom, the renderer and the segmentation.
CAVITY, ECM, SMC = 0, 1, 2

#: Default fibre axes (x, y, z): the paper's three SMC directions (docs/model.md; printed rounded, |v| =
#: 0.9974), normalised.
_PAPER_AXES = tuple(tuple(float(c) for c in v) for v in PAPER_DIRECTIONS)


@dataclass(frozen=True)
class PhantomOptions:
    """Geometry and composition of a synthetic tissue block.

    Parameters
    ----------
    extent_um : (z, y, x) size of the block in um.
    voxel_um : edge of the cubic voxels in um.
    smc_fraction : SMC volume fraction of the tissue without cavities (paper, Section 3.1: 58.9 %).
    cavity_fraction : cavity volume fraction of the whole block (Kochova & Tonar 2014: about 36 %).
    cell_length_um, cell_radius_um : full length 2a and equatorial semi-axis b of the prolate cells
        (Kochova & Tonar 2014, Exp. Mech. 54:791: 72 um and 3 um).
    axes : three (x, y, z) unit vectors, the modal axes of the Watson mixture (default: docs/model.md
        fibres).
    weights : mixture weights of the three axes (summing to 1).
    kappa : Watson concentration of every component (> 0: bipolar, axes concentrated about the
        mode).
    packing : ``"tessellation"`` (default): cells fill the tissue without interpenetrating, each axis inside its own
        voxels (:mod:`~bayestissue.stereology.micrographs.packing`); ``"overlap"``: the earlier phantom, random
        sequential adsorption of rigid spindles that may interpenetrate by up to ``max_overlap`` (about 20 % of the
        axis length then runs inside other cells at 58.9 % SMC, where no image shows it; kept for contrast).
    min_axis_gap_um : tessellation: the least distance between two cell axes (>= 2 voxels, so that every axis
        voxel is its own cell's).
    max_overlap : overlap packing: largest fraction of a new cell's voxels allowed to lie in earlier cells or in
        their ``gap_um`` neighbourhood (random sequential adsorption with a tolerance).
    max_in_cavity : largest fraction of a candidate cell inside the sinuses (the sinuses cut the
        cells they cross; cells mostly inside a sinus are not placed).
    gap_um : collagen sheath kept around earlier cells when testing overlap (0 allows touching
        cells).
    max_attempts : candidates tried before giving up (default: half the number of voxels).
    seams : overlap packing: free a one-voxel collagen seam (endomysium) wherever two cells touch, so that
        touching cells stay distinguishable; cells are added until the SMC fraction after the seams is met (the
        tessellation always cuts seams).
    cavity_scale_um : (z, y, x) correlation lengths (Gaussian filter sigmas) of the random field
        the cavities are cut from. The default makes the sinuses channels along z, persistent
        from section to section when cut along z, which is what registration relies on (with
        24 um along z the registration error reached 2.7 px for some seeds).
    """

    extent_um: tuple[float, float, float] = (60.0, 100.0, 100.0)
    voxel_um: float = 1.0
    smc_fraction: float = 0.589
    cavity_fraction: float = 1.0 / 3.0
    cell_length_um: float = 72.0
    cell_radius_um: float = 3.0
    axes: tuple = _PAPER_AXES
    weights: tuple[float, float, float] = (1 / 3, 1 / 3, 1 / 3)
    kappa: float = 20.0
    packing: str = "tessellation"
    min_axis_gap_um: float = 2.0
    max_overlap: float = 0.25
    max_in_cavity: float = 0.5
    gap_um: float = 0.0
    seams: bool = False
    cavity_scale_um: tuple[float, float, float] = (40.0, 8.0, 8.0)
    max_attempts: int | None = None

    def __post_init__(self):
        ext = np.asarray(self.extent_um, dtype=float)
        if ext.shape != (3,) or not np.all(np.isfinite(ext)) or np.any(ext <= 0):
            raise ValidationError("extent_um", self.extent_um, "three positive lengths (z, y, x) in um")
        check_positive("voxel_um", self.voxel_um)
        if np.any(ext / self.voxel_um < 4):
            raise ValidationError("extent_um", self.extent_um, "at least 4 voxels along each axis", "reduce voxel_um")
        check_interval("smc_fraction", self.smc_fraction, 0.0, 1.0, closed=(False, False))
        check_interval("cavity_fraction", self.cavity_fraction, 0.0, 1.0, closed=(True, False))
        check_positive("cell_length_um", self.cell_length_um)
        check_positive("cell_radius_um", self.cell_radius_um)
        if self.cell_radius_um > self.cell_length_um / 2:
            raise ValidationError(
                "cell_radius_um",
                self.cell_radius_um,
                f"<= cell_length_um / 2 = {self.cell_length_um / 2}",
            )
        if len(self.axes) != len(self.weights) or len(self.axes) == 0:
            raise ValidationError("axes", self.axes, f"{len(self.weights)} unit vectors, one per weight")
        for k, a in enumerate(self.axes):
            check_unit_vector(f"axes[{k}]", a)
        w = np.asarray(self.weights, dtype=float)
        if np.any(w < 0) or abs(w.sum() - 1) > 1e-6:
            raise ValidationError("weights", self.weights, "non-negative weights summing to 1")
        check_positive("kappa", self.kappa)
        if self.packing not in ("tessellation", "overlap"):
            raise ValidationError("packing", self.packing, "'tessellation' or 'overlap'")
        check_positive("min_axis_gap_um", self.min_axis_gap_um)
        if self.packing == "tessellation" and self.min_axis_gap_um < 2 * self.voxel_um:
            raise ValidationError(
                "min_axis_gap_um", self.min_axis_gap_um, f">= 2 voxels ({2 * self.voxel_um} um) with tessellation"
            )
        check_interval("max_overlap", self.max_overlap, 0.0, 1.0)
        check_interval("max_in_cavity", self.max_in_cavity, 0.0, 1.0)
        if self.max_attempts is not None and (int(self.max_attempts) != self.max_attempts or self.max_attempts < 1):
            raise ValidationError("max_attempts", self.max_attempts, "a positive integer or None")
        check_positive("gap_um", self.gap_um, allow_zero=True)
        sc = np.asarray(self.cavity_scale_um, dtype=float)
        if sc.shape != (3,) or not np.all(np.isfinite(sc)) or np.any(sc <= 0):
            raise ValidationError("cavity_scale_um", self.cavity_scale_um, "three positive lengths (z, y, x) in um")

    @property
    def shape(self) -> tuple[int, int, int]:
        """Voxel counts (nz, ny, nx)."""
        return tuple(int(round(e / self.voxel_um)) for e in self.extent_um)


@dataclass
class TissuePhantom:
    """A generated block: component and cell-id volumes plus the truth.

    Attributes
    ----------
    components : (nz, ny, nx) uint8 ndarray, CAVITY / ECM / SMC codes.
    cell_ids : (nz, ny, nx) int32 ndarray, 0 outside cells, else the 1-based cell id.
    voxel_um : voxel edge in um.
    segments_um : (n_cells, 2, 3) ndarray, each cell's axis clipped to the block, endpoints (x, y,
        z) in um.
    directions : (n_cells, 3) unit axes (x, y, z) of the cells.
    component_of : (n_cells,) index of the Watson component each cell was drawn from.
    options : the PhantomOptions used; seed : the seed (or None).
    """

    components: np.ndarray
    cell_ids: np.ndarray
    voxel_um: float
    segments_um: np.ndarray
    directions: np.ndarray
    component_of: np.ndarray
    options: PhantomOptions
    seed: int | None = None

    @property
    def volume_um3(self) -> float:
        """Volume of the block in um^3."""
        return float(self.components.size * self.voxel_um**3)

    @property
    def lengths_um(self) -> np.ndarray:
        """Length of every cell axis inside the block (um), sinus crossings included."""
        return np.linalg.norm(self.segments_um[:, 1] - self.segments_um[:, 0], axis=1)

    def tissue_lengths_um(self, box_um=None, *, step_um: float = 0.25, visible: bool = False) -> np.ndarray:
        """Length of every cell axis inside tissue (not in a sinus) and inside ``box_um``.

        Parameters
        ----------
        box_um : optional ((x0, x1), (y0, y1), (z0, z1)) sub-box in um (default: the whole block).
        step_um : spacing of the sample points along each axis (length resolution).
        visible : count only the axis inside the cell's own voxels (not where it runs inside an
            earlier cell it interpenetrates, or a seam).

        Returns
        -------
        (n_cells,) ndarray of lengths in um.
        """
        step_um = check_positive("step_um", step_um)
        shape = np.array(self.components.shape[::-1])  # (nx, ny, nz)
        out = np.zeros(len(self.segments_um))
        for i, (p0, p1) in enumerate(self.segments_um):
            L = float(np.linalg.norm(p1 - p0))
            pts = midpoints(p0, p1 - p0, step_um)
            ijk = np.clip((pts / self.voxel_um).astype(int), 0, shape - 1)
            keep = self.components[ijk[:, 2], ijk[:, 1], ijk[:, 0]] != CAVITY
            if visible:
                keep &= self.cell_ids[ijk[:, 2], ijk[:, 1], ijk[:, 0]] == i + 1
            if box_um is not None:
                bx = np.asarray(box_um, dtype=float)
                keep &= np.all((pts >= bx[:, 0]) & (pts <= bx[:, 1]), axis=1)
            out[i] = L * keep.mean()
        return out

    def visible_share(self) -> float:
        """Share of the axis length in tissue that lies inside the cell's own voxels (1 where cells do not
        interpenetrate; nan without axes in tissue)."""
        full = float(self.tissue_lengths_um().sum())
        return float(self.tissue_lengths_um(visible=True).sum()) / full if full > 0 else float("nan")

    def volume_fractions(self, region: tuple[slice, ...] | None = None) -> dict[str, float]:
        """Voxel volume fractions of the block (``*_total``) and of the tissue (``*_tissue``)."""
        c = self.components if region is None else self.components[region]
        n = np.bincount(c.ravel(), minlength=3).astype(float)
        tissue = n[ECM] + n[SMC]
        return {
            "cavity_total": n[CAVITY] / n.sum(),
            "ecm_total": n[ECM] / n.sum(),
            "smc_total": n[SMC] / n.sum(),
            "smc_tissue": n[SMC] / tissue if tissue else float("nan"),
            "ecm_tissue": n[ECM] / tissue if tissue else float("nan"),
        }

    def length_density(self, box_um=None, *, visible: bool = False) -> float:
        r"""True length density :math:`L_V = \sum_i \ell_i / V` (paper eq. 2), um^-2.

        :math:`\ell_i` is the length of cell axis *i* in tissue (sinus crossings excluded: the
        micrographs show no cell there) inside ``box_um`` (default: the block), V that box's volume.
        ``visible``: only the axis inside the cell's own voxels (see :meth:`tissue_lengths_um`), the
        part an image can show where cells interpenetrate.
        """
        lengths = self.tissue_lengths_um(box_um, visible=visible)
        if box_um is None:
            vol = self.volume_um3
        else:
            vol = float(np.prod(np.diff(np.asarray(box_um, dtype=float), axis=1)))
        return float(lengths.sum() / vol)

    def truth(self) -> dict:
        """The ground truth as a JSON-serialisable dict."""
        o = self.options
        return {
            "synthetic": True,
            "seed": self.seed,
            "voxel_um": self.voxel_um,
            "shape_zyx": list(self.components.shape),
            "extent_um_zyx": [s * self.voxel_um for s in self.components.shape],
            "volume_fractions": self.volume_fractions(),
            "target": {
                "smc_fraction_of_tissue": o.smc_fraction,
                "cavity_fraction": o.cavity_fraction,
            },
            "packing": o.packing,
            "axes_inside_own_cell": self.visible_share(),
            "length_density_per_um2": self.length_density(),
            "total_tissue_length_um": float(self.tissue_lengths_um().sum()),
            "volume_um3": self.volume_um3,
            "axes_xyz": [list(map(float, a)) for a in o.axes],
            "weights": list(map(float, o.weights)),
            "kappa": o.kappa,
            "cell_length_um": o.cell_length_um,
            "cell_radius_um": o.cell_radius_um,
            "n_cells": int(len(self.segments_um)),
            "cells": [
                {
                    "id": i + 1,
                    "component": int(self.component_of[i]),
                    "direction_xyz": self.directions[i].round(6).tolist(),
                    "segment_um": self.segments_um[i].round(4).tolist(),
                    "length_um": round(float(self.lengths_um[i]), 4),
                }
                for i in range(len(self.segments_um))
            ],
        }


def make_phantom(options: PhantomOptions | None = None, *, rng=None) -> TissuePhantom:
    r"""Generate a tissue block with known volume fractions and cell axes.

    1. Cavities (haemocoelic sinuses) are the voxels with the highest values of a Gaussian-filtered
       white-noise field (sd ``cavity_scale_um``), exactly ``cavity_fraction`` of the block.
    2. ``packing="tessellation"`` (default): axes placed at least ``min_axis_gap_um`` apart until their length in
       tissue is what the nominal spindles need for the SMC fraction, the tissue tessellated among them
       (:mod:`~bayestissue.stereology.micrographs.packing`). ``packing="overlap"``: cells are placed by random
       sequential adsorption: a candidate (centre uniform in the block
       dilated by half a cell length, axis from the Watson mixture) is accepted when at most
       ``max_overlap`` of its voxels fall in earlier cells dilated by ``gap_um``; its voxels not
       yet taken get its id. Sinuses cut through the cells (cell voxels there stay cavity).
       Placement stops when the SMC voxels reach the target fraction of the tissue,

       .. math:: N(\mathrm{SMC}) = V_V(\mathrm{SMC}, \mathrm{tissue})\, N(\mathrm{tissue}).

    3. The rest is ECM (collagen), so the voxel fractions hit the targets to within one cell.

    Parameters
    ----------
    options : PhantomOptions (default: a 60 x 100 x 100 um block at 1 um voxels).
    rng : seed or Generator.

    Returns
    -------
    TissuePhantom

    Raises
    ------
    ValidationError if the target SMC fraction cannot be reached within ``max_attempts``
    candidates (too dense for the overlap tolerance).
    """
    o = options if options is not None else PhantomOptions()
    seed = int(rng) if isinstance(rng, int | np.integer) else None
    rng = np.random.default_rng(rng)
    shape = o.shape
    v = o.voxel_um
    upper = np.array(shape[::-1], dtype=float) * v  # (x, y, z) extent
    a, b = o.cell_length_um / 2, o.cell_radius_um
    axes = np.array([np.asarray(x, float) / np.linalg.norm(x) for x in o.axes])
    weights = np.asarray(o.weights, dtype=float)

    cavity = np.zeros(shape, dtype=bool)
    n_cav = int(round(o.cavity_fraction * np.prod(shape)))
    if n_cav > 0:
        field_ = ndimage.gaussian_filter(
            rng.standard_normal(shape), np.asarray(o.cavity_scale_um) / v, mode="wrap"
        ).ravel()
        cavity.ravel()[np.argpartition(field_, field_.size - n_cav)[field_.size - n_cav :]] = True
    n_target = o.smc_fraction * (np.prod(shape) - n_cav)
    max_attempts = o.max_attempts if o.max_attempts is not None else max(1000, np.prod(shape) // 2)
    if o.packing == "tessellation":
        cell_ids, segments, directions, comps = _tessellated_cells(o, cavity, axes, weights, rng)
        return _phantom(o, cavity, cell_ids, segments, directions, comps, seed)

    cell_ids = np.zeros(shape, dtype=np.int32)
    blocked = np.zeros(shape, dtype=bool)  # cells dilated by the gap
    gap_vox = int(round(o.gap_um / v))
    ball = ndimage.generate_binary_structure(3, 1)
    segments, directions, comps = [], [], []
    n_smc = 0
    batch = 256
    attempts = 0
    goal = n_target
    while True:
        while n_smc < goal:
            if attempts >= max_attempts:
                raise ValidationError(
                    "smc_fraction",
                    o.smc_fraction,
                    f"a density reachable with max_overlap={o.max_overlap}, gap_um={o.gap_um}",
                    f"reached {n_smc / (np.prod(shape) - n_cav):.3f} of the tissue after "
                    f"{attempts} candidates; raise max_overlap or lower gap_um",
                )
            dirs, comp = mixture_axes(batch, axes, weights, o.kappa, rng)
            centres = rng.uniform(size=(batch, 3)) * (upper + 2 * a) - a
            for j in range(batch):
                attempts += 1
                d = dirs[j] * (-1.0 if dirs[j][2] < 0 else 1.0)
                seg = clip_segment_to_box(centres[j] - a * d, centres[j] + a * d, upper)
                if seg is None:
                    continue
                vox = ellipsoid_voxels(centres[j], d, a, b, shape, v)
                if vox is None or vox[0].size == 0:
                    continue
                in_tissue = ~cavity[vox]
                if in_tissue.mean() < 1 - o.max_in_cavity:
                    continue
                if (blocked[vox] & in_tissue).mean() > o.max_overlap:
                    continue
                free = (cell_ids[vox] == 0) & in_tissue
                idx = tuple(x[free] for x in vox)
                cell_ids[idx] = len(segments) + 1
                n_smc += int(free.sum())
                if gap_vox > 0:
                    lo = [max(0, int(x.min()) - gap_vox) for x in vox]
                    hi = [min(s, int(x.max()) + gap_vox + 1) for x, s in zip(vox, shape, strict=True)]
                    box = tuple(slice(l_, h_) for l_, h_ in zip(lo, hi, strict=True))
                    sub = np.zeros([h_ - l_ for l_, h_ in zip(lo, hi, strict=True)], dtype=bool)
                    sub[tuple(x - l_ for x, l_ in zip(vox, lo, strict=True))] = True
                    blocked[box] |= ndimage.binary_dilation(sub, ball, iterations=gap_vox)
                else:
                    blocked[vox] = True
                segments.append(seg)
                directions.append(d)
                comps.append(int(comp[j]))
                if n_smc >= goal:
                    break
        if not o.seams:
            break
        n_smc -= carve_seams(cell_ids)
        if n_smc >= n_target:
            break
        goal = n_smc + 1.25 * (n_target - n_smc)

    return _phantom(o, cavity, cell_ids, segments, directions, comps, seed)


def _phantom(o, cavity, cell_ids, segments, directions, comps, seed) -> TissuePhantom:
    components = np.full(cavity.shape, ECM, dtype=np.uint8)
    components[cell_ids > 0] = SMC
    components[cavity] = CAVITY
    return TissuePhantom(
        components=components,
        cell_ids=cell_ids,
        voxel_um=o.voxel_um,
        segments_um=np.array(segments).reshape(-1, 2, 3),
        directions=np.array(directions).reshape(-1, 3),
        component_of=np.array(comps, dtype=int),
        options=o,
        seed=seed,
    )


def _tessellated_cells(o, cavity, axes, weights, rng):
    """Axes placed without crossing until their length in tissue is what the nominal spindles need, then the tissue
    tessellated among them (:mod:`.packing`); a fraction the tessellation cannot reach is refused. Returns cell
    ids, clipped segments, directions and mixture components."""
    shape, v = cavity.shape, o.voxel_um
    upper = np.array(shape[::-1], dtype=float) * v
    a, b = o.cell_length_um / 2, o.cell_radius_um
    pool = {"dirs": np.empty((0, 3)), "comp": np.empty(0, dtype=int)}

    def draw(rng):
        if pool["comp"].size == 0:
            pool["dirs"], pool["comp"] = mixture_axes(512, axes, weights, o.kappa, rng)
        d, c = pool["dirs"][0], int(pool["comp"][0])
        pool["dirs"], pool["comp"] = pool["dirs"][1:], pool["comp"][1:]
        return d * (-1.0 if d[2] < 0 else 1.0), c

    def in_cavity(p0, p1):
        t = (np.arange(16) + 0.5) / 16
        pts = p0 + t[:, None] * (p1 - p0)
        inside = np.all((pts >= 0) & (pts < upper), axis=1)
        if not inside.any():
            return 1.0
        ijk = (pts[inside] / v).astype(int)
        return float(cavity[ijk[:, 2], ijk[:, 1], ijk[:, 0]].mean())

    tissue = ~cavity
    # axes are added until their length in tissue is what spindles of the nominal shape need for the SMC fraction:
    # mean cross-section of a prolate spindle along its axis V / 2a = 2 pi b^2 / 3
    length_needed = o.smc_fraction * tissue.sum() * v**3 / (2.0 * np.pi * b * b / 3.0)
    dilated = np.prod(upper + 2 * a) / np.prod(upper)  # centres fill the block dilated by a half length
    per_axis = 2 * a / dilated  # expected length of one axis in the block, until measured
    index, length = AxisIndex(max(2 * o.min_axis_gap_um, 4 * v)), 0.0
    for _ in range(40):  # rounds of half the estimated deficit, then the rest: overshoot <= a few axes
        n = max(4, int(np.ceil(0.5 * (length_needed - length) / per_axis)))
        done = place_axes(index, n, draw, upper, a, o.min_axis_gap_um, in_cavity, o.max_in_cavity, rng)
        length += tissue_length(index.starts[index.n - done :], index.vectors[index.n - done :], tissue, v)
        if length >= length_needed or done < n:  # enough, or random packing jammed
            break
        per_axis = length / index.n
    clipped = [clip_segment_to_box(p, p + d, upper) for p, d in zip(index.starts, index.vectors, strict=True)]
    kept = [k for k, seg in enumerate(clipped) if seg is not None]
    starts, vectors = index.starts[kept], index.vectors[kept]
    comps = np.array(index.components, dtype=int)[kept]
    ids, _, reached = tessellate(starts, vectors, b, tissue, v, o.smc_fraction)
    if ids is None:
        raise ValidationError(
            "smc_fraction", o.smc_fraction, f"a fraction the tessellation reaches (reached {reached:.4f})",
            "lower smc_fraction or min_axis_gap_um",
        )  # fmt: skip
    segments = [clipped[k] for k in kept]
    directions = vectors / np.linalg.norm(vectors, axis=1, keepdims=True)
    return _renumber(ids, segments, directions, comps)


def _renumber(ids, segments, directions, comps):
    """Drop the axes that received no tissue voxel (entirely in sinuses) and renumber the cells 1..n."""
    present = np.unique(ids[ids > 0]) - 1
    lut = np.zeros(len(segments) + 1, dtype=np.int32)
    lut[present + 1] = np.arange(1, present.size + 1)
    return (
        lut[ids],
        [segments[k] for k in present],
        directions[present],
        [int(comps[k]) for k in present],
    )
