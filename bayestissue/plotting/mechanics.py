"""Figures of the forward model: simulated curves over data (the analogue of the paper's Figs. 10 and 12)."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np

__all__ = ["plot_fit_curves"]


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
