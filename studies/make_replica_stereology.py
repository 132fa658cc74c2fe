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
from bayestissue.paper import PAPER_DIRECTIONS
from bayestissue.stereology import (
    LineSystem,
    PointCounts,
    WatsonMixture,
    ratio_ce,
    segments_from_polylines,
    stereology_replicates,
    surs_indices,
)
from bayestissue.stereology.micrographs.phantom import clip_segment_to_box

ROOT = Path(__file__).resolve().parents[1]

# --- generating values (recorded in the files) ---
N_SERIES, PERIOD = 72, 6  # 72 serial sections of 5 um, every 6th sampled (paper Section 2.5.1)
GRID_POINTS = 400  # points of the test grid per micrograph (20 x 20)
TISSUE_MEAN, TISSUE_AMP = 0.70, 0.06  # fraction of grid points on tissue (not cavity), smooth trend
SMC_TARGET, SMC_AMP = 0.589, 0.04  # SMC fraction of the tissue (paper: 58.9 %), smooth trend
WATSON_WEIGHTS = (0.45, 0.275, 0.275)  # v1 strongest
WATSON_KAPPAS = (20.0, 25.0, 25.0)
CELL_LENGTH_UM, CELL_LENGTH_SD_UM = 72.0, 12.0  # Kochova & Tonar 2014: SMC about 72 um long
VERTEX_STEP_UM, JITTER_UM = 8.0, 0.4  # traced centroid spacing and tracing noise
PIXEL_UM = float(np.sqrt(184774.0 / (1280 * 960 * 50.0)))  # so that the stack is exactly 184 774 um^3
EXTENT_UM = (1280 * PIXEL_UM, 960 * PIXEL_UM, 10 * 5.0)  # x, y (image), z (10 sections x 5 um)
TOTAL_LENGTH_UM, VOLUME_UM3 = 3171.1, 184774.0
MIN_TRACED_UM = 6.0
MARGIN_UM = 0.5 * (CELL_LENGTH_UM + 4 * CELL_LENGTH_SD_UM)
NUGGET_SHAPE_FACTOR = 4.5  # b / sqrt(a) of SMC-bundle and cavity profiles (elongated, irregular)
PROFILES_PER_SECTION = 40  # profiles of each phase per micrograph (a fragmented meshwork)


def _noisy_count(expected, rng):
    """Expected grid points plus point-counting noise of Gundersen's nugget for k profiles per section:
    var = 0.0724 (b / sqrt a) sqrt(k P) (Gundersen et al. 1999, eq. 13, summed over k equal profiles)."""
    var = 0.0724 * NUGGET_SHAPE_FACTOR * np.sqrt(PROFILES_PER_SECTION * expected)
    return np.clip(np.round(expected + rng.normal(0.0, np.sqrt(var))), 0, GRID_POINTS).astype(int)


def _nugget_kwargs(n_sections: int) -> dict:
    n = PROFILES_PER_SECTION * n_sections
    return {"shape_factors": NUGGET_SHAPE_FACTOR, "n_profiles": (n, n)}


def make_counts(seed: int) -> tuple[dict, int]:
    """Point counts on a SURS of the series; retry seeds until the ratio is within one CE of 58.9 %."""
    for s in range(seed, seed + 1000):
        rng = np.random.default_rng(s)
        phase1, phase2 = 2 * np.pi * rng.random(2)
        pos = np.arange(N_SERIES)
        tissue = TISSUE_MEAN + TISSUE_AMP * np.sin(2 * np.pi * pos / N_SERIES + phase1)
        smc = SMC_TARGET + SMC_AMP * np.cos(2 * np.pi * pos / 40.0 + phase2)
        idx = surs_indices(N_SERIES, PERIOD, rng=rng)
        P = _noisy_count(GRID_POINTS * tissue[idx], rng)
        Q = np.minimum(_noisy_count(P * smc[idx], rng), P)
        vv = Q.sum() / P.sum()
        ce = float(ratio_ce(Q, P, smoothness=1, **_nugget_kwargs(len(idx))))
        if abs(vv - SMC_TARGET) <= ce * vv:
            counts = np.stack([Q, P - Q, GRID_POINTS - P], axis=1)
            return {"section": idx, "counts": counts, "vv": vv, "ce": ce}, s
    raise RuntimeError("no seed matched")  # pragma: no cover


