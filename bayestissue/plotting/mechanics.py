"""Figures of the forward model: simulated curves over data (the analogue of the paper's Figs. 10 and 12)."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np

__all__ = ["plot_fit_curves", "plot_stress_stretch"]


def plot_fit_curves(experiment, curves: dict, *, ax=None, title: str | None = None):
    """Plot the data of ``experiment`` and simulated displacement curves.

    Parameters
    ----------
    experiment : Experiment
        Its ``time_s`` and ``displacement_mm`` (if any) are drawn as data points.
    curves : dict
        Label -> (n_obs,) displacement (mm) at the data times.
    ax : matplotlib Axes, optional

    Returns
    -------
    The Axes.
    """
    if ax is None:
        _, ax = plt.subplots(figsize=(6, 4))
    if experiment.displacement_mm is not None:
        label = "data (synthetic replica)" if experiment.synthetic else "data"
        ax.plot(experiment.time_s, experiment.displacement_mm, ".", ms=3, color="0.45", label=label, zorder=1)
    styles = ["-", "--", "-.", ":"]
    for k, (lab, u) in enumerate(curves.items()):
        u = np.asarray(u)
        ax.plot(experiment.time_s, u, styles[k % len(styles)], lw=1.8, label=lab, zorder=2)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("displacement of loaded face (mm)")
    ax.set_title(title or f"{experiment.name}: {experiment.protocol.kind} test")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return ax


def plot_stress_stretch(stretch, stress, *, model_draws=None, fits=None, title=None):
    """A stretch-controlled elastic test: measured nominal stress against stretch with the 90 % band of the model
    curve over posterior draws (``model_draws`` ``(n_draws, n_obs)``), other fitted curves (``fits``: label ->
    ``(n_obs,)``), and below it the residuals of each fit against the stretch. Returns the figure."""
    from bayestissue.plotting.style import FONT, tidy_axes

    fig, (ax, axr) = plt.subplots(2, 1, figsize=(7, 6), sharex=True, height_ratios=(3, 1.4))
    lam = np.asarray(stretch, dtype=float)
    fine_order = np.argsort(lam)
    if model_draws is not None:
        lo, hi = np.quantile(model_draws, [0.05, 0.95], axis=0)
        ax.fill_between(lam[fine_order], lo[fine_order], hi[fine_order], color="tab:orange", alpha=0.35, lw=0,
                        label="posterior 90 % band (model curve)")  # fmt: skip
    ax.plot(lam, stress, "o", ms=4, color="0.2", label="measured", zorder=5)
    styles = [{"color": "tab:blue", "ls": "-"}, {"color": "tab:red", "ls": "--"}, {"color": "tab:green", "ls": ":"}]
    for k, (label, curve) in enumerate((fits or {}).items()):
        ax.plot(lam[fine_order], np.asarray(curve)[fine_order], lw=1.5, label=label, **styles[k % len(styles)])
        axr.plot(lam, np.asarray(curve) - stress, marker="o", ms=3, lw=1, **styles[k % len(styles)])
    axr.axhline(0.0, color="0.5", lw=0.8)
    ax.set_ylabel("nominal stress P11 (kPa)", fontsize=FONT["label"])
    axr.set_ylabel("fit - measured (kPa)", fontsize=FONT["label"])
    axr.set_xlabel("stretch", fontsize=FONT["label"])
    ax.legend(fontsize=FONT["legend"] - 1, loc="upper left")
    ax.grid(alpha=0.3)
    axr.grid(alpha=0.3)
    if title:
        ax.set_title(title, fontsize=FONT["title"] - 1)
    tidy_axes(fig)
    fig.tight_layout()
    return fig
