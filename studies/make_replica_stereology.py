"""Write seeded SYNTHETIC replicas of the paper's stereology data to data/ (the real counts are not public).

Outputs (all labelled synthetic, generating values and seed in the comment headers):

- ``stereology_counts.csv``: point counts on m = 12 of 72 serial sections (every 6th, random start), components
  smc / ecm / other (other = haemocoelic cavity, excluded from the reference space). The seed is the first one
  from ``--seed`` on whose ratio estimate lies within one predicted CE (m = 1) of the paper's 58.9 % SMC.
- ``stereology_lines.csv`` + ``stereology_lines.toml``: a traced line system, polylines through the axes of
  spindle cells whose axes come from a three-component Watson mixture about the paper's v1, v2, v3 (v1 the
  strongest, all elevations 0), clipped to a stack of 10 sections x 5 um over a 1280 x 960 px field, scaled to
  the paper's total length 3171.1 um in 184 774 um^3.
- ``stereology_replicates.csv``: the joint bootstrap replicate table for the mechanics (design-aware parametric
  bootstrap of the fractions, cell bootstrap of a Watson-mixture fit of the directions, the paper's split).

Usage: ``python studies/make_replica_stereology.py [--quick | --full] [--out DIR] [--seed N]``
(``--quick`` writes 20 replicates into figures/quick_replica/ and leaves data/ alone).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from bayestissue.io.stereology_files import (
    write_line_system,
    write_point_counts,
    write_replicates,
)
from bayestissue.stereology import LineSystem, PointCounts, replica, stereology_replicates

ROOT = Path(__file__).resolve().parents[1]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    g = ap.add_mutually_exclusive_group()
    g.add_argument("--quick", action="store_true", help="20 replicates into figures/quick_replica/")
    g.add_argument("--full", action="store_true", help="1000 replicates")
    ap.add_argument("--out", type=Path, default=None, help="output folder (default data/)")
    ap.add_argument("--seed", type=int, default=20140791)
    ap.add_argument("--n-boot", type=int, default=None, help="replicates (default 300)")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    out = args.out or (ROOT / "figures" / "quick_replica" if args.quick else ROOT / "data")
    n_boot = args.n_boot or (20 if args.quick else 1000 if args.full else 300)
    out.mkdir(parents=True, exist_ok=True)

    cnt, used_seed = replica.make_counts(args.seed)
    common = {"synthetic": "yes -- seeded replica, NOT the paper's measurements (those are not public)"}
    write_point_counts(
        out / "stereology_counts.csv",
        cnt["section"],
        cnt["counts"],
        ("smc", "ecm", "other"),
        meta={
            **common,
            "generator": "bayestissue.stereology.replica.make_counts (studies/make_replica_stereology.py)",
            "seed": used_seed,
            "seed_rule": f"first seed >= {args.seed} whose SMC ratio is within one CE (m=1) of 0.589",
            "excluded": "other",
            "n_series": replica.N_SERIES,
            "period": replica.PERIOD,
            "section_thickness_um": 5,
            "grid_points_per_micrograph": replica.GRID_POINTS,
            "true_tissue_fraction": f"{replica.TISSUE_MEAN} + {replica.TISSUE_AMP} sin(2 pi s/72 + U(0,2pi))",
            "true_smc_fraction_of_tissue": f"{replica.SMC_TARGET} + {replica.SMC_AMP} cos(2 pi s/40 + U(0,2pi))",
            "counts_model": (
                "P = round(grid tissue(s) + noise), Q_smc = round(P smc(s) + noise), other = grid - P; "
                "noise N(0, 0.0724 b/sqrt(a) sqrt(k E[count])) (Gundersen 1999 nugget for k profiles)"
            ),
            "nugget_shape_factor": replica.NUGGET_SHAPE_FACTOR,
            "nugget_profiles_per_section": replica.PROFILES_PER_SECTION,
            "columns": "section = position in the series (0-based); *_points = grid points on it",
        },
    )
    ln = replica.make_lines(args.seed + 1)
    write_line_system(
        out / "stereology_lines.csv",
        ln["start"],
        ln["end"],
        ln["cell"],
        meta={
            **common,
            "generator": "bayestissue.stereology.replica.make_lines (studies/make_replica_stereology.py)",
            "seed": args.seed + 1,
            "frame": "body frame um: x longitudinal (loading), y top-down, z = stack axis",
            "watson_axes": "paper v1 [0,1,0], v2 [0.9369,0.342,0], v3 [0.9369,-0.342,0] (normalised)",
            "watson_kappas": list(replica.WATSON_KAPPAS),
            "watson_weights": list(replica.WATSON_WEIGHTS),
            "cell_length_um": f"N({replica.CELL_LENGTH_UM}, {replica.CELL_LENGTH_SD_UM}) clipped to the stack",
            "vertex_step_um": replica.VERTEX_STEP_UM,
            "tracing_jitter_sd_um": replica.JITTER_UM,
            "length_scale_applied": f"{ln['scale']:.6f}",
            "true_family_length_shares": [round(x, 4) for x in ln["shares"]],
            "total_length_um": replica.TOTAL_LENGTH_UM,
            "volume_um3": replica.VOLUME_UM3,
        },
        sidecar={
            "synthetic": True,
            "volume_um3": replica.VOLUME_UM3,
            "extent_x_um": replica.EXTENT_UM[0],
            "extent_y_um": replica.EXTENT_UM[1],
            "n_sections": 10,
            "section_thickness_um": 5.0,
            "pixel_um": replica.PIXEL_UM,
            "image_px": [1280, 960],
            "note": "synthetic replica; extent chosen so that the stack is the paper's 184774 um^3",
        },
    )

    # read back through the io layer (round trip) and build the replicate table
    counts = PointCounts.from_file(out / "stereology_counts.csv")
    lines = LineSystem.from_file(out / "stereology_lines.csv")
    rep_seed = args.seed + 2
    cols, info = stereology_replicates(counts, lines, n_boot=n_boot, split="paper", rng=rep_seed)
    write_replicates(
        out / "stereology_replicates.csv",
        cols,
        meta={
            **common,
            "generator": "studies/make_replica_stereology.py (bayestissue.stereology.stereology_replicates)",
            "inputs": "stereology_counts.csv, stereology_lines.csv (+ .toml)",
            "seed": rep_seed,
            "n_boot": n_boot,
            "split": "paper",
            "split_rule": "phi_matrix = phi_ecm, phi_fibre_k = phi_smc / 3 (the paper's equal thirds)",
            "fractions": "design-aware parametric bootstrap (logistic-normal, SURS covariance m=1, nugget)",
            "directions": "cell bootstrap of a 3-component length-weighted Watson mixture (EM)",
            "alignment": "family k matched to paper v_k (Hungarian on axial angle), v_k . paper_v_k >= 0",
            "point_estimate_axes": np.round(info["axes"], 4).tolist(),
            "point_estimate_length_shares": np.round(info["shares"], 4).tolist(),
            "cone95_deg": np.round(info["cone_deg"], 2).tolist(),
            "dispersion": "disp_fibre1..3: GOH dispersion (1 - A(k)) / 2 of each family's Watson concentration k",
            "point_estimate_dispersion": np.round(info["dispersion"], 4).tolist(),
        },
    )
    print(f"counts: seed {used_seed}, V_V(SMC) = {cnt['vv']:.4f}, CE(m=1) = {cnt['ce']:.4f}")
    print(
        f"lines: {lines.n_cells} cells, {len(lines.cell)} segments, L = {lines.total_length_um:.1f} um, "
        f"L_V = {lines.length_density():.4f} um^-2 (scale applied {ln['scale']:.4f})"
    )
    print(f"axes (rows v1..v3):\n{np.round(info['axes'], 4)}")
    print(f"angle to paper (deg): {np.round(info['angle_to_paper_deg'], 2)}")
    print(f"length shares: {np.round(info['shares'], 3)}; 95 % cones (deg): {np.round(info['cone_deg'], 2)}")
    print(f"wrote {out}/stereology_{{counts,lines,replicates}}.csv in {time.perf_counter() - t0:.1f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
