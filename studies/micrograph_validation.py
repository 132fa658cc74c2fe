"""Micrograph pipeline validated on a synthetic histology phantom with known truth.

phantom (known fractions, cell axes) -> misregistered Mallory-trichrome sections -> registration ->
colour segmentation -> point grid on SURS sections + cell tracing -> stereology estimates (V_V +
CE, L_V, three directions) -> bootstrap replicates, each compared with the truth.

Two phantoms: the default one (SMC 58.9 % of tissue, which random packing of 72 x 6 um spindles
only reaches with up to 25 % interpenetration, so that touching cells merge) and a "separable"
one (SMC 42 %, 1 um gaps and seams between touching cells) on which tracing is checked alone.
Both are repeated over further seeds (pipeline + a single Watson-mixture fit, no bootstrap), and
the L_V error is split into its parts: tracing the true section planes (no rendering, registration
or segmentation) and the grazing loss of one isolated in-plane cell traced from 5 um planes.

Writes figures/micrographs_validation.png, figures/micrographs_overlay.png and
figures/micrographs_validation.md.

    python studies/micrograph_validation.py [--quick | --full] [--seed 1]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from bayestissue.plotting.micrographs import plot_overlay
from bayestissue.stereology.axial import axial_angle, fit_watson_mixture
from bayestissue.stereology.micrographs import analyse_micrographs
from bayestissue.stereology.micrographs.gridcount import count_points
from bayestissue.stereology.micrographs.phantom import SMC, PhantomOptions, _ellipsoid_voxels, make_phantom
from bayestissue.stereology.micrographs.registration import displacement_error_px
from bayestissue.stereology.micrographs.render import render_sections, section_phantom, stack_frame
from bayestissue.stereology.micrographs.segmentation import confusion_matrix, label_fractions
from bayestissue.stereology.micrographs.tracing import trace_cells
from bayestissue.stereology.replicates import direction_bootstrap, fraction_replicates
from bayestissue.stereology.rose import lambert_project
from bayestissue.stereology.sections import surs_indices
from bayestissue.stereology.uncertainty import align_axes

FIG = Path(__file__).resolve().parents[1] / "figures"
SIZES = {  # extent (z, y, x) um at 1 um voxels, bootstrap size, SURS repeats, seeds per phantom
    "quick": ((30.0, 70.0, 70.0), 50, 20, 1),
    "default": ((80.0, 120.0, 120.0), 300, 200, 3),
    "full": ((160.0, 200.0, 200.0), 1000, 500, 8),
}


def _truth_in_field(phantom, stack, valid):
    """True fractions and L_V of the probed block: camera field (valid part) x stack depth; also L_V of
    the visible axis (inside each cell's own voxels, TissuePhantom.length_density(visible=True))."""
    m = stack.margin_px
    n, H, W = stack.labels.shape
    depth = int(round(n * stack.thickness_um / phantom.voxel_um))
    block = phantom.components[:depth, m : m + H, m : m + W]
    vf = label_fractions(block, valid=valid)
    ys, xs = np.nonzero(valid)
    box = (
        np.array(
            [
                [m + xs.min(), m + xs.max() + 1],
                [m + ys.min(), m + ys.max() + 1],
                [0, depth],
            ],
            dtype=float,
        )
        * phantom.voxel_um
    )
    return vf, phantom.length_density(box), phantom.length_density(box, visible=True)


def _lv_bootstrap(traced, n_boot, rng):
    ids, inv = np.unique(traced.cell_id, return_inverse=True)
    per_cell = np.bincount(inv, weights=traced.lengths_um)
    draws = rng.integers(0, len(ids), size=(n_boot, len(ids)))
    return per_cell[draws].sum(axis=1) / traced.volume_um3


def run_chain(options, *, seed, n_boot, n_surs, period=2, grid_um=8.0):
    """One full chain; returns a dict of estimates, truths and timings."""
    rng = np.random.default_rng(seed)
    t = {}
    t0 = time.perf_counter()
    phantom = make_phantom(options, rng=seed)
    t["phantom_s"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    stack = render_sections(phantom, thickness_um=5.0, axis="z", rng=seed)
    t["render_s"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    res = analyse_micrographs(
        stack.images, pixel_um=1.0, thickness_um=5.0, grid_spacing_um=grid_um, period=period,
        rng=rng,
    )  # fmt: skip
    t["pipeline_s"] = time.perf_counter() - t0
    reg = res.registered
    out = {"phantom": phantom, "stack": stack, "res": res, "timing": t}
    out["reg_err_px"] = displacement_error_px(reg.transforms, stack.transforms, stack.images.shape[1:3], mask=reg.valid)
    vf_true, lv_true, _ = _truth_in_field(phantom, stack, reg.valid)
    out["vf_true"], out["lv_true"] = vf_true, lv_true
    # segmentation error: registered labels against the true planes of the reference frame
    planes, _ = section_phantom(phantom, thickness_um=5.0)
    m = stack.margin_px
    ref = planes[:, m : m + stack.labels.shape[1], m : m + stack.labels.shape[2]]
    seg_vf = label_fractions(res.segmentation.labels, valid=reg.valid)
    plane_vf = label_fractions(ref, valid=reg.valid)
    out["seg_err"] = {k: seg_vf[k] - plane_vf[k] for k in seg_vf}
    out["confusion"] = confusion_matrix(res.segmentation.labels, ref, valid=reg.valid)
    # point counting: estimate, CE predictors, parametric bootstrap
    pc = res.point_counts()
    out["summary"] = pc.summary()
    out["vv_boot"] = fraction_replicates(pc, n_boot=n_boot, rng=rng)
    # true spread of V_V over SURS starts and grid offsets, on the same segmentation
    vv = []
    for _ in range(n_surs):
        secs = surs_indices(len(stack.images), period, rng=rng)
        g = count_points(res.segmentation.labels, spacing_px=grid_um, sections=secs,
                         valid=reg.valid, rng=rng)  # fmt: skip
        vv.append(g.volume_fractions()["smc_tissue"])
    out["vv_surs"] = np.array(vv)
    # lines: L_V and its cell bootstrap; directions with cones
    out["lv"] = res.traced.length_density()
    out["lv_boot"] = _lv_bootstrap(res.traced, n_boot, rng)
    lines = res.line_system()
    t0 = time.perf_counter()
    out["dirs"] = direction_bootstrap(lines, method="watson", n_boot=min(n_boot, 50), rng=rng)
    t["directions_s"] = time.perf_counter() - t0
    true_axes = np.array([stack_frame("z") @ np.asarray(a) for a in options.axes])
    al, _ = align_axes(out["dirs"]["axes"], true_axes)
    out["true_axes"] = true_axes
    out["dir_err_deg"] = axial_angle(al, true_axes)
    return out


def seed_row(options, *, seed, grid_um=8.0, chain=None):
    """Pipeline on one seed (or the outputs of :func:`run_chain`): registration, V_V, L_V (also
    traced on the true planes, with and without the profile cores) and the direction errors of
    one Watson-mixture fit (no bootstrap)."""
    if chain is None:
        phantom = make_phantom(options, rng=seed)
        stack = render_sections(phantom, thickness_um=5.0, axis="z", rng=seed)
        res = analyse_micrographs(stack.images, pixel_um=1.0, thickness_um=5.0,
                                  grid_spacing_um=grid_um, rng=seed)  # fmt: skip
    else:
        phantom, stack, res = chain["phantom"], chain["stack"], chain["res"]
    reg = res.registered
    err = displacement_error_px(reg.transforms, stack.transforms, stack.images.shape[1:3], mask=reg.valid)
    vf, lv, lv_vis = _truth_in_field(phantom, stack, reg.valid)
    planes, _ = section_phantom(phantom, thickness_um=5.0)
    m = stack.margin_px
    ref = planes[:, m : m + stack.labels.shape[1], m : m + stack.labels.shape[2]] == SMC
    on_truth = trace_cells(ref, spacing_um=(5.0, 1.0, 1.0), valid=reg.valid, rng=seed)
    on_truth0 = trace_cells(ref, spacing_um=(5.0, 1.0, 1.0), valid=reg.valid, rng=seed, core_px=0)
    corr = trace_cells(res.segmentation.labels == SMC, spacing_um=(5.0, 1.0, 1.0), valid=reg.valid, rng=seed,
                       end_correction=True)  # fmt: skip
    tr = res.traced
    mix = fit_watson_mixture(tr.directions, 3, weights=tr.lengths_um, rng=0)
    true_axes = np.array([stack_frame("z") @ np.asarray(a) for a in options.axes])
    al, _ = align_axes(mix.axes, true_axes)
    return {
        "seed": seed,
        "reg_max_px": float(err.max()),
        "vv_err": res.point_counts().summary()["smc"]["V_V"] - vf["smc_tissue"],
        "lv_err_pct": 100 * (tr.length_density() / lv - 1),
        "lv_visible_err_pct": 100 * (tr.length_density() / lv_vis - 1),
        "visible_share": lv_vis / lv,
        "lv_true_planes_err_pct": 100 * (on_truth.length_density() / lv - 1),
        "lv_true_planes0_err_pct": 100 * (on_truth0.length_density() / lv - 1),
        "lv_corr_err_pct": 100 * (corr.length_density() / lv - 1),
        "dir_err_deg": axial_angle(al, true_axes),
    }


def grazing_loss(*, thickness_um=5.0, n_offsets=20, core_px=0):
    """Traced length / true length of one isolated in-plane cell (72 x 6 um spindle, 1 um voxels)
    cut by planes every ``thickness_um``, averaged over the plane offset; and the spindle model's
    value 2 a E[s], :math:`s = \\sqrt{1 - h^2/b^2}`, h ~ U[0, T/2] the axis' distance to the
    nearest plane (the profile of a grazed spindle is shortened by s)."""
    a, b = 36.0, 3.0
    shape = (50, 20, 90)
    ratios = []
    for h in np.arange(n_offsets) * thickness_um / n_offsets:
        vol = np.zeros(shape, bool)
        vol[_ellipsoid_voxels(np.array([45.0, 10.0, 20.0 + h]), np.array([1.0, 0, 0]), a, b, shape, 1.0)] = True
        planes = np.floor((np.arange(int(shape[0] // thickness_um)) + 0.5) * thickness_um).astype(int)
        tc = trace_cells(vol[planes], spacing_um=(thickness_um, 1.0, 1.0), piece_length_um=200.0,
                         core_px=core_px)  # fmt: skip
        ratios.append(tc.lengths_um.sum() / (2 * a))
    u = np.linspace(0, min(thickness_um / 2, b), 2001)
    model = float(np.mean(np.sqrt(1 - (u / b) ** 2)))
    return float(np.mean(ratios)), model


def _figure(main, sep):
    fig = plt.figure(figsize=(14, 8.5), constrained_layout=True)
    gs = fig.add_gridspec(2, 3)
    # (a) volume fractions
    ax = fig.add_subplot(gs[0, 0])
    s = main["summary"]
    names = [("smc", "smc_tissue"), ("ecm", "ecm_tissue")]
    for i, (c, key) in enumerate(names):
        est = s[c]["V_V"]
        ce = s[c]["CE_q_hat"] if np.isfinite(s[c]["CE_q_hat"]) else s[c]["CE_m1"]
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
    ax.legend(fontsize=7)
    # (b) L_V
    ax = fig.add_subplot(gs[0, 1])
    for i, r in enumerate((main, sep)):
        if r is None:
            continue
        lo, hi = np.quantile(r["lv_boot"], [0.025, 0.975])
        ax.errorbar(i, r["lv"], yerr=[[r["lv"] - lo], [hi - r["lv"]]], fmt="o", capsize=4,
                    color="C0", label="traced (cell bootstrap 95 %)" if i == 0 else None)  # fmt: skip
        ax.plot(i, r["lv_true"], "k_", ms=30, mew=2, label="truth" if i == 0 else None)
        ax.fill_between([i - 0.25, i + 0.25], 0.85 * r["lv_true"], 1.15 * r["lv_true"],
                        color="0.85", label="truth +- 15 %" if i == 0 else None)  # fmt: skip
    ax.set_xticks([0, 1], ["default\n58.9 % SMC", "separable\n42 % SMC"])
    ax.set_xlim(-0.6, 1.6)
    ax.set_ylabel("L_V (um^-2)")
    ax.set_title("(b) length density")
    ax.legend(fontsize=7)
    # (c) registration error
    ax = fig.add_subplot(gs[0, 2])
    for r, name, c in ((main, "default", "C0"), (sep, "separable", "C2")):
        if r is not None:
            ax.plot(r["reg_err_px"], "o-", color=c, label=name)
    ax.axhline(1.0, color="k", ls="--", lw=1, label="1 px")
    ax.set_xlabel("section")
    ax.set_ylabel("mean displacement error (px)")
    ax.set_title("(c) registration error\n(template of 3 sections)")
    ax.legend(fontsize=7)
    # (d, e) directions: Lambert equal-area of traced pieces, estimated axes, truth
    for k, (r, name) in enumerate(((main, "default"), (sep, "separable"))):
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
        for j in range(3):
            ax.annotate(f"{r['dir_err_deg'][j]:.1f} deg (cone {r['dirs']['cone_deg'][j]:.1f})",
                        est[j], fontsize=7, xytext=(4, 4), textcoords="offset points")  # fmt: skip
        ax.add_patch(plt.Circle((0, 0), np.sqrt(2), fill=False, color="0.5"))
        ax.set_aspect("equal")
        ax.set_xlim(-1.5, 1.5)
        ax.set_ylim(-1.5, 1.5)
        ax.set_title(f"({'de'[k]}) directions, {name} phantom\n(Lambert equal-area, upper half)")
        ax.legend(fontsize=7, loc="lower left")
    # (f) V_V over SURS repeats vs predicted CE
    ax = fig.add_subplot(gs[1, 2])
    vv = main["vv_surs"]
    ax.hist(vv, bins=20, color="C0", alpha=0.6, label="V_V(SMC) over SURS starts")
    s_smc = main["summary"]["smc"]
    for key, c in (("CE_m1", "C1"), ("CE_q_hat", "C3"), ("CE_classic", "C4")):
        sd = s_smc[key] * s_smc["V_V"]
        if np.isfinite(sd):
            ax.axvspan(vv.mean() - sd, vv.mean() + sd, color=c, alpha=0.15, label=f"+-1 {key}")
    ax.axvline(main["vf_true"]["smc_tissue"], color="k", lw=2, label="truth")
    ax.set_xlabel("V_V(SMC, tissue)")
    ax.set_title("(f) SURS spread vs predicted CE\n(one sample)")
    ax.legend(fontsize=7)
    return fig


def _ranges(seed_rows, key):
    """'name [min, max]' of a seed-table column, per phantom."""
    return ", ".join(
        f"{name} [{min(r[key] for r in rs):+.1f}, {max(r[key] for r in rs):+.1f}]" for name, rs in seed_rows.items()
    )


def _md(main, sep, args, elapsed, seed_rows, graze):
    L = ["# Micrograph pipeline on a synthetic histology phantom (synthetic data)", ""]
    L.append(f"Run: `python studies/micrograph_validation.py {' '.join(args)}`; {elapsed:.0f} s.")
    for name, r in (("default", main), ("separable", sep)):
        if r is None:
            continue
        o = r["phantom"].options
        st = r["stack"]
        L += ["", f"## {name} phantom", ""]
        L.append(
            f"- block {o.extent_um} um (z, y, x) at {o.voxel_um} um voxels, SMC {o.smc_fraction} "
            f"of tissue, cavities {o.cavity_fraction:.3f}, max_overlap {o.max_overlap}, "
            f"gap {o.gap_um} um, seams {o.seams}; {len(r['phantom'].segments_um)} cells"
        )
        L.append(
            f"- {st.images.shape[0]} sections of 5 um, {st.images.shape[1]} x "
            f"{st.images.shape[2]} px at 1 um/px; timings: " + ", ".join(f"{k} {v:.1f}" for k, v in r["timing"].items())
        )
        e = r["reg_err_px"]
        L.append(f"- registration error: mean {e.mean():.2f} px, max {e.max():.2f} px")
        s = r["summary"]["smc"]
        se = r["seg_err"]["smc_tissue"]
        vt = r["vf_true"]["smc_tissue"]
        ce = s["CE_q_hat"] if np.isfinite(s["CE_q_hat"]) else s["CE_m1"]
        lo, hi = np.quantile(r["vv_boot"]["smc"], [0.025, 0.975])
        L.append(
            f"- V_V(SMC, tissue): estimate {s['V_V']:.3f}, truth {vt:.3f} (error "
            f"{s['V_V'] - vt:+.3f}); CE_q_hat {s['CE_q_hat']:.3f}, CE_m1 {s['CE_m1']:.3f}, "
            f"CE_classic {s['CE_classic']:.3f}; 2 CE x V_V + |segmentation error| = "
            f"{2 * ce * s['V_V'] + abs(se):.3f}; bootstrap 95 % [{lo:.3f}, {hi:.3f}]"
        )
        L.append(
            f"- segmentation error (pixel fractions of the registered sections minus the true "
            f"planes): SMC/tissue {se:+.3f}, cavity/total {r['seg_err']['cavity_total']:+.3f}; "
            f"pixel accuracy {np.trace(r['confusion']) / r['confusion'].sum():.3f}"
        )
        rows = r["res"].sensitivity
        base = rows[0]["smc_tissue"]
        sens = ", ".join(f"{x['threshold']} {x['rel_shift']:+.1f}: {x['smc_tissue'] - base:+.3f}" for x in rows[1:])
        L.append(f"- threshold sensitivity of V_V(SMC, tissue) (shift x class gap): {sens}")
        vv = r["vv_surs"]
        L.append(
            f"- over {len(vv)} SURS starts + grid offsets: sd(V_V) {vv.std(ddof=1):.4f} vs "
            f"predicted CE_q_hat x V_V {s['CE_q_hat'] * s['V_V']:.4f}, CE_m1 x V_V "
            f"{s['CE_m1'] * s['V_V']:.4f}"
        )
        lo, hi = np.quantile(r["lv_boot"], [0.025, 0.975])
        L.append(
            f"- L_V: traced {r['lv']:.4f} um^-2 (cell bootstrap 95 % [{lo:.4f}, {hi:.4f}]), "
            f"truth {r['lv_true']:.4f}; error {100 * (r['lv'] / r['lv_true'] - 1):+.1f} %; "
            f"{np.unique(r['res'].traced.cell_id).size} traced cells, "
            f"{len(r['res'].traced.cell_id)} segments"
        )
        d = r["dirs"]
        L.append(
            "- directions (Watson mixture, stack frame = phantom frame): errors "
            + ", ".join(f"{x:.1f}" for x in r["dir_err_deg"])
            + " deg; 95 % cones "
            + ", ".join(f"{x:.1f}" for x in d["cone_deg"])
            + " deg; shares "
            + ", ".join(f"{x:.2f}" for x in d["shares"])
        )
    L += ["", "## Over seeds (pipeline; directions from one Watson-mixture fit, no bootstrap)", ""]
    L.append("| phantom | seed | registration max (px) | V_V error | L_V error (%) | L_V error, true planes "
             "(%) | L_V error, true planes, core_px=0 (%) | L_V error, end-corrected (%) | "
             "visible axis / truth | L_V error vs visible axis (%) | direction errors (deg) |")  # fmt: skip
    L.append("|---|---|---|---|---|---|---|---|---|---|---|")
    for name, rs in seed_rows.items():
        for r in rs:
            L.append(
                f"| {name} | {r['seed']} | {r['reg_max_px']:.2f} | {r['vv_err']:+.3f} | "
                f"{r['lv_err_pct']:+.1f} | {r['lv_true_planes_err_pct']:+.1f} | "
                f"{r['lv_true_planes0_err_pct']:+.1f} | {r['lv_corr_err_pct']:+.1f} | "
                f"{r['visible_share']:.3f} | {r['lv_visible_err_pct']:+.1f} | "
                + ", ".join(f"{x:.1f}" for x in r["dir_err_deg"])
                + " |"
            )
    n_ok = {k: sum(bool(np.all(r["dir_err_deg"] < 10)) for r in v) for k, v in seed_rows.items()}
    lv_ok = {k: sum(abs(r["lv_err_pct"]) < 15 for r in v) for k, v in seed_rows.items()}
    L += [
        "",
        "Seeds with all three directions within 10 deg: "
        + ", ".join(f"{k} {n_ok[k]}/{len(seed_rows[k])}" for k in seed_rows)
        + "; with L_V within 15 %: "
        + ", ".join(f"{k} {lv_ok[k]}/{len(seed_rows[k])}" for k in seed_rows)
        + ".",
        "",
        "## Why L_V is not met",
        "",
        f"- Grazing loss (no image processing): one isolated in-plane cell (72 x 6 um) traced from "
        f"5 um planes, averaged over the plane offset, gives {100 * graze[0]:.1f} % of its length "
        f"traced on the full profiles (core_px=0) and {100 * graze[2]:.1f} % on the profile cores "
        f"(core_px=1, the pipeline's default: thin grazed profiles lose more to the erosion); the "
        f"spindle model 2 a E[s] gives {100 * graze[1]:.1f} %. A spindle lying in the section plane is "
        "seen only where a plane cuts it, and a plane at distance h from its axis shows a profile "
        "shortened by s = sqrt(1 - h^2 / b^2): with the plane spacing (5 um) close to the cell "
        "diameter (6 um) this bias alone uses most of the 15 % allowed.",
        "- Tracing the true section planes (perfect registration and segmentation) with the same "
        "tracer: L_V error " + _ranges(seed_rows, "lv_true_planes_err_pct") + " %; without the profile "
        "cores (core_px=0) "
        + _ranges(seed_rows, "lv_true_planes0_err_pct")
        + " %; the pipeline: "
        + _ranges(seed_rows, "lv_err_pct")
        + " %. On the separable phantom the true planes traced without cores come within the "
        "grazing loss; the loss in the pipeline comes from the 1-voxel seams between touching "
        "cells, which the blur (0.8 px) closes: without cores the segmentation's merged cells make "
        "L_V erratic, with cores the erosion removes the seam-thinned profiles (seeds 1-3, measured "
        "while preparing this report: blur 0 and core_px=0 -14, -1, -9 %; blur 0.8 and core_px=0 "
        "-26, -16, -1 %; blur 0.8 and core_px=1, the pipeline, -19, -20, -25 %; blur 0 and "
        "core_px=1 -28, -28, -29 %). On the default phantom the cells interpenetrate (random packing "
        "reaches 58.9 % only with up to 25 % overlap): overlapping cells are one object in the truth "
        "as well, and even the true planes are traced with errors that spread widely between seeds.",
        "- Correcting the grazing loss per cell needs the cell radius to about 10 % (L_V ~ 1/s, "
        "s from the profile width); at 1 um pixels and 3 um radii, with merged profiles, it was "
        "not measurable (a width-based correction gave -25 % to +17 % for width quantiles 0.5 to 0.9, seeds 1-4). "
        "The geometric end correction (trace_cells(end_correction=True), off by default; the "
        "expected deficit per tip of a prolate spheroid cut by planes every T, with the radius "
        "measured as sqrt(5 lambda_perp) on the traced line-like cells) brings the isolated "
        "in-plane cell from 0.85 to 1.02 of its length, but on the pipeline it gives "
        + _ranges(seed_rows, "lv_corr_err_pct")
        + " % (column 'end-corrected'; seeds 1-6 measured while preparing this report: default "
        "+22, +4, -10, -1, -24, +32 %, separable +11, +4, -1, +23, +4, +28 %): most of the length "
        "comes from the volume rule for merged regions, whose cross-section is measured on cell "
        "fragments about 16 um long (cut by sinuses, the field edge or the linking) whose cut ends "
        "are corrected as if they were tips, and the seed-to-seed spread of that cross-section "
        "dominates. The phantom's truth also counts the axis length hidden in interpenetrating "
        "cells: the cells' own voxels per um of true axis are 15.0 um^2 (default) and 14.7 um^2 "
        "(separable) against 19.6 um^2 for an isolated voxel spindle (seed 1), so any estimate from "
        "the visible SMC volume misses about 20 %. "
        "Packing aligned spindles in bundles (a staggered lattice per bundle) reached at most "
        "0.586 of the tissue in one unbounded bundle at 1 um voxels and 0.20 to 0.45 with "
        "bundle borders and sinuses, short of 58.9 % without overlap (measured while preparing "
        "this report; not in the package).",
        "- The truth is defined by the phantom, not by the images: against the visible axis only (the "
        "part of each cell's axis inside its own voxels, TissuePhantom.length_density(visible=True); "
        "visible share of the true axis length "
        + ", ".join(
            f"{k} {min(r['visible_share'] for r in v):.2f}-{max(r['visible_share'] for r in v):.2f}"
            for k, v in seed_rows.items()
        )
        + ") the pipeline's L_V error is "
        + _ranges(seed_rows, "lv_visible_err_pct")
        + " %. Which truth the 15 % target refers to (the full axes of interpenetrating rigid "
        "spindles, their visible part, or a phantom whose cells deform instead of overlapping) is a "
        "decision for the issue's owners; the pass count above uses the full axes.",
    ]
    L += ["", "![validation](micrographs_validation.png)", "",
          "![overlay](micrographs_overlay.png)", ""]  # fmt: skip
    return "\n".join(L)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    g = ap.add_mutually_exclusive_group()
    g.add_argument("--quick", action="store_true", help="CI smoke run (small phantom)")
    g.add_argument("--full", action="store_true", help="bigger phantom, more replicates")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--no-separable", action="store_true", help="skip the separable phantom")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    size = "quick" if args.quick else "full" if args.full else "default"
    extent, n_boot, n_surs, n_seeds = SIZES[size]
    main_opts = PhantomOptions(extent_um=extent)
    main_run = run_chain(main_opts, seed=args.seed, n_boot=n_boot, n_surs=n_surs)
    sep = None
    sep_opts = PhantomOptions(extent_um=extent, smc_fraction=0.42, gap_um=1.0, seams=True)
    if not args.no_separable:
        sep = run_chain(sep_opts, seed=args.seed, n_boot=n_boot, n_surs=n_surs)
    seeds = range(args.seed, args.seed + n_seeds)
    rows = {"default": [seed_row(main_opts, seed=k, chain=main_run if k == args.seed else None) for k in seeds]}
    if not args.no_separable:
        rows["separable"] = [seed_row(sep_opts, seed=k, chain=sep if k == args.seed else None) for k in seeds]
    graze = grazing_loss(core_px=0) + grazing_loss(core_px=1)[:1]
    FIG.mkdir(exist_ok=True)
    fig = _figure(main_run, sep)
    fig.savefig(FIG / "micrographs_validation.png", dpi=110)
    res = main_run["res"]
    k = int(res.grid.section[0])
    fig = plot_overlay(
        res.registered.images[k], res.segmentation.labels[k], pixel_um=1.0,
        points=res.grid.points[0], segments_um=res.traced.segments_um,
        section_z_um=(k + 0.5) * 5.0, thickness_um=5.0, valid=res.registered.valid,
        title=f"default phantom, registered section {k} (synthetic)",
    )  # fmt: skip
    fig.savefig(FIG / "micrographs_overlay.png", dpi=110)
    elapsed = time.perf_counter() - t0
    md = _md(main_run, sep, argv if argv is not None else [], elapsed, rows, graze)
    (FIG / "micrographs_validation.md").write_text(md)
    print(md)
    print(f"micrograph_validation ({size}) took {elapsed:.1f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
