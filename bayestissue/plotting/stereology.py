"""Figures of the stereology: rose histograms (paper Fig. 6), 3-D rose (Fig. 7), Lambert plots of the
preferential directions with bootstrap cones (Fig. 8), and CE predictors against the truth on a
known object.

Every function takes ``ax=None`` (a new figure is made) and returns the figure; nothing is saved or
shown.
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np

from bayestissue.plotting.style import FONT
from bayestissue.stereology.lines import to_upper_hemisphere
from bayestissue.stereology.rose import EqualAreaRose, lambert_project

__all__ = [
    "plot_rose_histogram",
    "plot_rose_3d",
    "plot_lambert_directions",
    "plot_ce_check",
]

#: Font sizes from the style module (one step below its defaults: these panels are small).
_LEGEND, _SMALL, _TITLE = FONT["legend"] - 1, FONT["tick"] - 1, FONT["title"] - 1

_RANK_STYLES = ("-", "--", "-.")


def plot_rose_histogram(rose: EqualAreaRose, *, top: list[dict] | None = None, ax=None):
    """Total line length per equal-area cell (paper Fig. 6) on axes of azimuth and sin(elevation).

    With sin(elevation) on the vertical axis every cell of the n x n partition is a rectangle of the
    same area, so the colour is directly comparable between cells. ``top``: preferential directions
    to mark (:func:`bayestissue.stereology.rose.preferential_directions`): a circle on each one's longest cell,
    a cross on its refined axis.
    """
    fig, ax = _fig_ax(ax)
    n = rose.n
    az = rose.azimuth_edges
    z = np.arange(n + 1) / n
    m = ax.pcolormesh(az, z, rose.lengths, cmap="viridis", shading="flat")
    fig.colorbar(m, ax=ax, label="line length per cell (um)")
    if top:
        # the circle marks the direction's first (longest) cell; "+" its refined axis, which for a mode near the
        # equator may lie at az + 180 (the same undirected axis), where a circle looked misplaced
        for c in top:
            a, e = c["cell_azimuth"], np.sin(np.radians(c["cell_elevation"]))
            ax.plot(a, e, "o", mfc="none", mec="w", ms=12, mew=1.8)
            dx = -16 if a > 330 else 7  # keep the rank inside the axes at the right edge
            ax.annotate(str(c["rank"]), (a, e), xytext=(dx, 5), textcoords="offset points", color="w", fontsize=11)
            ax.plot(c["azimuth"] % 360, np.sin(np.radians(abs(c["elevation"]))), "+", color="w", ms=8, mew=1.5)
    ax.set_xlim(0, 360)
    ax.set_ylim(0, 1)
    ax.set_xticks(np.arange(0, 361, 60))
    el_ticks = np.array([0, 15, 30, 45, 60, 90])
    ax.set_yticks(np.sin(np.radians(el_ticks)), [f"{t}" for t in el_ticks])
    ax.set_xlabel("azimuth atan2(y, x) (deg)")
    ax.set_ylabel("elevation (deg, equal-area scale)")
    ax.set_title(f"rose of directions, n = {n} (n^2 = {n * n} equal-area cells)")
    return fig


def plot_rose_3d(rose: EqualAreaRose, *, ax=None, sub: int = 4):
    """Spatial rose (paper Fig. 7): radius proportional to the length per cell, drawn for the upper
    hemisphere and mirrored through the origin (axes are undirected)."""
    if ax is None:
        fig = plt.figure(figsize=(6, 5))
        ax = fig.add_subplot(projection="3d")
    fig = ax.figure
    n = rose.n
    k = n * sub
    zf = np.linspace(0, 1, k + 1)  # equal-area bands in z
    ph = np.radians(np.linspace(0, 360, k + 1))
    Z, PH = np.meshgrid(zf, ph, indexing="ij")
    band = np.minimum((Z[:-1, :-1] * n + 1e-9).astype(int), n - 1)
    mer = np.minimum((np.degrees(PH[:-1, :-1]) / 360 * n + 1e-9).astype(int), n - 1)
    L = rose.lengths / rose.lengths.max()
    # radius per vertex: the cell value of the patch it starts (piecewise constant in appearance)
    Rc = np.pad(L[band, mer], ((0, 1), (0, 1)), mode="edge")
    S = np.sqrt(np.clip(1 - Z**2, 0, None))
    X, Y, ZZ = Rc * S * np.cos(PH), Rc * S * np.sin(PH), Rc * Z
    colors = plt.cm.viridis(L[band, mer])
    for sgn in (1.0, -1.0):  # the axis d and -d: the rose is symmetric through the origin
        ax.plot_surface(sgn * X, sgn * Y, sgn * ZZ, facecolors=colors, rstride=1, cstride=1, linewidth=0, shade=False)
    ax.set_xlim(-1, 1)
    ax.set_ylim(-1, 1)
    ax.set_zlim(-0.6, 0.6)
    ax.set_box_aspect((2, 2, 1.2))
    ax.set_xlabel("x (longitudinal)")
    ax.set_ylabel("y (top-down)")
    ax.set_zlabel("z")
    ax.set_title(f"spatial rose, n = {n} (radius = length / max)")
    return fig


#: Cones wider than this (degrees) are not outlined on the Lambert plot: they mean the bootstrap's top cells switch
#: family between replicates, and their outlines (up to 150 deg) ran off the plot across every other direction.
MAX_CONE_DEG = 40.0


def _lambert_frame(ax):
    t = np.linspace(0, 2 * np.pi, 361)
    for el in (0, 30, 60):
        r = np.sqrt(2 * (1 - np.sin(np.radians(el))))
        ax.plot(r * np.cos(t), r * np.sin(t), color="0.8", lw=0.8, zorder=0)
        # on the 255 deg ray, between the azimuth labels 240 and 270 (at -80 deg "el 0" ran into "270")
        ax.text(r * np.cos(np.radians(255)), r * np.sin(np.radians(255)), f"el {el}", fontsize=_SMALL, color="0.45",
                ha="center", va="center", bbox={"fc": "white", "ec": "none", "pad": 0.5})  # fmt: skip
    for a in range(0, 360, 30):
        ax.plot(
            [0, np.sqrt(2) * np.cos(np.radians(a))],
            [0, np.sqrt(2) * np.sin(np.radians(a))],
            color="0.9",
            lw=0.6,
            zorder=0,
        )
        ax.text(
            1.5 * np.cos(np.radians(a)),
            1.5 * np.sin(np.radians(a)),
            f"{a}",
            ha="center",
            va="center",
            fontsize=_SMALL,
        )
    ax.set_aspect("equal")
    ax.set_xlim(-1.85, 1.85)  # room for cones (at most MAX_CONE_DEG wide) that cross the rim
    ax.set_ylim(-1.85, 1.85)
    ax.axis("off")


def _cone_outline(axis, half_angle_deg, m=180):
    """Points on the boundary of a cone about ``axis`` (unit vectors)."""
    a = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    h = np.array([1.0, 0, 0]) if abs(a[0]) < 0.9 else np.array([0, 1.0, 0])
    e1 = np.cross(a, h)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(a, e1)
    t = np.linspace(0, 2 * np.pi, m)
    c, s = np.cos(np.radians(half_angle_deg)), np.sin(np.radians(half_angle_deg))
    return c * a + s * (np.cos(t)[:, None] * e1 + np.sin(t)[:, None] * e2)


def plot_lambert_directions(directions_by_n: dict, *, cones_by_n: dict | None = None, reference=None, ax=None):
    """Preferential directions for several n on a Lambert equal-area plot about the pole z (paper Fig. 8).

    The rim is elevation 0, the centre the pole; azimuth is the polar angle. Ranks 1, 2, 3 are drawn
    as solid, dashed and dash-dotted lines from the centre (the paper's convention), colours
    distinguish n. A cone that crosses the equator continues on the opposite side of the rim (axes
    are undirected).

    Parameters
    ----------
    directions_by_n : {n or label: list of dicts with ``vector`` and ``rank``} (or (k, 3) arrays).
    cones_by_n : {n: (k,) cone half-angles in degrees}, same keys, optional.
    reference : optional (k, 3) axes to mark with crosses (e.g. the paper's v1, v2, v3); each plotted axis
        is then signed like its nearest reference, so axes just below the equator are drawn just
        outside the rim (full-sphere Lambert, r up to 2) instead of jumping to the opposite side.
    """
    fig, ax = _fig_ax(ax, figsize=(6.2, 6))
    _lambert_frame(ax)
    ref = None if reference is None else np.asarray(reference, dtype=float)
    colors = plt.cm.plasma(np.linspace(0, 0.85, max(len(directions_by_n), 1)))
    for (key, tops), col in zip(directions_by_n.items(), colors, strict=True):
        vecs = to_upper_hemisphere(np.array([c["vector"] if isinstance(c, dict) else c for c in tops]))
        if ref is not None:  # sign each axis like its nearest reference: no jump across the rim
            near = np.argmax(np.abs(vecs @ ref.T), axis=1)
            vecs = vecs * np.sign(np.sum(vecs * ref[near], axis=1) + 1e-300)[:, None]
        xy = lambert_project(vecs, upper=ref is None)
        for r, (v, p) in enumerate(zip(vecs, xy, strict=True)):
            ls = _RANK_STYLES[r % 3]
            ax.plot([0, p[0]], [0, p[1]], ls=ls, color=col, lw=1.2, label=f"{key}" if r == 0 else None)
            ax.plot(*p, "o", color=col, ms=4)
            if cones_by_n is not None and key in cones_by_n and cones_by_n[key][r] > MAX_CONE_DEG:
                ax.plot(*p, "o", mfc="white", mec=col, ms=7, mew=1.5)  # an open ring: cone too wide to draw
            elif cones_by_n is not None and key in cones_by_n:
                out = _cone_outline(v, cones_by_n[key][r])
                pts = lambert_project(out if ref is not None else to_upper_hemisphere(out), upper=False)
                jump = np.r_[False, np.linalg.norm(np.diff(pts, axis=0), axis=1) > 0.3]
                seg = np.cumsum(jump)
                for s in np.unique(seg):
                    q = pts[seg == s]
                    ax.plot(q[:, 0], q[:, 1], color=col, lw=0.8, alpha=0.8)
    if ref is not None:
        xy = lambert_project(ref, upper=False)
        ax.plot(xy[:, 0], xy[:, 1], "kx", ms=9, mew=2, label="paper v1-v3")
    ax.legend(
        loc="upper left",
        fontsize=_LEGEND,
        title="n",
        title_fontsize=_LEGEND,
        frameon=False,
        bbox_to_anchor=(-0.02, 1.02),
    )
    ax.set_title(
        "Lambert equal-area about z (rim: elevation 0)\nrank/family 1 solid, 2 dashed, 3 dash-dotted; "
        f"open ring: 95 % cone wider than {MAX_CONE_DEG:g} deg (not drawn)",
        fontsize=_TITLE,
        pad=14,
    )
    return fig


def plot_ce_check(results: list[dict], *, x: str = "n_sections", ax=None, title: str | None = None):
    """CE predictors against the true spread over random starts on a known object.

    ``results``: dicts from :func:`bayestissue.stereology.known_object.ce_check` (one per spacing),
    with the key ``x`` for the horizontal axis.
    """
    fig, ax = _fig_ax(ax)
    xs = np.array([r[x] for r in results])
    order = np.argsort(xs)
    xs = xs[order]

    def col(k):
        return np.array([results[i][k] for i in order])

    ax.plot(xs, col("true_ce"), "k-o", lw=2, label="true spread over random starts")
    ax.plot(xs, col("m1"), "-s", label="predicted, m = 1 (ratio + cov + nugget)")
    ax.plot(xs, col("q_hat"), "-^", label="predicted, fractional q_hat")
    ax.plot(xs, col("m0"), "--", label="predicted, m = 0")
    ax.plot(xs, col("classic"), ":", label="independent units (Cochran)")
    ax.plot(xs, col("naive_bootstrap"), "-x", color="tab:red", label="naive section bootstrap")
    ax.set_yscale("log")
    ax.set_xlabel("number of sections" if x == "n_sections" else x)
    ax.set_ylabel("CE of V_V")
    ax.legend(fontsize=_LEGEND)
    ax.grid(True, which="both", alpha=0.3)
    if title:
        ax.set_title(title, fontsize=_TITLE)
    return fig


def _fig_ax(ax, figsize=(6.4, 4.2)):
    if ax is None:
        fig, ax = plt.subplots(figsize=figsize)
        return fig, ax
    return ax.figure, ax
