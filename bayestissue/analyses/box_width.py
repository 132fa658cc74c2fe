"""How a model's evidence moves when its log-scaled prior boxes are narrowed or widened (issue 36).

A parameter with a log-uniform prior on :math:`[a_j, b_j]` has the density :math:`1/W_j` per unit of
:math:`\\ln\\theta_j`, :math:`W_j = \\ln(b_j/a_j)`. Moving both bounds by a factor :math:`f` (10 here) on every such
parameter :math:`j \\in J` gives the boxes :math:`B_-` (narrowed, :math:`[f a_j, b_j/f]`, width
:math:`W_j - 2\\ln f`) and :math:`B_+` (widened, :math:`[a_j/f, f b_j]`, width :math:`W_j + 2\\ln f`); the other
parameters keep their priors.

**Narrowed** (exact, from the runs' weighted points): the narrowed prior is the old one restricted to :math:`B_-`
and renormalised, so

.. math:: \\ln Z_- - \\ln Z = \\sum_{j \\in J} \\ln\\frac{W_j}{W_j - 2\\ln f} + \\ln P(\\theta \\in B_- \\mid D),

the posterior mass inside the narrowed box estimated per run from its normalised weights, its error per run from
the run's own bootstrap replicate weights (UltraNest), merged over runs as the evidence is (mean; error the larger of
the own errors combined over :math:`n` and the scatter over :math:`\\sqrt n`).

**Widened** (bounded, then estimated): the old box's part of :math:`Z_+` is :math:`Z` times the volume ratio, and the
mass beyond the old bounds adds to it, so

.. math:: \\ln Z_+ - \\ln Z \\ge -\\sum_{j \\in J} \\ln\\frac{W_j + 2\\ln f}{W_j}

(the *volume term*, exact where the likelihood vanishes beyond the old box). The runs never sampled beyond the
bounds; the *flat estimate* assumes the posterior density per unit :math:`\\ln\\theta_j` beyond each bound equals
its mean over the box's outermost :math:`\\ln f` (the outermost decade for :math:`f = 10`): each bound then adds the
posterior share :math:`s_{j,\\pm}` of that edge band, :math:`\\ln Z_+ - \\ln Z \\approx` volume term
:math:`+ \\ln(1 + \\sum_j (s_{j,-} + s_{j,+}))` (first order: bounds extended together are not combined). It is right
for a parameter the data cannot bound on that side (a matrix so soft it no longer matters) and wrong where the
likelihood turns beyond the bound; only runs in the wider box measure it.

The log Bayes factor of model A over model B moves by the difference of the two models' shifts; parameters the two
models share move both evidences alike, so the factor moves by the volume of the parameters one model has and the
other not, and by the posterior mass each model keeps.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from bayestissue.inference.diagnostics import runs_mean_error

__all__ = ["FACTOR", "BoxShift", "box_shift", "merge_runs"]

#: every log-scaled box narrowed or widened by this factor at each end (issue 36)
FACTOR = 10.0


@dataclass(frozen=True)
class BoxShift:
    """One model's evidence under boxes moved by ``factor`` at both ends (module docstring). ``names``: the
    log-scaled parameters (narrowing skips any whose box spans less than ``factor**2``).
    ``narrowed_runs``/``narrowed_errs``: per run, :math:`\\ln Z_- - \\ln Z` and its bootstrap error (NaN without
    replicate weights); ``narrowed``: merged (value, error). ``widened_volume``: the volume term (a lower bound);
    ``edge_share[j]``: the posterior share of the outermost ``ln factor`` at the lower and the upper bound of
    ``names[j]`` (runs pooled); ``widened_flat``: the flat estimate."""

    factor: float
    names: list[str]
    narrowed_runs: list[float]
    narrowed_errs: list[float]
    narrowed: tuple[float, float]
    widened_volume: float
    edge_share: list[tuple[float, float]]
    widened_flat: float


def merge_runs(values, errors) -> tuple[float, float]:
    """Mean of per-run estimates and its error (:func:`~bayestissue.inference.diagnostics.runs_mean_error`, the
    evidence's rule); NaN own errors count as zero."""
    v = np.asarray(values, dtype=float)
    return float(v.mean()), float(runs_mean_error(v, np.nan_to_num(np.asarray(errors, dtype=float))))


def _log_share(inside: np.ndarray, w: np.ndarray, reps: np.ndarray | None) -> tuple[float, float]:
    """ln of the weighted share of points ``inside`` and its bootstrap error over the replicate weights."""
    share = float(np.sum(w[inside]) / np.sum(w))
    if reps is None:
        return math.log(share) if share > 0 else -math.inf, math.nan
    boot = reps[inside].sum(axis=0) / reps.sum(axis=0)
    boot = np.log(boot[boot > 0])
    return (math.log(share) if share > 0 else -math.inf), float(boot.std(ddof=1)) if boot.size > 1 else math.nan


def box_shift(runs, specs, factor: float = FACTOR) -> BoxShift:
    """:class:`BoxShift` of one model from its nested ``runs`` (each with ``points`` in natural units, normalised
    ``log_w`` and optional ``bootstrap_weights``) and its sampled parameters' ``specs`` (``name``, ``prior``,
    ``lower``, ``upper``), in the runs' column order."""
    lf = math.log(factor)
    log_cols = [j for j, s in enumerate(specs) if s.prior == "loguniform"]
    if not log_cols:
        raise ValueError("no log-uniform parameter: nothing to narrow or widen")
    width = {j: math.log(specs[j].upper / specs[j].lower) for j in log_cols}
    narrow = [j for j in log_cols if width[j] > 2 * lf]
    volume_narrow = sum(math.log(width[j] / (width[j] - 2 * lf)) for j in narrow)
    values, errs, xs, ws = [], [], [], []
    for r in runs:
        x, w = np.asarray(r.points, dtype=float), np.exp(np.asarray(r.log_w, dtype=float))
        inside = np.ones(len(w), dtype=bool)
        for j in narrow:
            inside &= (x[:, j] >= specs[j].lower * factor) & (x[:, j] <= specs[j].upper / factor)
        log_p, err = _log_share(inside, w, getattr(r, "bootstrap_weights", None))
        values.append(volume_narrow + log_p)
        errs.append(err)
        xs.append(x)
        ws.append(w)
    x, w = np.concatenate(xs), np.concatenate(ws)
    w = w / w.sum()
    edge = [(float(w[x[:, j] < specs[j].lower * factor].sum()), float(w[x[:, j] > specs[j].upper / factor].sum()))
            for j in log_cols]  # fmt: skip
    volume_wide = -sum(math.log((width[j] + 2 * lf) / width[j]) for j in log_cols)
    return BoxShift(
        factor=float(factor),
        names=[specs[j].name for j in log_cols],
        narrowed_runs=[float(v) for v in values],
        narrowed_errs=[float(e) for e in errs],
        narrowed=merge_runs(values, errs) if np.all(np.isfinite(values)) else (-math.inf, math.nan),
        widened_volume=float(volume_wide),
        edge_share=edge,
        widened_flat=float(volume_wide + math.log1p(sum(lo + hi for lo, hi in edge))),
    )
