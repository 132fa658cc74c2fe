"""Seeded SYNTHETIC stereology data shaped like the paper's (its counts and tracings are not public).

:func:`make_counts`: point counts on a systematic uniform random sample (SURS) of a serial-section series whose
true SMC and tissue fractions vary smoothly along the series, with Gundersen's nugget as counting noise
(Gundersen et al. 1999, eq. 13). :func:`make_lines`: traced polylines along spindle-cell axes drawn from a
three-component Watson mixture about the paper's fibre directions, clipped to the stack and scaled to the paper's
total length (3171.1 um in 184 774 um^3). The generating values are the module constants below;
``studies/make_replica_stereology.py`` writes them into the files' headers.
"""

from __future__ import annotations

import numpy as np

from bayestissue.paper import PAPER_DIRECTIONS
from bayestissue.stereology.axial import WatsonMixture
from bayestissue.stereology.lines import segments_from_polylines
from bayestissue.stereology.micrographs.geometry import clip_segment_to_box
from bayestissue.stereology.sections import ratio_ce, surs_indices

__all__ = ["make_counts", "make_lines"]

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


def nugget_kwargs(n_sections: int) -> dict:
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
        ce = float(ratio_ce(Q, P, smoothness=1, **nugget_kwargs(len(idx))))
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
