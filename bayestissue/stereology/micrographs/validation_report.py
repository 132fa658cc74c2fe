"""The validation table of the micrograph pipeline (``figures/micrographs_validation.md``) as markdown text."""

from __future__ import annotations

import numpy as np

__all__ = ["validation_markdown"]


def _ranges(seed_rows, key):
    """'name [min, max]' of a seed-table column, per phantom."""
    return ", ".join(
        f"{name} [{min(r[key] for r in rs):+.1f}, {max(r[key] for r in rs):+.1f}]" for name, rs in seed_rows.items()
    )


def validation_markdown(main, sep, args, elapsed, seed_rows, graze) -> str:
    """Markdown of the chain results ``main``/``sep`` (:func:`~.validation.run_chain`), the seed table and the
    grazing-loss measurements."""
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