def make_lines(seed: int) -> dict:
    """Traced polylines of cells with Watson-mixture axes, scaled to the paper's total length."""
    rng = np.random.default_rng(seed)
    mix = WatsonMixture(PAPER_DIRECTIONS, WATSON_KAPPAS, WATSON_WEIGHTS)
    upper = np.array(EXTENT_UM)
    polylines, labels, total = [], [], 0.0
    while total < TOTAL_LENGTH_UM:
        axis, lab = mix.sample(1, rng=rng)
        # centres uniform in the box dilated by the longest half-length: a stationary fibre process, so the
        # expected length share of each family inside the box equals its mixture weight
        centre = -MARGIN_UM + rng.random(3) * (upper + 2 * MARGIN_UM)
        half = 0.5 * float(np.clip(rng.normal(CELL_LENGTH_UM, CELL_LENGTH_SD_UM), 20.0, 2 * MARGIN_UM))
        seg = clip_segment_to_box(centre - half * axis[0], centre + half * axis[0], upper)
        if seg is None:
            continue
        a, b = seg
        L = float(np.linalg.norm(b - a))
        if L < MIN_TRACED_UM:
            continue
        k = max(int(round(L / VERTEX_STEP_UM)), 1)
        t = np.linspace(0.0, 1.0, k + 1)[:, None]
        pts = a + t * (b - a) + rng.normal(0, JITTER_UM, (k + 1, 3))
        pts = np.clip(pts, 0.0, upper)
        polylines.append(pts)
        labels.append(int(lab[0]) + 1)
        total += float(np.sum(np.linalg.norm(np.diff(pts, axis=0), axis=1)))
    scale = TOTAL_LENGTH_UM / total  # scale each polyline about its midpoint: directions unchanged
    polylines = [p.mean(axis=0) + scale * (p - p.mean(axis=0)) for p in polylines]
    start, end, cell = segments_from_polylines(polylines, np.arange(1, len(polylines) + 1))
    family = np.repeat(labels, [len(p) - 1 for p in polylines])
    seg_len = np.linalg.norm(end - start, axis=1)
    shares = [float(seg_len[family == k].sum() / seg_len.sum()) for k in (1, 2, 3)]
    return {"start": start, "end": end, "cell": cell, "scale": scale, "shares": shares}


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

    cnt, used_seed = make_counts(args.seed)
    common = {"synthetic": "yes -- seeded replica, NOT the paper's measurements (those are not public)"}
    write_point_counts(
        out / "stereology_counts.csv",
        cnt["section"],
        cnt["counts"],
        ("smc", "ecm", "other"),
        meta={
            **common,
            "generator": "studies/make_replica_stereology.py make_counts",
            "seed": used_seed,
            "seed_rule": f"first seed >= {args.seed} whose SMC ratio is within one CE (m=1) of 0.589",
            "excluded": "other",
            "n_series": N_SERIES,
            "period": PERIOD,
            "section_thickness_um": 5,
            "grid_points_per_micrograph": GRID_POINTS,
            "true_tissue_fraction": f"{TISSUE_MEAN} + {TISSUE_AMP} sin(2 pi s/72 + U(0,2pi))",
            "true_smc_fraction_of_tissue": f"{SMC_TARGET} + {SMC_AMP} cos(2 pi s/40 + U(0,2pi))",
            "counts_model": (
                "P = round(grid tissue(s) + noise), Q_smc = round(P smc(s) + noise), other = grid - P; "
                "noise N(0, 0.0724 b/sqrt(a) sqrt(k E[count])) (Gundersen 1999 nugget for k profiles)"
            ),
            "nugget_shape_factor": NUGGET_SHAPE_FACTOR,
            "nugget_profiles_per_section": PROFILES_PER_SECTION,
            "columns": "section = position in the series (0-based); *_points = grid points on it",
        },
    )
    ln = make_lines(args.seed + 1)
    write_line_system(
        out / "stereology_lines.csv",
        ln["start"],
        ln["end"],
        ln["cell"],
        meta={
            **common,
            "generator": "studies/make_replica_stereology.py make_lines",
            "seed": args.seed + 1,
            "frame": "body frame um: x longitudinal (loading), y top-down, z = stack axis",
            "watson_axes": "paper v1 [0,1,0], v2 [0.9369,0.342,0], v3 [0.9369,-0.342,0] (normalised)",
            "watson_kappas": list(WATSON_KAPPAS),
            "watson_weights": list(WATSON_WEIGHTS),
            "cell_length_um": f"N({CELL_LENGTH_UM}, {CELL_LENGTH_SD_UM}) clipped to the stack",
            "vertex_step_um": VERTEX_STEP_UM,
            "tracing_jitter_sd_um": JITTER_UM,
            "length_scale_applied": f"{ln['scale']:.6f}",
            "true_family_length_shares": [round(x, 4) for x in ln["shares"]],
            "total_length_um": TOTAL_LENGTH_UM,
            "volume_um3": VOLUME_UM3,
        },
        sidecar={
            "synthetic": True,
            "volume_um3": VOLUME_UM3,
            "extent_x_um": EXTENT_UM[0],
            "extent_y_um": EXTENT_UM[1],
            "n_sections": 10,
            "section_thickness_um": 5.0,
            "pixel_um": PIXEL_UM,
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
