"""Overlay figure to check the micrograph pipeline: segmentation, grid points, traced axes."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.colors import ListedColormap
from matplotlib.lines import Line2D

from bayestissue._validation import check_positive

__all__ = ["plot_overlay", "LABEL_COLOURS"]

#: Display colours of CAVITY, ECM, SMC.
LABEL_COLOURS = ("#f2f2f2", "#3b6fd4", "#c8323c")


def plot_overlay(
    image,
    labels,
    *,
    pixel_um: float,
    points=None,
    segments_um=None,
    section_z_um: float | None = None,
    thickness_um: float | None = None,
    valid=None,
    title: str | None = None,
    axes=None,
):
    """Show one registered section with its segmentation, grid points and traced cell axes.

    Parameters
    ----------
    image : (H, W, 3) registered RGB section (uint8 or floats in [0, 255] or [0, 1]).
    labels : (H, W) segmentation (CAVITY / ECM / SMC).
    pixel_um : pixel size in um (segment coordinates are in um).
    points : optional (k, 2) grid points (row, col) counted on this section.
    segments_um : optional (m, 2, 3) traced segments (x, y, z in um); those crossing the slab
        ``section_z_um +- thickness_um / 2`` are drawn.
    valid : optional (H, W) common registered field (its border is outlined).
    axes : optional two matplotlib axes; default: a new 1 x 2 figure.

    Returns
    -------
    matplotlib Figure (left: micrograph with SMC outline, grid points and axes; right: labels).
    """
    pixel_um = check_positive("pixel_um", pixel_um)
    img = np.asarray(image, dtype=float)
    img = img / 255.0 if img.max() > 1.0 else img
    lab = np.asarray(labels)
    if axes is None:
        fig, axes = plt.subplots(1, 2, figsize=(11, 5.2), constrained_layout=True)
    else:
        fig = axes[0].figure
    a0, a1 = axes
    a0.imshow(np.clip(img, 0, 1), interpolation="nearest")
    a0.contour(lab == 2, levels=[0.5], colors="k", linewidths=0.6)
    a1.imshow(lab, cmap=ListedColormap(LABEL_COLOURS), vmin=0, vmax=2, interpolation="nearest")
    handles = [
        Line2D([], [], color="k", lw=0.8, label="SMC outline"),
    ]
    if valid is not None:
        for a in axes:
            a.contour(np.asarray(valid, dtype=float), levels=[0.5], colors="y", linewidths=1.0)
        handles.append(Line2D([], [], color="y", lw=1, label="registered field"))
    if points is not None and len(points):
        p = np.asarray(points)
        ij = np.floor(p).astype(int)
        hit = lab[ij[:, 0], ij[:, 1]]
        for code, colour, name in ((0, "0.4", "cavity"), (1, "cyan", "ECM"), (2, "yellow", "SMC")):
            sel = hit == code
            a0.plot(p[sel, 1], p[sel, 0], "+", ms=5, mew=1.2, color=colour, ls="none")
            handles.append(Line2D([], [], marker="+", color=colour, ls="none", label=f"grid point: {name}"))
    if segments_um is not None and len(segments_um):
        seg = np.asarray(segments_um, dtype=float)
        if section_z_um is not None and thickness_um is not None:
            zlo = np.minimum(seg[:, 0, 2], seg[:, 1, 2])
            zhi = np.maximum(seg[:, 0, 2], seg[:, 1, 2])
            half = thickness_um / 2
            seg = seg[(zhi >= section_z_um - half) & (zlo <= section_z_um + half)]
        for s in seg:
            xs = s[:, 0] / pixel_um - 0.5
            ys = s[:, 1] / pixel_um - 0.5
            for a in axes:
                a.plot(xs, ys, "-", color="lime", lw=1.4)
        handles.append(Line2D([], [], color="lime", lw=1.4, label="traced axes"))
    for a in axes:
        a.set_xlim(-0.5, lab.shape[1] - 0.5)
        a.set_ylim(lab.shape[0] - 0.5, -0.5)
        a.set_xlabel("x (px)")
    a0.set_ylabel("y (px)")
    a0.set_title(title or "registered section")
    a1.set_title("segmentation: cavity (white), ECM (blue), SMC (red)")
    a0.legend(handles=handles, loc="lower left", fontsize=7, framealpha=0.8)
    return fig
