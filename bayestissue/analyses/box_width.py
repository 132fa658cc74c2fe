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

**From importance-weighted draws** (:func:`box_shift_weighted`, the evidence check's draws,
:mod:`~bayestissue.analyses.evidence_check`): the same terms, the posterior shares from the self-normalised weights.
Their error is that of a share among as many independent draws as the weights' Kish effective sample size
:math:`n_e` (Kish 1965, *Survey Sampling*, 8.2), with the Agresti-Coull centre
:math:`\\tilde p = (n_e \\hat p + 1)/(n_e + 2)` so that a share of 1 (no weight outside) still carries one
(Agresti & Coull 1998, *Am. Stat.* 52, 119): :math:`\\sigma_{\\ln p} = \\sqrt{\\tilde p (1 - \\tilde p)/(n_e + 2)}
/ \\tilde p`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from bayestissue.inference.diagnostics import runs_mean_error

__all__ = ["FACTOR", "BoxShift", "box_shift", "box_shift_weighted", "merge_runs"]

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


@dataclass(frozen=True)
class _Boxes:
    """The log-scaled columns of ``specs``, their widths :math:`W_j`, the ones narrowing keeps (wider than
    ``factor**2``) and the two volume terms (module docstring)."""

    factor: float
    log_cols: list[int]
    narrow: list[int]
    volume_narrow: float
    volume_wide: float

    @classmethod
    def of(cls, specs, factor: float) -> _Boxes:
        lf = math.log(factor)
        log_cols = [j for j, s in enumerate(specs) if s.prior == "loguniform"]
        if not log_cols:
            raise ValueError("no log-uniform parameter: nothing to narrow or widen")
        width = {j: math.log(specs[j].upper / specs[j].lower) for j in log_cols}
        narrow = [j for j in log_cols if width[j] > 2 * lf]
        return cls(factor=float(factor), log_cols=log_cols, narrow=narrow,
                   volume_narrow=sum(math.log(width[j] / (width[j] - 2 * lf)) for j in narrow),
                   volume_wide=-sum(math.log((width[j] + 2 * lf) / width[j]) for j in log_cols))  # fmt: skip

    def inside(self, x: np.ndarray, specs) -> np.ndarray:
        """Which points ``x`` (natural units) lie inside the narrowed boxes."""
        keep = np.ones(x.shape[0], dtype=bool)
        for j in self.narrow:
            keep &= (x[:, j] >= specs[j].lower * self.factor) & (x[:, j] <= specs[j].upper / self.factor)
        return keep

    def shift(self, specs, narrowed: list[tuple[float, float]], merged: tuple[float, float], x, w) -> BoxShift:
        """The :class:`BoxShift` from per-estimate ``narrowed`` (value, error) pairs, their ``merged`` value and the
        pooled points ``x`` with normalised weights ``w`` (for the edge shares)."""
        f = self.factor
        edge = [(float(w[x[:, j] < specs[j].lower * f].sum()), float(w[x[:, j] > specs[j].upper / f].sum()))
                for j in self.log_cols]  # fmt: skip
        return BoxShift(
            factor=f,
            names=[specs[j].name for j in self.log_cols],
            narrowed_runs=[float(v) for v, _ in narrowed],
            narrowed_errs=[float(e) for _, e in narrowed],
            narrowed=merged,
            widened_volume=float(self.volume_wide),
            edge_share=edge,
            widened_flat=float(self.volume_wide + math.log1p(sum(lo + hi for lo, hi in edge))),
        )


def box_shift(runs, specs, factor: float = FACTOR) -> BoxShift:
    """:class:`BoxShift` of one model from its nested ``runs`` (each with ``points`` in natural units, normalised
    ``log_w`` and optional ``bootstrap_weights``) and its sampled parameters' ``specs`` (``name``, ``prior``,
    ``lower``, ``upper``), in the runs' column order."""
    boxes = _Boxes.of(specs, factor)
    narrowed, xs, ws = [], [], []
    for r in runs:
        x, w = np.asarray(r.points, dtype=float), np.exp(np.asarray(r.log_w, dtype=float))
        log_p, err = _log_share(boxes.inside(x, specs), w, getattr(r, "bootstrap_weights", None))
        narrowed.append((boxes.volume_narrow + log_p, err))
        xs.append(x)
        ws.append(w)
    x, w = np.concatenate(xs), np.concatenate(ws)
    values = [v for v, _ in narrowed]
    merged = merge_runs(values, [e for _, e in narrowed]) if np.all(np.isfinite(values)) else (-math.inf, math.nan)
    return boxes.shift(specs, narrowed, merged, x, w / w.sum())


def box_shift_weighted(points, weights, ess: float, specs, factor: float = FACTOR) -> BoxShift:
    """:class:`BoxShift` of one model from importance-weighted draws ``points`` ``(n, d)`` (natural units, in the
    column order of ``specs``) with ``weights`` and their Kish effective sample size ``ess``; the narrowed share's
    error as the module docstring says (one estimate: ``narrowed_runs`` holds it alone)."""
    x, w = np.asarray(points, dtype=float), np.asarray(weights, dtype=float)
    if x.ndim != 2 or x.shape != (w.size, len(specs)) or not np.all(np.isfinite(w)) or np.any(w < 0) or w.sum() <= 0:
        raise ValueError(f"weighted draws of shape {x.shape} with {w.size} weights: expected (n, {len(specs)}) "
                         "points and n finite, non-negative weights, not all zero")  # fmt: skip
    if not ess >= 1.0:
        raise ValueError(f"effective sample size {ess}: expected at least 1")
    boxes = _Boxes.of(specs, factor)
    w = w / w.sum()
    share = float(w[boxes.inside(x, specs)].sum())
    centre = (ess * share + 1.0) / (ess + 2.0)
    err = math.sqrt(centre * (1.0 - centre) / (ess + 2.0)) / centre
    value = boxes.volume_narrow + (math.log(share) if share > 0 else -math.inf)
    merged = (value, err) if math.isfinite(value) else (-math.inf, math.nan)
    return boxes.shift(specs, [(value, err)], merged, x, w)
