"""``bayestissue stereology ...``: volume fractions, line systems, roses of directions, replicate tables.

Examples::

    bayestissue stereology surs --n-sections 72 --period 6 --seed 1
    bayestissue stereology fractions data/stereology_counts.csv
    bayestissue stereology lines data/stereology_lines.csv
    bayestissue stereology rose data/stereology_lines.csv --n 8 15
    bayestissue stereology replicates data/stereology_counts.csv data/stereology_lines.csv \\
        --n-boot 1000 --split paper --out runs/R.csv
"""

from __future__ import annotations

import argparse
import json

import numpy as np

from bayestissue.cli import plain, seed

__all__ = ["register", "run"]


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "stereology",
        help="volume fractions, length density, rose of directions, replicate tables",
        description=plain(__doc__.splitlines()[0]),
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog=plain(__doc__.split("Examples::", 1)[1]),
    )
    sub = p.add_subparsers(dest="stereology_command", required=True)

    s = sub.add_parser("surs", help="select SURS section indices (random start, every k-th)")
    s.add_argument("--n-sections", type=int, required=True, help="sections in the series")
    s.add_argument("--period", type=int, required=True, help="take every k-th section")
    s.add_argument("--seed", type=seed, default=None)

    f = sub.add_parser("fractions", help="volume fractions and CE predictors from point counts")
    f.add_argument("counts", help="point-count CSV (section, <component>_points ...)")
    f.add_argument("--json", action="store_true", help="print JSON instead of a table")

    ln = sub.add_parser("lines", help="length density, orientation tensor, Watson mixture")
    ln.add_argument("lines", help="line-system CSV (with its .toml sidecar)")
    ln.add_argument("--seed", type=seed, default=0)
    ln.add_argument(
        "--uniform-background",
        action="store_true",
        help="add a uniform component to the mixture (lines traced from packed cells: fragments in every direction)",
    )

    r = sub.add_parser("rose", help="top directions of the equal-area rose for several n")
    r.add_argument("lines", help="line-system CSV")
    r.add_argument("--n", type=int, nargs="+", default=[8, 15], help="parallels = meridians")
    r.add_argument("--top", type=int, default=3)
    r.add_argument("--merge-deg", type=float, default=20.0, help="0 = the paper's literal top cells")
    r.add_argument("--out", default=None, help="write the table as CSV")
    r.set_defaults(outputs={"--out": ("out", "file")})

    b = sub.add_parser("replicates", help="joint bootstrap replicate table for the mechanics")
    b.add_argument("counts")
    b.add_argument("lines")
    b.add_argument("--n-boot", type=int, default=300)
    b.add_argument("--split", choices=("paper", "length"), default="paper")
    b.add_argument(
        "--directions",
        choices=("watson", "watson+uniform", "rose"),
        default="watson",
        help="watson+uniform: with a uniform background component (for lines traced from packed cells)",
    )
    b.add_argument("--rose-n", type=int, default=15, help="n for --directions rose")
    b.add_argument(
        "--fractions",
        choices=("parametric", "cluster", "naive"),
        default="parametric",
        help="fraction bootstrap (naive = labelled comparison only; it overestimates)",
    )
    b.add_argument("--seed", type=seed, default=0)
    b.add_argument("--out", required=True, help="output CSV")
    b.set_defaults(outputs={"--out": ("out", "file")})
    p.set_defaults(func=run)


def run(args) -> int:
    return {
        "surs": _surs,
        "fractions": _fractions,
        "lines": _lines,
        "rose": _rose,
        "replicates": _replicates,
    }[args.stereology_command](args)


def _surs(args) -> int:
    from bayestissue.stereology import surs_indices

    idx = surs_indices(args.n_sections, args.period, rng=args.seed)
    print(" ".join(str(i) for i in idx))
    return 0


def _fractions(args) -> int:
    from bayestissue.stereology import PointCounts

    pc = PointCounts.from_file(args.counts)
    summ = pc.summary()
    if args.json:
        print(json.dumps(summ, indent=2))
        return 0
    keys = ("V_V", "CE_m0", "CE_m1", "CE_q_hat", "q_hat", "CE_classic")
    print(f"{len(pc.section)} sections; reference = {' + '.join(pc.reference_components)}")
    print(f"{'component':<10}" + "".join(f"{k:>12}" for k in keys))
    for c, r in summ.items():
        print(f"{c:<10}" + "".join(f"{r[k]:>12.4f}" for k in keys))
    print("CE_m*: ratio form with covariance and nugget (Gundersen et al. 1999); CE_classic treats")
    print("sections as independent (Cochran) and overestimates for systematic samples.")
    return 0


#: Fewest traced segments for the three-family Watson mixture: it has 14 free parameters (per family an axis, 2, and
#: a concentration; weights summing to one), so fewer segments than 15 cannot determine it.
MIN_SEGMENTS = 15


def _mixture_lines(path):
    """The line system of ``path``, refused in one line if it has too few segments for the three-family mixture."""
    from bayestissue._validation import ValidationError
    from bayestissue.stereology import LineSystem

    ls = LineSystem.from_file(path)
    if len(ls.cell) < MIN_SEGMENTS:
        raise ValidationError(f"{path} rows", f"{len(ls.cell)} segment(s) of {ls.n_cells} cell(s)",
                              f"at least {MIN_SEGMENTS} traced segments for the three fibre families' Watson mixture "
                              "(14 free parameters)")  # fmt: skip
    return ls


