"""The figure of the branch count (:mod:`bayestissue.analyses.branch_count`): the relaxation with each count's
posterior predictive, its residuals about the median prediction, and each count's evidence per run."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np

from bayestissue.analyses.branch_count import SCATTER_RULE
from bayestissue.plotting.style import FONT, tidy_axes

__all__ = ["BRANCH_COLOURS", "plot_branch_count"]

#: One colour per branch count, the same in every panel.
BRANCH_COLOURS = {1: "tab:red", 2: "tab:blue", 3: "tab:green"}


def _label(n: int) -> str:
    return f"{n} branch{'es' if n > 1 else ''}"


def _curves(ax, rec) -> None:
    t, y = np.asarray(rec.time_s), np.asarray(rec.force_mN)
    every = "" if rec.thin == 1 else f"; every {rec.thin}-th point"
    ax.plot(t, y, ".", color="0.55", ms=2.5, label=f"data (synthetic{every})")
    for i, n in enumerate(rec.counts):  # each later count's line thinner, so that one lying on another shows
        f, c = rec.fits[str(n)], BRANCH_COLOURS.get(n, "0.3")
        ax.fill_between(t, f.band[0], f.band[1], color=c, alpha=0.15, lw=0)
        ax.plot(t, f.median, color=c, lw=max(2.6 - 0.8 * i, 0.8), label=f"{_label(n)}: median, 90 % predictive")
    ax.set_xlabel("time (s)", fontsize=FONT["label"])
    ax.set_ylabel("force (mN)", fontsize=FONT["label"])
    ax.set_title(f"Ramp and hold (generated with {rec.true_branches} branches)", fontsize=FONT["title"])
    ax.legend(fontsize=FONT["legend"], loc="lower right")


def _residuals(ax, rec) -> None:
    """Data minus each count's median prediction, offset by count so that none hides another."""
    t, y = np.asarray(rec.time_s), np.asarray(rec.force_mN)
    step = 0.0
    spread = [np.ptp(y - np.asarray(rec.fits[str(n)].median)) for n in rec.counts]
    gap = 1.1 * max(spread) if spread else 1.0
    ticks = []
    for n in rec.counts:
        f, c = rec.fits[str(n)], BRANCH_COLOURS.get(n, "0.3")
        r = y - np.asarray(f.median)
        ax.plot(t, r + step, ".", color=c, ms=2)
        ax.axhline(step, color=c, lw=0.8)
        ticks.append((step, f"{_label(n)}\nnoise x {f.noise_ratio:.2f}\nlag-1 {f.lag1:.2f}"))
        step -= gap
    ax.set_yticks([s for s, _ in ticks], [lab for _, lab in ticks], fontsize=FONT["legend"])
    ax.set_xlabel("time (s)", fontsize=FONT["label"])
    ax.set_title(f"Residuals about the median (rows {gap:.0f} mN apart)", fontsize=FONT["title"])


def _evidence(ax, rec) -> None:
    """Each run's log Z (own error) and the merged value, relative to the best count's merged log Z, on a scale
    linear within +- 2 nats and logarithmic beyond (one count may lie hundreds of nats below)."""
    best = rec.log_z(rec.best)[0]
    for i, n in enumerate(rec.counts):
        e, c = rec.fits[str(n)].evidence, BRANCH_COLOURS.get(n, "0.3")
        x = i + np.linspace(-0.2, 0.2, len(e.log_z))
        ax.errorbar(x, np.asarray(e.log_z) - best, yerr=e.log_z_err, fmt="o", color=c, ms=4, capsize=2)
        z, s = e.merged
        ax.errorbar([i + 0.32], [z - best], yerr=[s], fmt="s", color=c, ms=6, capsize=3)
        if n != rec.best and rec.decides(n)[1] == SCATTER_RULE:  # the bound that rejects scattered runs
            ax.plot([i - 0.3, i + 0.4], [-rec.scatter_bound(n)] * 2, color=c, ls="--", lw=1)
            ax.annotate(SCATTER_RULE, (i + 0.05, -rec.scatter_bound(n)), xytext=(0, 4),
                        textcoords="offset points", ha="center", fontsize=FONT["legend"], color=c)  # fmt: skip
    ax.set_yscale("symlog", linthresh=2.0)
    ax.axhline(0.0, color="0.4", lw=0.8)
    ax.set_xticks(range(len(rec.counts)), [f"{_label(n)}\n{len(rec.fits[str(n)].evidence.names)} sampled"
                                           for n in rec.counts])  # fmt: skip
    ax.set_xlim(-0.6, len(rec.counts) - 0.4)
    ax.set_ylabel(f"log Z minus {rec.best} branches' merged log Z", fontsize=FONT["label"])
    chosen = rec.chosen
    lines = [f"ln B {rec.best} over {n}: {b:.2f} +- {s:.2f}" + (f" (bound {rec.scatter_bound(n):.2f})" if
             rec.decides(n)[1] == SCATTER_RULE else "") for n, (b, s, _) in rec.grades().items()]  # fmt: skip
    head = f"the evidence picks {chosen}" if chosen is not None else "the evidence does not decide"
    ax.set_title("\n".join([f"log Z: runs (o), merged (s); {head}", *lines]), fontsize=FONT["title"])


def plot_branch_count(rec):
    """The three panels of the module docstring for a :class:`~bayestissue.analyses.branch_count.BranchCountRecord`."""
    fig, axes = plt.subplots(1, 3, figsize=(16, 5.2), gridspec_kw={"width_ratios": [1.2, 1.2, 0.9]})
    _curves(axes[0], rec)
    _residuals(axes[1], rec)
    _evidence(axes[2], rec)
    tidy_axes(fig)
    fig.suptitle(f"Synthetic tendon relaxation: how many Prony branches? ({rec.mode} runs)", fontsize=FONT["title"] + 1)
    fig.tight_layout()
    return fig
