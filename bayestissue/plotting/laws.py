"""Figures of the law comparison (:mod:`bayestissue.analyses.law_choice`): measured curves in several modes with each
law's 90 % predictive band, the prediction errors and the evidence."""

from __future__ import annotations

from dataclasses import dataclass, field

import matplotlib.pyplot as plt
import numpy as np

__all__ = ["LAW_COLOURS", "ModePanel", "plot_law_choice"]

#: One colour per law label, the same in every figure.
LAW_COLOURS = {
    "neo-Hookean": "0.45",
    "Mooney-Rivlin": "tab:blue",
    "Ogden 1": "tab:orange",
    "Ogden 2": "tab:green",
    "Ogden 3": "tab:red",
}


@dataclass
class ModePanel:
    """One mode's curve: ``x`` (stretch or amount of shear) and the measured ``y``; ``bands`` law label ->
    ``(median, 5 %, 95 %)`` of the model curve over the posterior draws at the points (without noise); ``fitted``
    whether the laws were calibrated on this mode (else predicted)."""

    mode: str
    xlabel: str
    ylabel: str
    x: np.ndarray
    y: np.ndarray
    fitted: bool
    bands: dict = field(default_factory=dict)


def _panel(ax, panel: ModePanel, font):
    order = np.argsort(panel.x)
    x = np.asarray(panel.x)[order]
    y = np.asarray(panel.y, dtype=float)
    span = max(np.ptp(y), 1e-12)
    # room beyond the data on the side where they lie (a prediction overshooting them stays in view)
    lo_lim = min(y.min(), 0.0) - (0.4 if y.min() < 0 else 0.12) * span
    hi_lim = max(y.max(), 0.0) + (0.4 if y.max() > 0 else 0.12) * span
    off = []
    for label, (mid, lo, hi) in panel.bands.items():
        colour = LAW_COLOURS.get(label, "k")
        ax.fill_between(x, np.asarray(lo)[order], np.asarray(hi)[order], color=colour, alpha=0.2, lw=0)
        ax.plot(x, np.asarray(mid)[order], color=colour, lw=1.4, label=label)
        if np.any((np.asarray(mid) > hi_lim) | (np.asarray(mid) < lo_lim)):
            off.append(label)
    ax.plot(panel.x, y, "o", ms=3.5, mfc="none", color="k", label="measured", zorder=5)
    ax.set_ylim(lo_lim, hi_lim)
    if off:  # a prediction far outside the data's range would flatten the curve: say so instead
        ax.text(0.02, 0.97, "off scale: " + ", ".join(off), transform=ax.transAxes, va="top",
                fontsize=font["tick"], color="0.3")  # fmt: skip
    ax.set_title(f"{panel.mode} ({'fitted' if panel.fitted else 'predicted'})", fontsize=font["title"] - 2)
    ax.set_xlabel(panel.xlabel, fontsize=font["label"] - 1)
    ax.set_ylabel(panel.ylabel, fontsize=font["label"] - 1)
    ax.grid(alpha=0.3)


def _errors(ax, modes, laws, rms, font):
    """Grouped bars: relative RMS error of the median prediction per mode (rows of ``rms``: laws)."""
    width = 0.8 / max(len(laws), 1)
    for k, label in enumerate(laws):
        pos = np.arange(len(modes)) + (k - (len(laws) - 1) / 2) * width
        ax.bar(pos, [rms[label][m] for m in modes], width, color=LAW_COLOURS.get(label, "k"), label=label)
    ax.set_yscale("log")
    ax.set_xticks(np.arange(len(modes)), [m.replace(" ", "\n", 1) for m in modes], fontsize=font["tick"] - 1)
    ax.set_ylabel("RMS error / range of the curve", fontsize=font["label"] - 1)
    ax.set_title("error of the median prediction", fontsize=font["title"] - 2)
    ax.grid(alpha=0.3, axis="y")


def _evidence(ax, laws, factors, font):
    """Horizontal bars: log Bayes factor of the best law over each (0 for the best), with 2-sigma error bars."""
    y = np.arange(len(laws))
    vals = np.array([factors[label][0] for label in laws])
    errs = np.array([factors[label][1] for label in laws])
    ax.barh(y, np.maximum(vals, 1e-3), xerr=2 * errs, color=[LAW_COLOURS.get(label, "k") for label in laws],
            capsize=3)  # fmt: skip
    for yi, v in zip(y, vals, strict=True):
        ax.text(max(v, 1e-3) * 1.15, yi, "best" if v == 0 else f"{v:.3g}", va="center", fontsize=font["tick"] - 1)
    ax.set_xscale("symlog", linthresh=1.0)
    ax.set_xlim(0, max(10.0, vals.max() * 20))
    ax.set_yticks(y, laws, fontsize=font["tick"] - 1)
    ax.invert_yaxis()
    from bayestissue.analyses.verdicts import BAYES_POSITIVE, BAYES_VERY_STRONG

    ax.axvline(BAYES_POSITIVE, color="0.5", lw=0.8, ls=":")
    ax.axvline(BAYES_VERY_STRONG, color="0.5", lw=0.8, ls="--")
    grades = (
        f"positive from {BAYES_POSITIVE:g} (dotted),\nvery strong from {BAYES_VERY_STRONG:g} (dashed; Kass & Raftery)"
    )
    ax.set_xlabel(f"ln B of the best law over this one\n(2-sigma bars); {grades}", fontsize=font["label"] - 2)
    ax.set_title("joint fits: evidence", fontsize=font["title"] - 2)
    ax.grid(alpha=0.3, axis="x")


def plot_law_choice(transfer: list[ModePanel], joint: list[ModePanel], rms: dict, factors: dict, *, title: str):
    """Two rows: the laws calibrated on the first mode alone and predicting the others, then calibrated on all modes
    jointly; the last column the transfer's prediction errors (``rms``: law -> mode -> relative RMS) and the joint
    evidence (``factors``: law -> (ln B of the best over it, its error)). Returns the figure."""
    from bayestissue.plotting.style import FONT, tidy_axes

    n = max(len(transfer), len(joint))
    fig, axes = plt.subplots(2, n + 1, figsize=(4.1 * (n + 1), 8.2), squeeze=False)
    laws = list(factors)
    for row, panels in enumerate((transfer, joint)):
        for k, panel in enumerate(panels):
            _panel(axes[row, k], panel, FONT)
        for k in range(len(panels), n):
            axes[row, k].set_visible(False)
    for row in (0, 1):  # each row its own legend: the joint row may hold laws the transfer row has not
        axes[row, 0].legend(fontsize=FONT["legend"] - 2, loc="upper left")
    axes[0, 0].annotate(f"calibrated on {transfer[0].mode} alone", (0.0, 1.13), xycoords="axes fraction",
                        fontsize=FONT["title"] - 1, weight="bold")  # fmt: skip
    axes[1, 0].annotate("calibrated on all modes jointly", (0.0, 1.13), xycoords="axes fraction",
                        fontsize=FONT["title"] - 1, weight="bold")  # fmt: skip
    _errors(axes[0, n], [p.mode for p in transfer[1:]], [law for law in laws if law in rms], rms, FONT)
    _evidence(axes[1, n], laws, factors, FONT)
    fig.suptitle(title, fontsize=FONT["title"])
    tidy_axes(fig)
    fig.tight_layout()
    return fig
