"""Synthetic smooth-muscle tissue in 3-D with known ground truth (the micrograph pipeline's test
object).

The phantom is a voxel volume of three components, coded ``0 = cavity`` (haemocoelic sinus), ``1 =
ECM``
(collagen matrix) and ``2 = SMC`` (smooth muscle cells), plus a cell-id volume. Cells are
spindle-shaped prolate
ellipsoids (Kochova & Tonar 2014: about 72 um long with 3 um semi-axes) whose axes are drawn from a
mixture of
three Watson distributions; cavities are the high part of a smooth random field carved out of the
space the cells
leave free. The truth (voxel volume fractions, every cell's axis segment clipped to the volume, its
length) is
returned with the volume, so that every estimate of the pipeline can be compared with what it
estimates.

Array order is ``(z, y, x)``; vectors and points are ``(x, y, z)`` in micrometres, the origin at
the corner of
voxel ``(0, 0, 0)`` (voxel centres at ``(i + 1/2) * voxel_um``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import ndimage

from bayestissue._validation import (
    ValidationError,
    check_interval,
    check_positive,
    check_unit_vector,
)

__all__ = [
    "CAVITY",
    "ECM",
    "SMC",
    "PhantomOptions",
    "TissuePhantom",
    "make_phantom",
    "sample_watson_axes",
    "clip_segment_to_box",
]

#: Component codes used by the phantom, the renderer and the segmentation.
CAVITY, ECM, SMC = 0, 1, 2

#: Default fibre axes (x, y, z): the paper's three SMC directions (MODEL.md; printed rounded, |v| =
#: 0.9974),
#: normalised.
_PAPER_AXES = tuple(
    tuple(float(c) for c in np.asarray(v) / np.linalg.norm(v))
    for v in ((0.0, 1.0, 0.0), (0.9369, 0.3420, 0.0), (0.9369, -0.3420, 0.0))
)


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
    axes : three (x, y, z) unit vectors, the modal axes of the Watson mixture (default: MODEL.md
        fibres).
    weights : mixture weights of the three axes (summing to 1).
    kappa : Watson concentration of every component (> 0: bipolar, axes concentrated about the
        mode).
    max_overlap : largest fraction of a new cell's voxels allowed to lie in earlier cells or in
        their
        ``gap_um`` neighbourhood (random sequential adsorption with a tolerance).
    gap_um : collagen sheath kept around earlier cells when testing overlap (0 allows touching
        cells).
    sheath_um : least distance of the cavities from any cell (the collagen sheath around the cells).
    cavity_scale_um : correlation length (Gaussian filter sigma) of the random field the cavities
        are cut from.
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
    max_overlap: float = 0.25
    gap_um: float = 1.0
    sheath_um: float = 1.0
    cavity_scale_um: float = 6.0
    max_attempts: int = field(default=200_000)

    def __post_init__(self):
        ext = np.asarray(self.extent_um, dtype=float)
        if ext.shape != (3,) or not np.all(np.isfinite(ext)) or np.any(ext <= 0):
            raise ValidationError(
                "extent_um", self.extent_um, "three positive lengths (z, y, x) in um"
            )
        check_positive("voxel_um", self.voxel_um)
        if np.any(ext / self.voxel_um < 4):
            raise ValidationError(
                "extent_um", self.extent_um, "at least 4 voxels along each axis", "reduce voxel_um"
            )
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
            raise ValidationError(
                "axes", self.axes, f"{len(self.weights)} unit vectors, one per weight"
            )
        for k, a in enumerate(self.axes):
            check_unit_vector(f"axes[{k}]", a)
        w = np.asarray(self.weights, dtype=float)
        if np.any(w < 0) or abs(w.sum() - 1) > 1e-6:
            raise ValidationError("weights", self.weights, "non-negative weights summing to 1")
        check_positive("kappa", self.kappa)
        check_interval("max_overlap", self.max_overlap, 0.0, 1.0)
        check_positive("gap_um", self.gap_um, allow_zero=True)
        check_positive("sheath_um", self.sheath_um, allow_zero=True)
        check_positive("cavity_scale_um", self.cavity_scale_um)

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
        """Length of every cell axis inside the block (um)."""
        return np.linalg.norm(self.segments_um[:, 1] - self.segments_um[:, 0], axis=1)

    def volume_fractions(self, region: tuple[slice, ...] | None = None) -> dict[str, float]:
        """Voxel volume fractions: of the whole block (``*_total``) and of the tissue without
        cavities."""
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

    def length_density(self) -> float:
        r"""True length density :math:`L_V = \sum_i \ell_i / V` (paper eq. 2) of the cell axes in
        um^-2."""
        return float(self.lengths_um.sum() / self.volume_um3)

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
            "length_density_per_um2": self.length_density(),
            "total_length_um": float(self.lengths_um.sum()),
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


def sample_watson_axes(mode, kappa: float, size: int, *, rng=None) -> np.ndarray:
    r"""Draw ``size`` unit axes from a bipolar Watson distribution about ``mode``.

    .. math:: f(\mathbf x) \propto \exp\{\kappa (\boldsymbol\mu \cdot \mathbf x)^2\},\qquad \kappa
        > 0.

    The cosine :math:`t = |\boldsymbol\mu\cdot\mathbf x|` has density :math:`\propto e^{\kappa
    t^2}` on [0, 1]; it is
    drawn by inverting its tabulated CDF (exact up to the 4097-point table), the azimuth about the
    mode uniformly
    (Fisher, Lewis & Embleton 1987, Statistical analysis of spherical data, Section 3.6). The sign
    of each axis is
    random (axes, not vectors).

    Returns
    -------
    (size, 3) ndarray of unit vectors.
    """
    rng = np.random.default_rng(rng)
    mu = check_unit_vector("mode", mode)
    kappa = check_positive("kappa", kappa)
    t_grid = np.linspace(0.0, 1.0, 4097)
    log_pdf = kappa * (t_grid**2 - 1.0)
    pdf = np.exp(log_pdf)
    cdf = np.concatenate([[0.0], np.cumsum(0.5 * (pdf[1:] + pdf[:-1]))])
    cdf /= cdf[-1]
    t = np.interp(rng.uniform(size=size), cdf, t_grid)
    phi = rng.uniform(0, 2 * np.pi, size=size)
    # orthonormal frame (e1, e2, mu)
    helper = np.array([1.0, 0, 0]) if abs(mu[0]) < 0.9 else np.array([0, 1.0, 0])
    e1 = np.cross(mu, helper)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(mu, e1)
    s = np.sqrt(np.clip(1 - t**2, 0, None))
    x = t[:, None] * mu + s[:, None] * (np.cos(phi)[:, None] * e1 + np.sin(phi)[:, None] * e2)
    sign = np.where(rng.uniform(size=size) < 0.5, -1.0, 1.0)
    return x * sign[:, None]


def clip_segment_to_box(p0, p1, upper) -> np.ndarray | None:
    """Clip the segment ``p0 -> p1`` to the box ``[0, upper]`` (Liang-Barsky); ``None`` if it
    misses the box."""
    p0, p1, upper = (np.asarray(v, dtype=float) for v in (p0, p1, upper))
    d = p1 - p0
    t0, t1 = 0.0, 1.0
    for k in range(3):
        for p, q in ((-d[k], p0[k]), (d[k], upper[k] - p0[k])):
            if p == 0:
                if q < 0:
                    return None
                continue
            r = q / p
            if p < 0:
                t0 = max(t0, r)
            else:
                t1 = min(t1, r)
    if t0 >= t1:
        return None
    return np.array([p0 + t0 * d, p0 + t1 * d])


def _ellipsoid_voxels(centre, axis, a, b, shape, voxel):
    """Indices (flat arrays iz, iy, ix) of the voxels whose centres lie in the prolate ellipsoid."""
    half = np.sqrt(a**2 * axis**2 + b**2 * (1 - axis**2))  # (x, y, z) half extents
    lo = np.floor((centre - half) / voxel - 0.5).astype(int)
    hi = np.ceil((centre + half) / voxel - 0.5).astype(int) + 1
    lim = np.array(shape[::-1])
    lo, hi = np.clip(lo, 0, lim), np.clip(hi, 0, lim)
    if np.any(hi <= lo):
        return None
    xs = (np.arange(lo[0], hi[0]) + 0.5) * voxel - centre[0]
    ys = (np.arange(lo[1], hi[1]) + 0.5) * voxel - centre[1]
    zs = (np.arange(lo[2], hi[2]) + 0.5) * voxel - centre[2]
    Z, Y, X = np.meshgrid(zs, ys, xs, indexing="ij")
    along = X * axis[0] + Y * axis[1] + Z * axis[2]
    r2 = X * X + Y * Y + Z * Z
    inside = (along / a) ** 2 + (r2 - along**2) / b**2 <= 1.0
    iz, iy, ix = np.nonzero(inside)
    return iz + lo[2], iy + lo[1], ix + lo[0]


def make_phantom(options: PhantomOptions | None = None, *, rng=None) -> TissuePhantom:
    r"""Generate a tissue block with known volume fractions and cell axes.

    Cells are placed by random sequential adsorption: a candidate (centre uniform in the block
    dilated by half a
    cell length, axis from the Watson mixture) is accepted when at most ``max_overlap`` of its
    voxels fall in
    earlier cells dilated by ``gap_um``; accepted voxels not yet taken get its id. Placement stops
    when the SMC
    voxels reach the target fraction of the whole block,

    .. math:: V_V(\mathrm{SMC}, \mathrm{block}) = V_V(\mathrm{SMC}, \mathrm{tissue})\,(1 -
        V_V(\mathrm{cavity})).

    Cavities are then the voxels with the highest values of a Gaussian-filtered white-noise field
    among the
    voxels farther than ``sheath_um`` from any cell, as many as the cavity fraction asks; the rest
    is ECM. The voxel
    fractions therefore hit the targets to within one cell's volume.

    Parameters
    ----------
    options : PhantomOptions (default: a 60 x 100 x 100 um block at 1 um voxels).
    rng : seed or Generator.

    Returns
    -------
    TissuePhantom

    Raises
    ------
    ValidationError if the target SMC fraction cannot be reached (too dense for the overlap
    tolerance) or the
    cavities do not fit into the space left by the cells.
    """
    o = options if options is not None else PhantomOptions()
    seed = rng if isinstance(rng, int | np.integer) else None
    rng = np.random.default_rng(rng)
    shape = o.shape
    v = o.voxel_um
    upper = np.array(shape[::-1], dtype=float) * v  # (x, y, z) extent
    a, b = o.cell_length_um / 2, o.cell_radius_um
    axes = np.array([np.asarray(x, float) / np.linalg.norm(x) for x in o.axes])
    weights = np.asarray(o.weights, dtype=float)
    target_smc = o.smc_fraction * (1 - o.cavity_fraction)
    n_target = target_smc * np.prod(shape)

    cell_ids = np.zeros(shape, dtype=np.int32)
    blocked = np.zeros(shape, dtype=bool)  # cells dilated by the gap
    gap_vox = int(round(o.gap_um / v))
    ball = ndimage.generate_binary_structure(3, 1)
    segments, directions, comps = [], [], []
    n_smc = 0
    batch = 256
    attempts = 0
    while n_smc < n_target:
        if attempts >= o.max_attempts:
            raise ValidationError(
                "smc_fraction",
                o.smc_fraction,
                f"a density reachable with max_overlap={o.max_overlap}, gap_um={o.gap_um}",
                f"reached {n_smc / np.prod(shape) / (1 - o.cavity_fraction):.3f} of the tissue
                after "
                f"{attempts} attempts; raise max_overlap or lower gap_um",
            )
        comp = rng.choice(len(weights), size=batch, p=weights)
        dirs = np.empty((batch, 3))
        for k in range(len(weights)):
            sel = comp == k
            if sel.any():
                dirs[sel] = sample_watson_axes(axes[k], o.kappa, int(sel.sum()), rng=rng)
        centres = rng.uniform(size=(batch, 3)) * (upper + 2 * a) - a
        for j in range(batch):
            attempts += 1
            d = dirs[j] * np.sign(dirs[j][2] if dirs[j][2] != 0 else 1.0)
            seg = clip_segment_to_box(centres[j] - a * d, centres[j] + a * d, upper)
            if seg is None:
                continue
            vox = _ellipsoid_voxels(centres[j], d, a, b, shape, v)
            if vox is None or vox[0].size == 0:
                continue
            if blocked[vox].mean() > o.max_overlap:
                continue
            free = cell_ids[vox] == 0
            idx = tuple(x[free] for x in vox)
            cell_ids[idx] = len(segments) + 1
            n_smc += int(free.sum())
            if gap_vox > 0:
                sub = np.zeros(shape, dtype=bool)
                sub[vox] = True
                lo = [max(0, int(x.min()) - gap_vox) for x in vox]
                hi = [min(s, int(x.max()) + gap_vox + 1) for x, s in zip(vox, shape)]
                box = tuple(slice(l_, h_) for l_, h_ in zip(lo, hi))
                blocked[box] |= ndimage.binary_dilation(sub[box], ball, iterations=gap_vox)
            else:
                blocked[vox] = True
            segments.append(seg)
            directions.append(d)
            comps.append(int(comp[j]))
            if n_smc >= n_target:
                break

    components = np.full(shape, ECM, dtype=np.uint8)
    components[cell_ids > 0] = SMC
    n_cav = int(round(o.cavity_fraction * np.prod(shape)))
    if n_cav > 0:
        if o.sheath_um > 0:
            dist = ndimage.distance_transform_edt(cell_ids == 0, sampling=v)
            candidates = dist > o.sheath_um
        else:
            candidates = cell_ids == 0
        if candidates.sum() < n_cav:
            raise ValidationError(
                "cavity_fraction",
                o.cavity_fraction,
                f"at most {candidates.mean():.3f} (the space farther than sheath_um from the
                cells)",
                "lower smc_fraction, cavity_fraction or sheath_um",
            )
        field_ = ndimage.gaussian_filter(
            rng.standard_normal(shape), o.cavity_scale_um / v, mode="wrap"
        )
        vals = field_[candidates]
        thr = np.partition(vals, vals.size - n_cav)[vals.size - n_cav]
        cav = candidates & (field_ >= thr)
        components[cav] = CAVITY

    return TissuePhantom(
        components=components,
        cell_ids=cell_ids,
        voxel_um=v,
        segments_um=np.array(segments).reshape(-1, 2, 3),
        directions=np.array(directions).reshape(-1, 3),
        component_of=np.array(comps, dtype=int),
        options=o,
        seed=seed,
    )
