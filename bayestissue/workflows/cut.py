"""The cut posterior over the stereology's replicate table, for any tissue: ``bayestissue fit --replicates``.

The stereology gives bootstrap replicates :math:`\\xi_r` of the tissue's fixed inputs: fibre directions, volume
fractions and, from the Watson concentration of each family, the GOH dispersion :math:`\\kappa_{k,r}` (the
replicate table's ``disp_fibre1..3``; :func:`bayestissue.stereology.axial.watson_goh_dispersion`). The cut
posterior (Plummer 2015, doi:10.1007/s11222-014-9503-z) keeps the mechanical data from updating :math:`\\xi`:

.. math:: p_{cut}(\\theta \\mid y) = \\frac1R \\sum_{r} p(\\theta \\mid y, \\xi_r),

so each chosen replicate is one calibration (:func:`~bayestissue.workflows.calibration.run_calibration`, its own
run directory ``replicate_<r>/``, resumable on its own) with the replicate's directions and fractions in every
experiment's tissue and, where the fibre law has a dispersion parameter (role ``dispersion``: the exponential
fibre's ``disp``), that parameter of family k held at :math:`\\kappa_{k,r}`. The draws are pooled in equal shares
(:func:`pool_draws`). The dispersion of a fibre law is then no longer a parameter the
mechanics must identify (a uniaxial test along the fibres cannot), but a measured input with its uncertainty.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from bayestissue._validation import ValidationError
from bayestissue.mechanics import TissueConfig

__all__ = [
    "CutOutcome",
    "choose_replicates",
    "pool_draws",
    "replicate_experiments",
    "replicate_fixed",
    "replicate_tissue",
    "run_cut_calibration",
    "write_cut_summary",
]


@dataclass
class CutOutcome:
    """The replicates' calibrations and their pooled draws.

    rows : the replicate table's rows used (0-based); outcomes : their
    :class:`~bayestissue.workflows.calibration.CalibrationOutcome`; fixed : each row's held dispersions
    (name -> value); names : the sampled parameters; pooled : (n, len(names)) draws in natural units, equal shares
    per replicate; within : (R, n_r, len(names)) each replicate's draws (thinned to the common count).
    """

    rows: list[int]
    outcomes: list
    fixed: list[dict]
    names: tuple[str, ...]
    pooled: np.ndarray
    within: np.ndarray

    def table(self, level: float = 0.9) -> list[dict]:
        """Per parameter: the pooled median and central interval, the mean width of the replicates' own
        intervals and the ratio pooled / within (how much the stereology's uncertainty widens it)."""
        a = (1.0 - level) / 2.0
        rows = []
        for j, name in enumerate(self.names):
            lo, med, hi = np.quantile(self.pooled[:, j], [a, 0.5, 1.0 - a])
            w = np.quantile(self.within[:, :, j], 1.0 - a, axis=1) - np.quantile(self.within[:, :, j], a, axis=1)
            within = float(np.mean(w))
            ratio = float((hi - lo) / within) if within > 0 else np.nan
            rows.append({"parameter": name, "median": float(med), "lower": float(lo), "upper": float(hi),
                         "within_width": within, "width_ratio": ratio})  # fmt: skip
        return rows


def replicate_tissue(tissue: TissueConfig, replicates: Mapping, row: int) -> TissueConfig:
    """``tissue`` with the directions and fractions of the replicate row (renormalised to sum 1: the table rounds);
    the laws, bulk modulus and slack strains stay. Needs a tissue of three fibre families, as the table has."""
    if tissue.n_fibres != 3:
        raise ValidationError("tissue fibre families", tissue.n_fibres, "3 (the replicate table's families)")
    D = np.asarray(replicates["directions"][row], dtype=float)
    phi = np.asarray(replicates["phi_fibres"][row], dtype=float)
    pm = float(replicates["phi_matrix"][row])
    total = pm + phi.sum()
    return replace(tissue, directions=D / np.linalg.norm(D, axis=1, keepdims=True), phi_fibres=phi / total,
                   phi_matrix=pm / total)  # fmt: skip


def pool_draws(draws: Sequence[np.ndarray], *, n_per: int | None = None, rng=None) -> np.ndarray:
    """Pool per-replicate posterior draws in equal shares (the mixture :math:`\\frac1R\\sum_r p_r`).

    ``n_per`` draws are taken from each replicate without replacement (default: the smallest count).
    """
    rng = np.random.default_rng(rng)
    arrays = [np.asarray(d, dtype=float) for d in draws if d is not None]
    if not arrays:
        raise ValidationError("draws", "no replicate draws", "at least one (n, p) array")
    p = {a.shape[1] for a in arrays}
    if len(p) != 1:
        raise ValidationError("draws", [a.shape for a in arrays], "arrays with the same number of columns")
    n = min(a.shape[0] for a in arrays) if n_per is None else int(n_per)
    if n < 1 or n > min(a.shape[0] for a in arrays):
        raise ValidationError("n_per", n_per, f"an integer in [1, {min(a.shape[0] for a in arrays)}]")
    return np.concatenate([a[rng.choice(a.shape[0], n, replace=False)] for a in arrays])


def replicate_experiments(experiments: Sequence, replicates: Mapping, row: int) -> list:
    """Every experiment with its tissue's fixed inputs from the replicate row (:func:`replicate_tissue`)."""
    return [replace(e, tissue=replicate_tissue(e.tissue, replicates, row)) for e in experiments]


def replicate_fixed(tissue: TissueConfig, replicates: Mapping, row: int) -> dict[str, float]:
    """The fibre law's dispersion parameter of each family held at the row's ``disp_fibre<k>`` (empty if the law
    has none). A law with a dispersion parameter and a table without dispersion columns is refused: the cut would
    silently sample what the stereology measures."""
    names = {}
    for k in range(1, tissue.n_fibres + 1):
        for name in tissue.family_parameters(k):
            spec = next(p for p in tissue.parameters if p.name == name)
            if spec.role == "dispersion":
                names[name] = k
    if not names:
        return {}
    disp = replicates.get("dispersion")
    if disp is None:
        raise ValidationError("replicate table", "no disp_fibre1..3 columns",
                              f"the families' dispersions for {sorted(names)} (bayestissue stereology replicates "
                              "with the Watson directions writes them)")  # fmt: skip
    return {name: float(disp[row][k - 1]) for name, k in names.items()}


def choose_replicates(n_rows: int, n: int, seed: int) -> list[int]:
    """``n`` distinct rows of the table (all if ``n >= n_rows``), drawn with ``seed``, in increasing order."""
    if not (isinstance(n, int) and n >= 2):
        raise ValidationError("--n-replicates", n, "an integer >= 2 (a cut posterior averages several replicates)")
    rng = np.random.default_rng(seed)
    return sorted(int(r) for r in rng.choice(n_rows, min(n, n_rows), replace=False))


def run_cut_calibration(
    experiments: Sequence,
    config,
    replicates: Mapping,
    *,
    n_replicates: int = 4,
    out_dir: str | Path | None = None,
    resume: bool = False,
    say: Callable[[str], None] | None = None,
    **kwargs,
) -> CutOutcome:
    """One calibration per chosen replicate row (module docstring), then the pooled draws. ``kwargs`` go to
    :func:`~bayestissue.workflows.calibration.run_calibration` (progress, provenance)."""
    from bayestissue.inference.posterior import evenly
    from bayestissue.workflows.calibration import run_calibration

    say = say or (lambda line: None)
    if not config.sample:
        raise ValidationError("--replicates", "with --no-sample", "a sampled run (the cut pools posterior draws)")
    rows = choose_replicates(len(replicates["phi_matrix"]), n_replicates, config.seed)
    base = dict(config.fixed) if isinstance(config.fixed, Mapping) else {n: None for n in config.fixed}
    fixed = [replicate_fixed(experiments[0].tissue, replicates, r) for r in rows]
    outcomes = []
    for i, (r, held) in enumerate(zip(rows, fixed, strict=True)):
        held_text = ", ".join(f"{k}={v:.4g}" for k, v in held.items()) or "no dispersion parameter"
        say(f"replicate {r + 1} ({i + 1}/{len(rows)}): {held_text}")
        cfg = replace(config, fixed={**base, **held}, seed=config.seed + r)
        sub = None if out_dir is None else Path(out_dir) / f"replicate_{r + 1}"
        outcomes.append(run_calibration(replicate_experiments(experiments, replicates, r), cfg, out_dir=sub,
                                        resume=resume, say=say, **kwargs))  # fmt: skip
    names = tuple(outcomes[0].sample.names)
    draws = [o.sample.flat() for o in outcomes]
    n = min(d.shape[0] for d in draws)
    within = np.stack([d[evenly(d.shape[0], n)] for d in draws])
    pooled = pool_draws(list(within), rng=config.seed)
    return CutOutcome(rows, outcomes, fixed, names, pooled, within)


def write_cut_summary(cut: CutOutcome, out_dir: str | Path, *, figures: bool = True) -> str:
    """``cut_summary.csv`` (one row per sampled parameter: pooled median and 90 % interval, the replicates' mean
    interval width, their ratio), ``cut_summary.md`` (that table, each replicate's held dispersions, verdict and
    predictive check) and, with ``figures``, ``cut_marginals.png``; returns the markdown."""
    from bayestissue.io.tables import write_table

    out = Path(out_dir)
    rows = cut.table()
    write_table(out / "cut_summary.csv", {k: np.array([r[k] for r in rows]) for k in rows[0]},
                meta={"cut_posterior": f"{len(cut.rows)} stereology replicates pooled in equal shares",
                      "replicate_rows": ", ".join(str(r + 1) for r in cut.rows)})  # fmt: skip
    used = ", ".join(str(r + 1) for r in cut.rows)
    head = "| parameter | median | 90 % interval | within-replicate width | pooled / within |"
    lines = [
        f"# Cut posterior over {len(cut.rows)} stereology replicates (rows {used})",
        "",
        head,
        "|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(f"| {r['parameter']} | {r['median']:.4g} | [{r['lower']:.4g}, {r['upper']:.4g}] | "
                     f"{r['within_width']:.4g} | {r['width_ratio']:.2f} |")  # fmt: skip
    lines += ["", "| replicate | held | verdict | predictive check |", "|---|---|---|---|"]
    for r, held, o in zip(cut.rows, cut.fixed, cut.outcomes, strict=True):
        h = ", ".join(f"{k} = {v:.4f}" for k, v in held.items()) or "-"
        lines.append(f"| {r + 1} | {h} | {o.report.verdict().split(':')[0]} | {o.table['meta']['fit_check']} |")
    text = "\n".join(lines) + "\n"
    (out / "cut_summary.md").write_text(text)
    if figures:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        from bayestissue.plotting.inference import cut_marginals

        fig = cut_marginals(cut)
        fig.savefig(out / "cut_marginals.png", dpi=110)
        plt.close(fig)
    return text
