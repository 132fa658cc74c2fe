r"""Joint replicates of (volume fractions, fibre directions): the table the mechanics takes as
input.

Pipeline (:func:`stereology_replicates`):

1. volume fractions of SMC and ECM from the point counts (paper eq. 1), replicated by the
design-aware
   parametric bootstrap (:func:`~bayestissue.stereology.uncertainty.parametric_fraction_bootstrap`)
   or, with several independent blocks, the cluster bootstrap;
2. three fibre directions from the line system (:func:`fit_fibre_directions`: Watson mixture by
default, or the
   rose's top cells for a given n), replicated by resampling whole traced cells and aligned to the
   point estimate (:func:`direction_bootstrap`);
3. the SMC fraction split between the three families (:func:`fibre_fraction_split`) and the table
assembled
   with family k matched to the paper's v_k (:func:`replicate_table`, columns
   :data:`bayestissue.io.stereology_files.REPLICATE_COLUMNS`).

Fractions and directions come from different measurements (point grid vs traced stack) and are
paired row by row as independent draws.
"""

from __future__ import annotations

import numpy as np

from bayestissue._validation import ValidationError
from bayestissue.io.stereology_files import DISPERSION_COLUMNS, REPLICATE_COLUMNS
from bayestissue.paper import PAPER_DIRECTIONS
from bayestissue.stereology.axial import axial_angle, fit_watson_mixture, watson_goh_dispersion
from bayestissue.stereology.lines import LineSystem
from bayestissue.stereology.point_counts import PointCounts
from bayestissue.stereology.rose import preferential_directions, rose_of_directions
from bayestissue.stereology.uncertainty import (
    align_axes,
    bootstrap_cells,
    cluster_fraction_bootstrap,
    confidence_cones,
    naive_section_bootstrap,
    parametric_fraction_bootstrap,
)

__all__ = [
    "REPLICATE_COLUMNS",
    "fibre_fraction_split",
    "fit_fibre_directions",
    "direction_bootstrap",
    "fraction_replicates",
    "replicate_table",
    "stereology_replicates",
]

_METHODS = ("watson", "watson+uniform", "rose")


def fibre_fraction_split(phi_smc, *, method: str = "paper", shares=None) -> np.ndarray:
    r"""Split the SMC volume fraction between the three fibre families.

    ``"paper"``: equal thirds, :math:`\phi_k = \phi_{SMC}/3` (the paper, Section 3.2.1, rounded
    0.589 / 3 = 0.196 to 0.2 and :math:`\phi_m` = 0.411 to 0.4). ``"length"``: :math:`\phi_k =
    \phi_{SMC}\,s_k` with :math:`s_k` the families' length shares (Watson mixture weights or the
    rose's top-cell lengths, normalised to sum 1).

    Returns (n, 3).
    """
    phi = np.atleast_1d(np.asarray(phi_smc, dtype=float))
    if method == "paper":
        return np.repeat(phi[:, None] / 3.0, 3, axis=1)
    if method == "length":
        if shares is None:
            raise ValidationError("shares", None, "(n, 3) length shares for split='length'")
        s = np.broadcast_to(np.asarray(shares, dtype=float), (phi.size, 3))
        if np.any(s < 0) or np.any(s.sum(axis=1) <= 0):
            raise ValidationError("shares", "negative or all-zero row", "length shares >= 0")
        return phi[:, None] * s / s.sum(axis=1, keepdims=True)
    raise ValidationError("split", method, "'paper' or 'length'")


def fit_fibre_directions(
    lines: LineSystem,
    index=None,
    *,
    method: str = "watson",
    n: int = 15,
    init_axes=None,
    rng=None,
    with_concentrations: bool = False,
) -> tuple[np.ndarray, ...]:
    """Three fibre axes and their length shares from (a subset of) a line system.

    ``method="watson"``: three-component Watson mixture with length weights (axes, weights);
    ``method="watson+uniform"``: the same with a uniform background component
    (:func:`~bayestissue.stereology.axial.fit_watson_mixture`, ``background=True``; shares are the three families'
    weights normalised over the three: the background's length belongs to no family);
    ``method="rose"``: the top three directions of the n x n equal-area rose (principal axes of the
    merged top cells, shares = their lengths normalised over the three).

    Returns axes (3, 3) and shares (3,); with ``with_concentrations`` also the families' Watson concentrations
    (3,) (NaN for ``"rose"``, which fits no concentration).
    """
    if method not in _METHODS:
        raise ValidationError("method", method, f"one of {list(_METHODS)}")
    d = lines.directions if index is None else lines.directions[index]
    w = lines.lengths if index is None else lines.lengths[index]
    if method.startswith("watson"):
        bg = method == "watson+uniform"
        if init_axes is None:
            mix = fit_watson_mixture(d, 3, weights=w, n_init=5, background=bg, rng=rng)
        else:
            mix = fit_watson_mixture(d, 3, weights=w, init_axes=init_axes, n_init=0, background=bg, rng=rng)
        out = (mix.axes, mix.weights / mix.weights.sum(), mix.kappas)
        return out if with_concentrations else out[:2]
    top = preferential_directions(rose_of_directions(d, w, n=n), k=3)
    if len(top) < 3:
        raise ValidationError("line system", f"{len(top)} occupied directions", ">= 3 distinct directions")
    L = np.array([c["length_um"] for c in top])
    out = (np.array([c["vector"] for c in top]), L / L.sum(), np.full(3, np.nan))
    return out if with_concentrations else out[:2]


