"""Geometry of the phantom's cells: Watson-distributed axes, segments clipped to the block, prolate ellipsoids as
voxels, and lengths measured along segments inside the tissue.

Vectors and points are ``(x, y, z)`` in micrometres, arrays ``(z, y, x)`` (as :mod:`.phantom`).
"""

from __future__ import annotations

import numpy as np

from bayestissue._validation import check_positive, check_unit_vector

__all__ = [
    "clip_segment_to_box",
    "ellipsoid_voxels",
    "midpoints",
    "mixture_axes",
    "sample_watson_axes",
    "tissue_length",
]


def sample_watson_axes(mode, kappa: float, size: int, *, rng=None) -> np.ndarray:
    r"""Draw ``size`` unit axes from a bipolar Watson distribution about ``mode``.

    .. math:: f(\mathbf x) \propto \exp\{\kappa (\boldsymbol\mu \cdot \mathbf x)^2\},\qquad \kappa >
    0.

    The cosine :math:`t = |\boldsymbol\mu\cdot\mathbf x|` has density :math:`\propto e^{\kappa t^2}`
    on [0, 1]; it is drawn by inverting its tabulated CDF (exact up to the 4097-point table), the
    azimuth about the mode uniformly (Fisher, Lewis & Embleton 1987, Statistical analysis of
    spherical data, Section 3.6). The sign of each axis is random (axes, not vectors).

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
    """Clip the segment ``p0 -> p1`` to the box ``[0, upper]`` (Liang-Barsky); None if it misses."""
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


def ellipsoid_voxels(centre, axis, a, b, shape, voxel):
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


def midpoints(p0, d, step) -> np.ndarray:
    """Midpoints of the ``max(2, ceil(L / step))`` equal pieces of the segment ``p0 -> p0 + d`` (length L): the
    sample points at which a length along the segment is measured."""
    m = max(2, int(np.ceil(float(np.linalg.norm(d)) / step)))
    return p0 + ((np.arange(m) + 0.5) / m)[:, None] * d


def tissue_length(starts, vectors, tissue, voxel, step=0.5) -> float:
    """Total length (um) of the segments ``starts + t vectors`` inside the block and in tissue, sampled every
    ``step`` um."""
    shape = np.array(tissue.shape[::-1])
    total = 0.0
    for p0, d in zip(starts, vectors, strict=True):
        pts = midpoints(p0, d, step)
        ijk = np.floor(pts / voxel).astype(int)
        inside = np.all((ijk >= 0) & (ijk < shape), axis=1)
        in_tissue = np.count_nonzero(tissue[ijk[inside, 2], ijk[inside, 1], ijk[inside, 0]])
        total += float(np.linalg.norm(d)) / len(pts) * in_tissue
    return total


def mixture_axes(n, axes, weights, kappa, rng) -> tuple[np.ndarray, np.ndarray]:
    """``n`` axes from the Watson mixture: the component of each (``weights``), then its Watson draw about
    ``axes[k]`` (:func:`sample_watson_axes`). Returns (directions (n, 3), components (n,))."""
    comp = rng.choice(len(weights), size=n, p=weights)
    dirs = np.empty((n, 3))
    for k in range(len(weights)):
        sel = comp == k
        if sel.any():
            dirs[sel] = sample_watson_axes(axes[k], kappa, int(sel.sum()), rng=rng)
    return dirs, comp
