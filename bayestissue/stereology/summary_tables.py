"""Markdown tables of the stereology study (``figures/stereology_directions_vs_n.md``).

Plain text from the estimators' results: volume fractions with the CE predictors, the top-three directions against
the paper's v_k for each rose resolution n, the cell-bootstrap cones, and the CE predictors against the true spread
on a known object.
"""

from __future__ import annotations

import numpy as np

from bayestissue.paper import PAPER_DIRECTIONS
from bayestissue.stereology.axial import axial_angle

__all__ = ["ce_row", "ce_table_header", "cones_table", "directions_table", "fractions_table", "nearest_paper"]


def nearest_paper(v) -> tuple[int, float]:
    """The paper direction (1, 2 or 3) nearest to the axis ``v`` and the axial angle to it (degrees)."""
    ang = axial_angle(np.asarray(v)[None], PAPER_DIRECTIONS)
    k = int(np.argmin(ang))
    return k + 1, float(ang[k])


def fractions_table(counts, lines) -> list[str]:
    """V_V per component with the CE predictors (paper eq. 1), then the line system's L_V (paper eq. 2)."""
    md = [
        "## Volume fractions (point counts, paper eq. 1) and CE predictors",
        "",
        "| component | V_V | CE m=0 | CE m=1 | CE q_hat | q_hat | CE classic (independent units) |",
        "|---|---|---|---|---|---|---|",
    ]
    for c, r in counts.summary().items():
        md.append(
            f"| {c} | {r['V_V']:.4f} | {r['CE_m0']:.4f} | {r['CE_m1']:.4f} | {r['CE_q_hat']:.4f} | "
            f"{r['q_hat']:.2f} | {r['CE_classic']:.4f} |"
        )
    return md + [
        "",
        f"Line system: {lines.n_cells} traced cells, {len(lines.cell)} segments, L = "
        f"{lines.total_length_um:.1f} um, V = {lines.volume_um3:.0f} um^3, L_V = "
        f"{lines.length_density():.4f} um^-2 (paper eq. 2; paper: 0.0172).",
        "",
    ]


def directions_table(res: dict, title: str) -> list[str]:
    """The top three directions for each n (``directions_vs_n`` output) with the nearest paper direction."""
    md = [
        f"## Top three directions vs n: {title}",
        "",
        "Azimuth atan2(y, x) and elevation arcsin(z) in degrees of the length-weighted principal axis of the",
        "lines in the (merged) cells; nearest paper direction and the angle to it.",
        "",
        "| n | rank 1: az, el, share (paper v, angle) | rank 2 | rank 3 |",
        "|---|---|---|---|",
    ]
    for n, tops in res.items():
        cells = []
        for c in tops:
            k, a = nearest_paper(c["vector"])
            cells.append(f"{c['azimuth']:.1f}, {c['elevation']:.1f}, {c['share']:.2f} (v{k}, {a:.1f})")
        md.append(f"| {n} | " + " | ".join(cells) + " |")
    md.append("")
    return md


def cones_table(cone_rows) -> list[str]:
    """Per estimator (``(name, direction_bootstrap result)``): angle to v_k, cone, share and length with 95 % CIs."""
    md = [
        "## Fibre directions with 95 % cell-bootstrap cones",
        "",
        "Bootstrap over whole traced cells, refit, axes aligned to the point estimate (Hungarian assignment on",
        "the axial angle). Columns per family k (matched to the paper's v_k): angle to paper v_k, cone",
        "half-angle (deg), length share [95 % interval], line length in um [95 % interval].",
        "",
        "| estimator | v1: angle, cone, share [CI], length [CI] | v2 | v3 |",
        "|---|---|---|---|",
    ]
    for name, b in cone_rows:
        lo, hi = np.quantile(b["replicate_shares"], [0.025, 0.975], axis=0)
        llo, lhi = b["length_ci_um"]
        cells = [
            f"{b['angle_to_paper_deg'][k]:.1f}, {b['cone_deg'][k]:.1f}, {b['shares'][k]:.2f} "
            f"[{lo[k]:.2f}, {hi[k]:.2f}], {b['lengths_um'][k]:.0f} [{llo[k]:.0f}, {lhi[k]:.0f}]"
            for k in range(3)
        ]
        md.append(f"| {name} | " + " | ".join(cells) + " |")
    md.append("")
    return md


def ce_table_header(phantom, n_starts: int) -> list[str]:
    """Heading and column names of the CE check on the two-ball phantom."""
    return [
        "## CE predictors vs the true spread on a known object",
        "",
        f"Two-ball phantom (R = 1, phase r = 0.75 at height 0.2, V_V = {phantom.volume_fraction:.4f}), a square",
        f"point grid of spacing 0.1 R placed at random on every section, {n_starts} random starts per spacing.",
        "Fixed object: its variance oscillates with 2R/T (Zitterbewegung); size jitter: the object is scaled",
        "by U[1, 1.3] per start, which averages the oscillation and leaves the extension term the predictors",
        "estimate. Ratios are predicted / true CE.",
        "",
        "| object | sections | true CE | m=1 | q_hat | m=0 | classic | naive bootstrap |",
        "|---|---|---|---|---|---|---|---|",
    ]


def ce_row(name: str, r: dict) -> str:
    """One row of the CE check (a ``ce_check`` result): the predictors as ratios to the true CE."""
    return (
        f"| {name} | {r['n_sections']:.1f} | {r['true_ce']:.4f} | {r['m1'] / r['true_ce']:.2f} | "
        f"{r['q_hat'] / r['true_ce']:.2f} | {r['m0'] / r['true_ce']:.2f} | "
        f"{r['classic'] / r['true_ce']:.1f} | {r['naive_bootstrap'] / r['true_ce']:.1f} |"
    )