def direction_bootstrap(
    lines: LineSystem, *, method: str = "watson", n: int = 15, n_boot: int = 300, rng=None, progress=None
) -> dict:
    """Point estimate of the three fibre axes and their cell-bootstrap replicates.

    Returns
    -------
    dict with ``axes`` (3, 3) and ``shares`` (3,) of the full data (ordered as the paper's v1, v2,
    v3 by optimal axial assignment), ``replicate_axes`` (n_boot, 3, 3) aligned to ``axes`` (no label
    switching, signs a . axes_k >= 0), ``replicate_shares`` (n_boot, 3) permuted alike, ``cone_deg``
    (3,) 95 % cone half-angles and ``angle_to_paper_deg`` (3,); ``lengths_um`` (3,) the families'
    line lengths (share x total), ``replicate_lengths_um`` (n_boot, 3) and their 95 % intervals
    ``length_ci_um`` (2, 3). The Watson methods also give each family's concentration and its GOH dispersion
    (:func:`~bayestissue.stereology.axial.watson_goh_dispersion`): ``concentrations`` and ``dispersion`` (3,),
    ``replicate_concentrations`` and ``replicate_dispersion`` (n_boot, 3), permuted with the axes (NaN for
    ``"rose"``). ``progress(done, n_boot)`` after each replicate (a refit of the directions).
    """
    rng = np.random.default_rng(rng)
    axes, shares, conc = fit_fibre_directions(lines, method=method, n=n, rng=rng, with_concentrations=True)
    axes, order = align_axes(axes, PAPER_DIRECTIONS)
    shares, conc = shares[order], conc[order]

    totals = []

    def est(idx):  # the shares and concentrations travel together through the bootstrap (columns 0 and 1)
        totals.append(lines.lengths[idx].sum())
        a, s, k = fit_fibre_directions(lines, idx, method=method, n=n, init_axes=axes, rng=rng,
                                       with_concentrations=True)  # fmt: skip
        return a, np.column_stack([s, k])

    rep_axes, rep_values = bootstrap_cells(lines.cell, est, n_boot=n_boot, rng=rng, progress=progress)
    rep_axes, rep_order = align_axes(rep_axes, axes)
    rep_values = np.take_along_axis(rep_values, rep_order[..., None], axis=1)
    rep_shares, rep_conc = rep_values[..., 0], rep_values[..., 1]
    rep_lengths = rep_shares * np.asarray(totals)[:, None]
    return {
        "concentrations": conc,
        "dispersion": watson_goh_dispersion(conc),
        "replicate_concentrations": rep_conc,
        "replicate_dispersion": watson_goh_dispersion(rep_conc),
        "lengths_um": shares * lines.total_length_um,
        "replicate_lengths_um": rep_lengths,
        "length_ci_um": np.quantile(rep_lengths, [0.025, 0.975], axis=0),
        "axes": axes,
        "shares": shares,
        "replicate_axes": rep_axes,
        "replicate_shares": rep_shares,
        "cone_deg": confidence_cones(rep_axes, axes),
        "angle_to_paper_deg": axial_angle(axes, PAPER_DIRECTIONS),
    }


def fraction_replicates(
    counts: PointCounts, *, n_boot: int = 300, kind: str = "parametric", rng=None, **ce_kwargs
) -> dict[str, np.ndarray]:
    """Replicates of the reference-space volume fractions, per component name.

    ``kind``: ``"parametric"`` (design-aware, the default), ``"cluster"`` (needs >= 2 blocks) or
    ``"naive"`` (resampling sections of one systematic sample; a labelled comparison only, it
    overestimates).
    """
    Q = counts.reference_counts()
    if kind == "parametric":
        kw = {**counts.ce_kwargs(), **ce_kwargs}
        draws = parametric_fraction_bootstrap(Q, n_boot=n_boot, rng=rng, **kw)
    elif kind == "cluster":
        if counts.block is None:
            raise ValidationError("block", None, "a 'block' column for the cluster bootstrap")
        order = np.argsort(counts.section, kind="stable")
        draws = cluster_fraction_bootstrap(Q, np.asarray(counts.block)[order], n_boot=n_boot, rng=rng)
    elif kind == "naive":
        draws = naive_section_bootstrap(Q, n_boot=n_boot, rng=rng)
    else:
        raise ValidationError("kind", kind, "'parametric', 'cluster' or 'naive'")
    return {c: draws[:, j] for j, c in enumerate(counts.reference_components)}