def _lines(args) -> int:
    from bayestissue.stereology import (
        azimuth_elevation,
        fit_watson_mixture,
        orientation_tensor,
        principal_axes,
    )

    ls = _mixture_lines(args.lines)
    print(f"{ls.n_cells} cells, {len(ls.cell)} segments, L = {ls.total_length_um:.1f} um")
    if ls.volume_um3 is not None:
        print(f"V = {ls.volume_um3:.1f} um^3, L_V = {ls.length_density():.5f} um^-2 (paper eq. 2)")
    lam, vec = principal_axes(orientation_tensor(ls.directions, ls.lengths))
    print("orientation tensor eigenvalues:", np.round(lam, 4).tolist())
    mix = fit_watson_mixture(ls.directions, 3, weights=ls.lengths, background=args.uniform_background, rng=args.seed)
    az, el = azimuth_elevation(mix.axes)
    bg = f", uniform background weight {mix.background:.3f}" if args.uniform_background else ""
    print(f"Watson mixture (length-weighted EM{bg}):")
    for k in range(3):
        print(
            f"  axis {np.round(mix.axes[k], 4).tolist()}  az {az[k]:6.1f}  el {el[k]:5.1f}  "
            f"kappa {mix.kappas[k]:7.2f}  weight {mix.weights[k]:.3f}"
        )
    return 0


def _rose(args) -> int:
    from bayestissue.io.tables import write_table
    from bayestissue.stereology import LineSystem, directions_vs_n

    ls = LineSystem.from_file(args.lines)
    res = directions_vs_n(ls.directions, ls.lengths, ns=args.n, k=args.top, merge_deg=args.merge_deg)
    rows = []
    print(f"{'n':>3} {'rank':>4} {'az':>7} {'el':>6} {'share':>6} {'cells':>5}  vector")
    for n, tops in res.items():
        for c in tops:
            print(
                f"{n:>3} {c['rank']:>4} {c['azimuth']:7.1f} {c['elevation']:6.1f} "
                f"{c['share']:6.3f} {c['n_cells']:>5}  {np.round(c['vector'], 4).tolist()}"
            )
            rows.append((n, c))
    if args.out:
        cols = {
            "n": np.array([n for n, _ in rows]),
            "rank": np.array([c["rank"] for _, c in rows]),
            "azimuth_deg": np.array([c["azimuth"] for _, c in rows]),
            "elevation_deg": np.array([c["elevation"] for _, c in rows]),
            "length_um": np.array([c["length_um"] for _, c in rows]),
            "share": np.array([c["share"] for _, c in rows]),
            "n_cells_merged": np.array([c["n_cells"] for _, c in rows]),
        }
        for j, x in enumerate("xyz"):
            cols[f"v_{x}"] = np.array([c["vector"][j] for _, c in rows])
        write_table(args.out, cols, meta={"source": args.lines, "merge_deg": args.merge_deg})
        print(f"wrote {args.out}")
    return 0


def _replicates(args) -> int:
    from bayestissue._validation import ValidationError
    from bayestissue.io.stereology_files import read_line_system, read_point_counts, write_replicates
    from bayestissue.stereology import PointCounts, stereology_replicates

    if args.n_boot < 2:
        raise ValidationError("--n-boot", args.n_boot, "at least 2 bootstrap replicates (a spread needs two)")

    pc = PointCounts.from_file(args.counts)
    ls = _mixture_lines(args.lines)
    from bayestissue.cli import progress_bar

    with progress_bar(args, total=args.n_boot, unit="replicate", desc="direction bootstrap") as bar:
        cols, info = stereology_replicates(
            pc,
            ls,
            n_boot=args.n_boot,
            split=args.split,
            method=args.directions,
            n=args.rose_n,
            fractions=args.fractions,
            rng=args.seed,
            progress=lambda done, total: bar.update(done - bar.n),
        )
    meta = {
        "inputs": f"{args.counts}, {args.lines}",
        "split": args.split,
        "directions": args.directions + (f" (n = {args.rose_n})" if args.directions == "rose" else ""),
        "fractions": args.fractions,
        "n_boot": args.n_boot,
        "seed": args.seed,
        "cone95_deg": np.round(info["cone_deg"], 2).tolist(),
    }
    if "disp_fibre1" in cols:
        meta["dispersion"] = ("disp_fibre1..3: GOH dispersion kappa = (1 - A(k)) / 2 of each family's Watson "
                              "concentration k (Gasser, Ogden & Holzapfel 2006)")  # fmt: skip
        meta["point_estimate_dispersion"] = np.round(info["dispersion"], 4).tolist()
    synth = [
        m["meta"].get("synthetic")
        for m in (read_point_counts(args.counts), read_line_system(args.lines))
        if "synthetic" in m["meta"]
    ]
    if synth:
        meta = {"synthetic": f"yes -- computed from synthetic inputs ({synth[0]})", **meta}
    write_replicates(args.out, cols, meta=meta)
    print(f"point estimates: {json.dumps(info['fractions'])}")
    print(f"axes (v1..v3): {np.round(info['axes'], 4).tolist()}")
    print(f"length shares: {np.round(info['shares'], 3).tolist()}")
    print(f"95 % cones (deg): {np.round(info['cone_deg'], 2).tolist()}")
    sd = {k: float(np.std(cols[k], ddof=1)) for k in ("phi_smc", "phi_ecm")}
    print(f"replicate sd: {json.dumps(sd)}")
    if "disp_fibre1" in cols:
        d = np.stack([cols[f"disp_fibre{k}"] for k in (1, 2, 3)], axis=1)
        lo, hi = np.quantile(d, [0.025, 0.975], axis=0)
        print("fibre dispersion kappa (GOH) of the Watson concentrations, point [95 % of replicates]: " + ", ".join(
            f"v{k + 1} {info['dispersion'][k]:.4f} [{lo[k]:.4f}, {hi[k]:.4f}]" for k in range(3)))  # fmt: skip
    print(f"wrote {args.n_boot} replicates to {args.out}")
    return 0
