"""Overlay figure to check the micrograph pipeline: segmentation, grid points, traced axes."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.colors import ListedColormap
from matplotlib.lines import Line2D

from bayestissue._validation import check_positive
from bayestissue.plotting.style import FONT
from bayestissue.stereology.micrographs.validation import predicted_ce
from bayestissue.stereology.rose import lambert_project

__all__ = ["plot_overlay", "plot_validation", "LABEL_COLOURS"]

#: Font sizes from the style module (one step below its defaults: these panels are small).
_LEGEND, _SMALL, _TITLE = FONT["legend"] - 1, FONT["tick"] - 1, FONT["title"] - 1

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
    a0.legend(handles=handles, loc="lower left", fontsize=_LEGEND, framealpha=0.8)
    return fig


def plot_validation(main, old):
    """The six-panel validation figure of :func:`~bayestissue.stereology.micrographs.validation.run_chain` results
    (default phantom ``main``; ``old``, the interpenetrating phantom shown for contrast, or None)."""
    fig = plt.figure(figsize=(14, 9.5), constrained_layout=True)
    gs = fig.add_gridspec(2, 3)
    # (a) volume fractions
    ax = fig.add_subplot(gs[0, 0])
    s = main["summary"]
    names = [("smc", "smc_tissue"), ("ecm", "ecm_tissue")]
    for i, (c, key) in enumerate(names):
        est = s[c]["V_V"]
        ce = predicted_ce(s[c])
        boot = main["vv_boot"][c]
        seg_e = abs(main["seg_err"][key])
        ax.errorbar(i - 0.1, est, yerr=2 * ce * est, fmt="o", color="C0", capsize=4,
                    label="estimate +- 2 CE" if i == 0 else None)  # fmt: skip
        ax.errorbar(i - 0.1, est, yerr=2 * ce * est + seg_e, fmt="none", color="C0", alpha=0.4,
                    capsize=8, label="+ |segmentation error|" if i == 0 else None)  # fmt: skip
        lo, hi = np.quantile(boot, [0.025, 0.975])
        ax.plot([i + 0.1] * 2, [lo, hi], color="C1", lw=3,
                label="parametric bootstrap 95 %" if i == 0 else None)  # fmt: skip
        ax.plot(i, main["vf_true"][key], "k_", ms=30, mew=2, label="truth" if i == 0 else None)
    ax.set_xticks([0, 1], ["SMC / tissue", "ECM / tissue"])
    ax.set_ylabel("volume fraction")
    ax.set_title("(a) point counting on SURS sections")
    ax.legend(fontsize=_LEGEND)
    # (b) L_V
    ax = fig.add_subplot(gs[0, 1])
    for i, r in enumerate((main, old)):
        if r is None:
            continue
        lo, hi = np.quantile(r["lv_boot"], [0.025, 0.975])
        ax.errorbar(i, r["lv"], yerr=[[r["lv"] - lo], [hi - r["lv"]]], fmt="o", capsize=4,
                    color="C0", label="traced (cell bootstrap 95 %)" if i == 0 else None)  # fmt: skip
        ax.plot(i, r["lv_true"], "k_", ms=30, mew=2, label="truth" if i == 0 else None)
        ax.fill_between([i - 0.25, i + 0.25], 0.85 * r["lv_true"], 1.15 * r["lv_true"],
                        color="0.85", label="truth +- 15 %" if i == 0 else None)  # fmt: skip
    ax.set_xticks([0, 1], ["default\n(packed)", "old\n(overlapping)"])
    ax.set_ylabel("L_V (um^-2)")
    ax.set_title("(b) length density")
    ax.set_xlim(-0.6, 1.6)
    ax.legend(fontsize=_LEGEND, loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=2, frameon=False)
    # (c) registration error
    ax = fig.add_subplot(gs[0, 2])
    for r, name, c in ((main, "default", "C0"), (old, "old phantom", "C2")):
        if r is not None:
            ax.plot(r["reg_err_px"], "o-", color=c, label=name)
    ax.axhline(1.0, color="k", ls="--", lw=1, label="1 px")
    ax.set_xlabel("section")
    ax.set_ylabel("mean displacement error (px)")
    ax.set_title("(c) registration error\n(template of 3 sections)")
    ax.legend(fontsize=_LEGEND)
    # (d, e) directions: Lambert equal-area of traced pieces, estimated axes, truth
    for k, (r, name) in enumerate(((main, "default"), (old, "old"))):
        if r is None:
            continue
        ax = fig.add_subplot(gs[1, k])
        tr = r["res"].traced
        xy = lambert_project(tr.directions)
        ax.scatter(xy[:, 0], xy[:, 1], s=3 + 30 * tr.lengths_um / tr.lengths_um.max(),
                   alpha=0.35, color="C0", label="traced pieces")  # fmt: skip
        est = lambert_project(r["dirs"]["axes"])
        ta = r["true_axes"]
        tru = lambert_project(np.concatenate([ta, -ta[np.abs(ta[:, 2]) < 0.2]]), upper=False)
        ax.plot(est[:, 0], est[:, 1], "r^", ms=9, label="estimated axes")
        ax.plot(tru[:, 0], tru[:, 1], "kx", ms=10, mew=2, label="true axes (both rim ends)")
        for j in range(3):  # each axis' error and cone, pushed towards the centre, clear of the rim markers
            inward = -est[j] / (np.linalg.norm(est[j]) + 1e-12)
            ax.annotate(f"{r['dir_err_deg'][j]:.1f} deg (cone {r['dirs']['cone_deg'][j]:.1f})", est[j],
                        xytext=tuple(38 * inward), textcoords="offset points", fontsize=_SMALL, ha="center",
                        va="center", bbox={"fc": "white", "ec": "0.7", "pad": 1.5, "alpha": 0.9},
                        arrowprops={"arrowstyle": "-", "color": "0.5", "lw": 0.6})  # fmt: skip
        ax.add_patch(plt.Circle((0, 0), np.sqrt(2), fill=False, color="0.5"))
        ax.set_aspect("equal")
        ax.set_xlim(-1.5, 1.5)
        ax.set_ylim(-1.5, 1.5)
        ax.set_title(f"({'de'[k]}) directions, {name} phantom\n(Lambert equal-area, upper half)")
        ax.legend(fontsize=_LEGEND, loc="upper center", bbox_to_anchor=(0.5, -0.08), ncol=3, frameon=False)
    # (f) V_V over SURS repeats vs predicted CE
    ax = fig.add_subplot(gs[1, 2])
    vv = main["vv_surs"]
    bins = np.histogram_bin_edges(np.concatenate([vv, main["vv_grid_only"]]), bins=20)
    ax.hist(vv, bins=bins, color="C0", alpha=0.6, label="V_V(SMC) over SURS starts + grid offsets")
    ax.hist(main["vv_grid_only"], bins=bins, histtype="step", color="k", lw=1.2,
            label="grid offsets alone (sections fixed)")  # fmt: skip
    s_smc, s_prof = main["summary"]["smc"], main["summary_profiles"]["smc"]
    top = ax.get_ylim()[1]
    bars = [(vv.std(ddof=1), "C0", "+-1 sd measured (SURS starts + offsets)")]
    for key, s_, c, text in (("CE_q_hat", s_smc, "C3", "+-1 CE_q_hat, 1 profile / section"),
                             ("CE_q_hat", s_prof, "C1", "+-1 CE_q_hat, measured profiles"),
                             ("CE_classic", s_smc, "C4", "+-1 CE_classic")):  # fmt: skip
        sd = s_[key] * s_smc["V_V"]
        if np.isfinite(sd):
            bars.append((sd, c, text))
    for j, (sd, c, text) in enumerate(bars):  # one bar per prediction above the histograms, centred on the mean
        ax.errorbar(vv.mean(), top * (1.08 + 0.09 * j), xerr=sd, fmt="o", ms=3, color=c, capsize=4, lw=2, label=text)
    ax.set_ylim(0, top * (1.15 + 0.09 * len(bars)))
    truth = main["vf_true"]["smc_tissue"]
    ax.axvline(truth, color="k", lw=2, label="truth")
    lo, hi = ax.get_xlim()
    pad = 0.1 * (max(hi, truth) - min(lo, truth))  # the truth line clear of the frame
    ax.set_xlim(min(lo, truth - pad), max(hi, truth + pad))
    ax.set_xlabel("V_V(SMC, tissue)")
    ax.set_ylabel("SURS starts")
    ax.set_title("(f) SURS spread vs predicted CE\n(one sample)")
    ax.legend(fontsize=_LEGEND, loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=2, frameon=False)  # off the bands
    return fig