def replicate_table(
    fractions: dict[str, np.ndarray],
    directions,
    *,
    split: str = "paper",
    shares=None,
    dispersion=None,
    reference=PAPER_DIRECTIONS,
) -> dict[str, np.ndarray]:
    """Assemble the replicate table handed to the mechanics (columns :data:`REPLICATE_COLUMNS`).

    Parameters
    ----------
    fractions : {"smc": (B,), "ecm": (B,)} volume-fraction replicates (reference space without
        cavities).
    directions : (B, 3, 3) fibre-axis replicates; aligned here to ``reference`` (the paper's v1,
        v2, v3), so family k matches paper v_k and v_k . paper_v_k >= 0.
    split : ``"paper"`` or ``"length"`` (then ``shares`` (B, 3) in the order of ``directions``,
        permuted with the axes), see :func:`fibre_fraction_split`.
    dispersion : optional (B, 3) GOH dispersion of each family in the order of ``directions`` (permuted with the
        axes): the columns ``disp_fibre1..3`` (:data:`~bayestissue.io.stereology_files.DISPERSION_COLUMNS`).

    Returns
    -------
    dict column -> (B,) array; ``phi_matrix = phi_ecm``.
    """
    for name in ("smc", "ecm"):
        if name not in fractions:
            raise ValidationError("fractions", sorted(fractions), f"a '{name}' component")
    phi_smc = np.asarray(fractions["smc"], dtype=float)
    phi_ecm = np.asarray(fractions["ecm"], dtype=float)
    D = np.asarray(directions, dtype=float)
    B = phi_smc.size
    if D.shape != (B, 3, 3):
        raise ValidationError("directions", f"shape {D.shape}", f"({B}, 3, 3) matching the fractions")
    if split not in ("paper", "length"):
        raise ValidationError("split", split, "'paper' or 'length'")
    aligned, order = align_axes(D, reference)
    aligned /= np.linalg.norm(aligned, axis=2, keepdims=True)
    sh = None
    if split == "length":
        if shares is None:
            raise ValidationError("shares", None, f"({B}, 3) length shares for split='length'")
        sh = np.take_along_axis(np.asarray(shares, dtype=float).reshape(B, 3), order, axis=1)
    phi_f = fibre_fraction_split(phi_smc, method=split, shares=sh)
    cols = {
        "replicate": np.arange(1, B + 1),
        "phi_smc": phi_smc,
        "phi_ecm": phi_ecm,
        "phi_matrix": phi_ecm.copy(),
    }
    for k in range(3):
        cols[f"phi_fibre{k + 1}"] = phi_f[:, k]
    for k in range(3):
        for j, c in enumerate("xyz"):
            cols[f"v{k + 1}_{c}"] = aligned[:, k, j]
    if dispersion is not None:
        disp = np.take_along_axis(np.asarray(dispersion, dtype=float).reshape(B, 3), order, axis=1)
        if np.any(~np.isfinite(disp)) or np.any(disp < 0) or np.any(disp > 1.0 / 3.0):
            raise ValidationError("dispersion", "a value outside [0, 1/3]", "GOH dispersions in [0, 1/3]")
        for k in range(3):
            cols[DISPERSION_COLUMNS[k]] = disp[:, k]
    return cols


def stereology_replicates(
    counts: PointCounts,
    lines: LineSystem,
    *,
    n_boot: int = 300,
    split: str = "paper",
    method: str = "watson",
    n: int = 15,
    fractions: str = "parametric",
    rng=None,
    progress=None,
    **ce_kwargs,
) -> tuple[dict[str, np.ndarray], dict]:
    """Joint replicate table of volume fractions and fibre directions (see the module docstring);
    ``progress(done, n_boot)`` after each direction replicate (the slow part).

    Returns
    -------
    columns : the replicate table (:func:`replicate_table`).
    info : the point estimates (``fractions``, ``axes``, ``shares``), ``cone_deg``,
        ``angle_to_paper_deg`` and the options used (for the file's comment header).
    """
    rng = np.random.default_rng(rng)
    for name in ("smc", "ecm"):
        if name not in counts.reference_components:
            raise ValidationError(
                "component",
                name,
                f"one of the reference components {list(counts.reference_components)}",
            )
    fr = fraction_replicates(counts, n_boot=n_boot, kind=fractions, rng=rng, **ce_kwargs)
    dirs = direction_bootstrap(lines, method=method, n=n, n_boot=n_boot, rng=rng, progress=progress)
    cols = replicate_table(
        fr,
        dirs["replicate_axes"],
        split=split,
        shares=dirs["replicate_shares"],
        dispersion=None if method == "rose" else dirs["replicate_dispersion"],
        reference=PAPER_DIRECTIONS,
    )
    info = {
        "fractions": counts.volume_fractions(),
        "axes": dirs["axes"],
        "shares": dirs["shares"],
        "concentrations": dirs["concentrations"],
        "dispersion": dirs["dispersion"],
        "cone_deg": dirs["cone_deg"],
        "angle_to_paper_deg": dirs["angle_to_paper_deg"],
        "split": split,
        "method": method,
        "fraction_bootstrap": fractions,
        "n_boot": n_boot,
    }
    return cols, info
