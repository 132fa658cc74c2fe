"""Micrograph pipeline validated on a synthetic histology phantom with known truth.

phantom (known fractions, cell axes) -> misregistered Mallory-trichrome sections -> registration ->
colour segmentation -> point grid on SURS sections + cell tracing -> stereology estimates (V_V +
CE, L_V, three directions) -> bootstrap replicates, each compared with the truth.

Two phantoms: the default one (SMC 58.9 % of tissue, which random packing of 72 x 6 um spindles
only reaches with up to 25 % interpenetration, so that touching cells merge) and a "separable"
one (SMC 42 %, 1 um gaps and seams between touching cells) on which tracing is checked alone.

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

from bayestissue.cli.micrographs import analyse_micrographs
from bayestissue.plotting.micrographs import plot_overlay
from bayestissue.stereology.axial import axial_angle
from bayestissue.stereology.gridcount import count_points
from bayestissue.stereology.phantom import PhantomOptions, make_phantom
from bayestissue.stereology.registration import displacement_error_px
from bayestissue.stereology.render import render_sections, section_phantom, stack_frame
from bayestissue.stereology.replicates import direction_bootstrap, fraction_replicates
from bayestissue.stereology.rose import lambert_project
from bayestissue.stereology.sections import surs_indices
from bayestissue.stereology.segmentation import confusion_matrix, label_fractions
from bayestissue.stereology.uncertainty import align_axes

FIG = Path(__file__).resolve().parents[1] / "figures"
SIZES = {  # extent (z, y, x) um at 1 um voxels, bootstrap size, SURS repeats
    "quick": ((30.0, 70.0, 70.0), 50, 20),
    "default": ((80.0, 120.0, 120.0), 300, 200),
    "full": ((160.0, 200.0, 200.0), 1000, 500),
}


def _truth_in_field(phantom, stack, valid):
    """True fractions and L_V of the probed block: camera field (valid part) x stack depth."""
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
    return vf, phantom.length_density(box)


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
    vf_true, lv_true = _truth_in_field(phantom, stack, reg.valid)
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
    out["dirs"] = direction_bootstrap(lines, method="watson", n_boot=min(n_boot, 200), rng=rng)
    t["directions_s"] = time.perf_counter() - t0
    true_axes = np.array([stack_frame("z") @ np.asarray(a) for a in options.axes])
    al, _ = align_axes(out["dirs"]["axes"], true_axes)
    out["true_axes"] = true_axes
    out["dir_err_deg"] = axial_angle(al, true_axes)
    return out


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
    ax.set_title("(c) registration error (template of 3 sections)")
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
    ax.set_title("(f) SURS spread vs predicted CE (one sample)")
    ax.legend(fontsize=7)
    return fig


def _md(main, sep, args, elapsed):
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
    extent, n_boot, n_surs = SIZES[size]
    main_run = run_chain(PhantomOptions(extent_um=extent), seed=args.seed, n_boot=n_boot,
                         n_surs=n_surs)  # fmt: skip
    sep = None
    if not args.no_separable:
        sep_opts = PhantomOptions(extent_um=extent, smc_fraction=0.42, gap_um=1.0, seams=True)
        sep = run_chain(sep_opts, seed=args.seed, n_boot=n_boot, n_surs=n_surs)
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
    md = _md(main_run, sep, argv if argv is not None else [], elapsed)
    (FIG / "micrographs_validation.md").write_text(md)
    print(md)
    print(f"micrograph_validation ({size}) took {elapsed:.1f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
