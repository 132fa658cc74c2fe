"""``bayestissue micrographs ...``: synthetic trichrome stacks and the micrograph pipeline.

Examples::

    bayestissue micrographs phantom phantom_dir --seed 1
    bayestissue micrographs analyse phantom_dir --pixel-size-um 1 --section-thickness-um 5 \\
        --out results_dir --grid-spacing-um 10 --period 2

``analyse`` registers the sections, segments them by colour, counts a random-offset point grid on a
systematic sample of sections and traces the muscle cells, then writes ``point_counts.csv``,
``lines.csv`` (+ ``lines.toml``, the probed volume), ``registration.csv``,
``segmentation_sensitivity.csv``, ``summary.json`` and ``overlay.png`` into ``--out``. The source is a folder of
PNG, JPEG or TIFF sections or one multi-page TIFF; the pixel size is ``--pixel-size-um`` or, without it, the one
the (first) TIFF's metadata states (resolution tags or ImageJ's unit); PNG and JPEG state none.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from bayestissue._validation import ValidationError
from bayestissue.cli import plain, progress_bar, seed
from bayestissue.io.micrographs import read_micrographs, write_micrographs, write_truth
from bayestissue.io.stereology_files import write_line_system
from bayestissue.io.tables import write_table
from bayestissue.stereology.micrographs.gridcount import write_grid_counts
from bayestissue.stereology.micrographs.phantom import PhantomOptions, make_phantom
from bayestissue.stereology.micrographs.pipeline import analyse_micrographs
from bayestissue.stereology.micrographs.registration import rigid_params
from bayestissue.stereology.micrographs.render import StainOptions, render_sections
from bayestissue.stereology.micrographs.segmentation import (
    check_rgb_stack,
    label_fractions,
)

__all__ = ["register", "run", "write_phantom_stack"]


def write_phantom_stack(outdir, *, seed=None, options=None, thickness_um=5.0, axis="z", fmt="png"):
    """Generate a phantom, render it and write the images plus ``truth.json`` into ``outdir``."""
    phantom = make_phantom(options, rng=seed)
    stack = render_sections(phantom, thickness_um=thickness_um, axis=axis, stain=StainOptions(), rng=seed)
    paths = write_micrographs(outdir, stack.images, fmt=fmt)
    truth = phantom.truth()
    truth["sections"] = stack.truth()
    truth["generator"] = "bayestissue micrographs phantom (synthetic Mallory trichrome)"
    write_truth(Path(outdir) / "truth.json", truth)
    return phantom, stack, paths


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "micrographs",
        help="synthetic trichrome stacks; register, segment, count and trace micrographs",
        description=plain(__doc__.splitlines()[0]),
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog=plain(__doc__.split("Examples::", 1)[1]),
    )
    sub = p.add_subparsers(dest="micrographs_command", required=True)
    g = sub.add_parser("phantom", help="write a synthetic serial-section stack and its truth")
    g.add_argument("outdir", help="folder for the sections and truth.json (created)")
    g.set_defaults(outputs={"OUTDIR": ("outdir", "dir")})
    g.add_argument("--seed", type=seed, default=1, help="phantom seed (default 1); same seed, same stack")
    g.add_argument(
        "--extent-um",
        type=float,
        nargs=3,
        default=(60.0, 100.0, 100.0),
        metavar=("Z", "Y", "X"),
        help="phantom size in um (default 60 100 100)",
    )
    g.add_argument("--voxel-um", type=float, default=1.0, help="voxel = pixel size in um (default 1)")
    g.add_argument(
        "--smc-fraction",
        type=float,
        default=0.589,
        help="smooth-muscle volume fraction of the tissue without cavities (default 0.589, the paper's)",
    )
    g.add_argument("--section-thickness-um", type=float, default=5.0, help="section thickness in um (default 5)")
    g.add_argument("--axis", choices=("z", "y", "x"), default="z", help="sections normal to this axis (default z)")
    g.add_argument(
        "--format",
        choices=("png", "tiff"),
        default="png",
        help="one PNG per section, or one multi-page TIFF (default png)",
    )
    a = sub.add_parser("analyse", help="run the pipeline on a folder or multi-page TIFF")
    a.add_argument("source", help="folder of PNG/JPEG/TIFF sections or a multi-page TIFF")
    a.add_argument(
        "--pixel-size-um",
        type=float,
        help="pixel size in um (default: the one the TIFF metadata states; required for PNG/JPEG or a TIFF without)",
    )
    a.add_argument("--section-thickness-um", type=float, required=True)
    a.add_argument("--out", required=True, help="output folder")
    a.set_defaults(outputs={"--out": ("out", "dir")})
    a.add_argument("--grid-spacing-um", type=float, default=10.0)
    a.add_argument("--period", type=int, default=2, help="count every k-th section")
    a.add_argument("--method", choices=("deconvolution", "lab"), default="deconvolution")
    a.add_argument("--seed", type=seed, default=0)
    a.add_argument("--overlay-section", type=int, default=None, help="default: first counted")
    a.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def run(args) -> int:
    from bayestissue._validation import check_positive

    check_positive("--section-thickness-um", args.section_thickness_um)  # before any work (35 s of phantom before)
    if args.micrographs_command == "phantom":
        t0 = time.perf_counter()
        opts = PhantomOptions(extent_um=tuple(args.extent_um), voxel_um=args.voxel_um, smc_fraction=args.smc_fraction)
        phantom, stack, paths = write_phantom_stack(
            args.outdir,
            seed=args.seed,
            options=opts,
            thickness_um=args.section_thickness_um,
            axis=args.axis,
            fmt=args.format,
        )
        vf = phantom.volume_fractions()
        print(
            f"wrote {stack.images.shape[0]} sections {stack.images.shape[1:3]} px "
            f"({len(paths)} file(s)) and truth.json to {args.outdir}; SMC {vf['smc_tissue']:.3f} "
            f"of tissue, L_V {phantom.length_density():.4f} um^-2 "
            f"({time.perf_counter() - t0:.1f} s)"
        )
        return 0
    return _run_analyse(args)


def _pixel_size(source, given: float | None) -> float:
    """``--pixel-size-um``, else what the (first) TIFF states; a one-line refusal when neither gives one. The source
    is checked first (it exists, holds sections, each file starts as its format does), so that a bad source is named
    as such, not as a missing pixel size."""
    from bayestissue._validation import ValidationError, check_positive
    from bayestissue.io.micrographs import stack_files, tiff_pixel_size_um

    files = stack_files(source)
    first = files[0]  # the reader's order: the first section is the one whose metadata counts
    tiffs = [f for f in files if f.suffix.lower() in (".tif", ".tiff")]
    if given is not None:
        given = check_positive("--pixel-size-um", given)
        stated = tiff_pixel_size_um(first, check=False) if first in tiffs else None
        if stated is not None and abs(stated / given - 1) > 1e-3:
            print(f"note: using --pixel-size-um {given:g}; {first.name} states {stated:.6g} um", file=sys.stderr)
        return given
    stated = tiff_pixel_size_um(first) if first in tiffs else None
    for other in tiffs[1:]:  # every section of a folder must state the same size (or none)
        size = tiff_pixel_size_um(other)
        if size is not None and stated is not None and abs(size / stated - 1) > 1e-6:
            raise ValidationError(f"{other.name} pixel size", f"{size:.6g} um",
                                  f"the {stated:.6g} um of {first.name} (one pixel size per stack)")  # fmt: skip
    if stated is None:
        raise ValidationError(
            "--pixel-size-um", "not given", "the pixel size in um", f"{first.name} states none in its metadata"
        )
    print(f"pixel size {stated:.6g} um, from the metadata of {first.name}", file=sys.stderr)
    return stated


def _run_analyse(args) -> int:
    from bayestissue.plotting.micrographs import plot_overlay

    t0 = time.perf_counter()
    args.pixel_size_um = _pixel_size(args.source, args.pixel_size_um)
    images, names = read_micrographs(args.source)
    imgs = check_rgb_stack(images)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    with progress_bar(args, total=len(imgs) + 2, desc="micrographs", unit="step") as bar:
        res = analyse_micrographs(
            imgs,
            pixel_um=args.pixel_size_um,
            thickness_um=args.section_thickness_um,
            grid_spacing_um=args.grid_spacing_um,
            period=args.period,
            method=args.method,
            rng=args.seed,
            progress=bar.update,
            stage=bar.set_description,
        )
    meta = {"source": str(args.source), "pixel_um": args.pixel_size_um, "seed": args.seed}
    write_grid_counts(out / "point_counts.csv", res.grid, pixel_um=args.pixel_size_um, meta=meta)
    tr = res.traced
    write_line_system(
        out / "lines.csv",
        tr.segments_um[:, 0],
        tr.segments_um[:, 1],
        tr.cell_id,
        sidecar={
            "volume_um3": tr.volume_um3,
            "n_sections": len(imgs),
            "section_thickness_um": args.section_thickness_um,
            "frame": "stack: x = image column, y = image row, z = section index (um)",
        },
        meta=meta,
    )
    pars = np.array([rigid_params(T, imgs.shape[1:3]) for T in res.registered.transforms])
    write_table(
        out / "registration.csv",
        {
            "section": np.arange(len(imgs)),
            "file": np.array(names),
            "angle_deg": pars[:, 0],
            "tx_px": pars[:, 1],
            "ty_px": pars[:, 2],
        },
        meta={"transform": "reference (section 0) pixel -> section pixel, about the image centre"},
    )
    sens = res.sensitivity
    write_table(
        out / "segmentation_sensitivity.csv",
        {k: np.array([r[k] for r in sens]) for k in sens[0]},
        meta={"method": res.segmentation.method, "rel_shift_unit": "class-median gap"},
    )
    pc = res.point_counts()
    summary = {
        "n_sections": len(imgs),
        "sampled_sections": res.grid.section.tolist(),
        "volume_fractions_points": res.grid.volume_fractions(),
        "point_counting": pc.summary(),
        "pixel_fractions": label_fractions(res.segmentation.labels, valid=res.registered.valid),
        "thresholds": res.segmentation.thresholds,
        "length_density_per_um2": tr.length_density(),
        "total_length_um": float(tr.lengths_um.sum()),
        "volume_um3": tr.volume_um3,
        "n_traced_cells": int(np.unique(tr.cell_id).size),
        "n_segments": len(tr.cell_id),
    }
    (out / "summary.json").write_text(json.dumps(summary, indent=1, default=float))
    k = res.grid.section[0] if args.overlay_section is None else args.overlay_section
    if not 0 <= k < len(imgs):
        raise ValidationError("overlay_section", k, f"a section index in [0, {len(imgs) - 1}]")
    j = list(res.grid.section).index(k) if k in res.grid.section else None
    fig = plot_overlay(
        res.registered.images[k],
        res.segmentation.labels[k],
        pixel_um=args.pixel_size_um,
        points=None if j is None else res.grid.points[j],
        segments_um=tr.segments_um,
        section_z_um=(k + 0.5) * args.section_thickness_um,
        thickness_um=args.section_thickness_um,
        valid=res.registered.valid,
        title=f"section {k} ({names[k]})",
    )
    fig.savefig(out / "overlay.png", dpi=110)
    vv = summary["volume_fractions_points"]
    print(
        f"{len(imgs)} sections; SMC {vv['smc_tissue']:.3f} / ECM {vv['ecm_tissue']:.3f} of tissue "
        f"({int(res.grid.counts.sum())} points on {len(res.grid.section)} sections), "
        f"L_V {summary['length_density_per_um2']:.4f} um^-2 from "
        f"{summary['n_traced_cells']} traced cells; wrote {out} "
        f"({time.perf_counter() - t0:.1f} s)"
    )
    return 0
