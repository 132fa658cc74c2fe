"""Rank statistics and the rank-histogram figure of the simulation-based calibration benchmarks
(``sbc_nested.py``, ``sbc_emcee.py``; Talts et al. 2018, arXiv:1804.06788).

A replication's rank of a generating value among ``L`` posterior draws is uniform on ``0..L`` when the sampler draws
from the posterior the data were simulated under. Per parameter: a chi-square test of the ranks' counts in 10 equal
bins (9 dof) and a Kolmogorov-Smirnov test of the fractional ranks randomised within their bin
(``(rank + U) / (L + 1)``, uniform on (0, 1) under calibration).
"""

from __future__ import annotations

import numpy as np
from scipy import stats

BINS = 10


def rank_tests(ranks: np.ndarray, n_draws: int, names, *, seed: int = 0) -> list[dict]:
    """Per parameter ``{name, counts, p_chi2, p_ks}`` of ``ranks`` ``(n_replications, n_parameters)`` among
    ``n_draws`` draws."""
    ranks = np.asarray(ranks)
    edges = np.linspace(0, n_draws + 1, BINS + 1)
    u = (ranks + np.random.default_rng(seed).random(ranks.shape)) / (n_draws + 1)
    rows = []
    for j, name in enumerate(names):
        counts, _ = np.histogram(ranks[:, j], bins=edges)
        rows.append(
            {
                "name": name,
                "counts": counts.tolist(),
                "p_chi2": float(stats.chisquare(counts).pvalue),
                "p_ks": float(stats.kstest(u[:, j], "uniform").pvalue),
            }
        )
    return rows


def rank_lines(rows) -> list[str]:
    """One printed line per parameter."""
    return [
        f"{r['name']}: rank counts per decile {r['counts']}; chi-square p = {r['p_chi2']:.3f}, KS p = {r['p_ks']:.3f}"
        for r in rows
    ]


def rank_figure(panels, n_draws: int, names, title: str, out) -> None:
    """Rank histograms, one row per panel ``(ranks, rows from rank_tests or None, row label)`` and one column per
    parameter, with the 99 % band of a uniform rank's bin count and each parameter's two p-values; saved to ``out``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(panels), len(names), figsize=(3.4 * len(names), 3.0 * len(panels)), squeeze=False)
    edges = np.linspace(0, n_draws + 1, BINS + 1)
    for row_axes, (ranks, rows, label) in zip(axes, panels, strict=True):
        ranks = np.asarray(ranks)
        lo, hi = stats.binom.ppf([0.005, 0.995], ranks.shape[0], 1 / BINS)
        for j, (ax, name) in enumerate(zip(row_axes, names, strict=True)):
            ax.hist(ranks[:, j], bins=edges, color="tab:blue", edgecolor="w")
            ax.axhspan(lo, hi, color="0.85", zorder=-1, label="99 % band of uniform ranks")
            ax.set_xlabel(f"rank of the generating {name}")
            if rows is not None:
                ax.set_title(f"chi2 p = {rows[j]['p_chi2']:.2f}, KS p = {rows[j]['p_ks']:.2f}", fontsize=9)
        row_axes[0].set_ylabel(f"{label}: replications" if label else "replications")
    axes[0, 0].legend(fontsize=7, loc="lower left")
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)
    print(f"wrote {out}")
