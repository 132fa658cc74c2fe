"""Figures of a calibration: corner plot, traces (emcee) or the nested runs' marginals, posterior predictive
bands, residuals, least-squares history (paper Figs. 9 and 11) and the multi-start waterfall. Every function
returns its figure; none saves or shows.

Parameters on a log-scaled box (moduli and rates) are shown as :math:`\\log_{10}` values: their
posteriors span decades.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "plot_corner",
    "plot_traces",
    "plot_nested_runs",
    "plot_predictive",
    "plot_residuals",
    "plot_ls_history",
    "plot_waterfall",
    "calibration_figures",
    "cut_marginals",
]


def _display(problem, values, idx):
    """Values of the sampled parameters ``idx`` for display: log10 for log-scaled ones; labels."""
    specs = problem.parameters.sampled
    out, labels = [], []
    for j in idx:
        v = np.asarray(values)[..., j]
        if specs[j].scale == "log":
            out.append(np.log10(v))
            labels.append(f"log10 {specs[j].name}")
        else:
            out.append(v)
            labels.append(specs[j].name)
    return np.stack(out, axis=-1), labels


def plot_corner(problem, draws, *, least_squares=None, references=None, max_points=20000):
    """Corner plot of the posterior draws ``(n, ndim)`` (natural units): 50 % and 90 % contours (smoothed by one
    bin), marginals with their 5/50/95 % quantiles, and the reference values marked as :mod:`.style` says.

    ``least_squares`` (LeastSquaresResult) and ``references`` (a label such as ``paper`` or ``generating`` -> a
    full material vector in the paper's order) are drawn as lines across every panel.
    """
    import corner
    import matplotlib.pyplot as plt

    from bayestissue.plotting.style import FONT, reference_handles, reference_style, tidy_axes

    draws = np.asarray(draws, dtype=float)
    if draws.shape[0] > max_points:
        draws = draws[np.linspace(0, draws.shape[0] - 1, max_points).astype(int)]
    idx = list(range(problem.ndim))
    data, labels = _display(problem, draws, idx)
    fig = plt.figure(figsize=(1.7 * len(idx) + 1, 1.7 * len(idx) + 1))
    corner.corner(
        data,
        labels=labels,
        fig=fig,
        quantiles=(0.05, 0.5, 0.95),
        plot_datapoints=False,
        plot_density=False,
        fill_contours=True,
        smooth=1.0,
        levels=(0.5, 0.9),
        max_n_ticks=3,
        label_kwargs={"fontsize": FONT["label"]},
        contourf_kwargs={"colors": ["white", "0.8", "0.55"]},
    )
    marks = {}
    if least_squares is not None:
        marks["least squares"] = problem.canonical(problem.nuisance_estimate(least_squares.x))
    names = problem.material.names
    for label, vec in (references or {}).items():
        vals = dict(zip(names, np.asarray(vec, dtype=float), strict=False))
        marks[label] = np.array([vals.get(n, np.nan) for n in problem.names])
    for label in sorted(marks, key=lambda k: reference_style(k)["zorder"]):
        shown, _ = _display(problem, marks[label][None, :], idx)
        corner.overplot_lines(fig, shown[0], **reference_style(label))
    tidy_axes(fig)
    fig.legend(handles=reference_handles(list(marks)), loc="upper right", fontsize=FONT["legend"] + 2, frameon=False)
    fig.subplots_adjust(bottom=0.08, left=0.08)
    return fig


def plot_traces(sample, *, max_walkers: int = 8):
    """Traces of every sampled parameter: a few walkers of every ensemble, burn-in marked."""
    import matplotlib.pyplot as plt

    from bayestissue.plotting.style import FONT, tidy_axes

    problem = sample.problem
    ndim = problem.ndim
    ncol = 3
    nrow = int(np.ceil(ndim / ncol))
    fig, axes = plt.subplots(nrow, ncol, figsize=(4.2 * ncol, 1.9 * nrow), sharex=True)
    axes = np.atleast_1d(axes).ravel()
    colors = plt.cm.tab10(np.arange(len(sample.ensembles)))
    for k, ens in enumerate(sample.ensembles):
        x = problem.coordinates.from_unconstrained(ens.chain_z.reshape(-1, ndim))
        x = x.reshape(ens.chain_z.shape)
        steps = np.arange(x.shape[0]) * ens.store_thin
        vals, labels = _display(problem, x, range(ndim))
        for j in range(ndim):
            ax = axes[j]
            ax.plot(steps, vals[:, :max_walkers, j], color=colors[k], lw=0.4, alpha=0.6)
            # the end of this ensemble's discarded burn-in (2 tau), visible however long the run
            ax.axvline(ens.burn_in, color=colors[k], ls="--", lw=1.2)
            if k == 0:
                ax.set_ylabel(labels[j], fontsize=FONT["label"] - 1)
                ax.axvspan(0, ens.burn_in, color="0.9", zorder=-1)
    for ax in axes[ndim:]:
        ax.set_visible(False)
    for ax in axes[-ncol:]:
        ax.set_xlabel("step", fontsize=FONT["label"])
    tidy_axes(fig)
    fig.suptitle(
        "traces (colour = ensemble; dashed: end of each ensemble's discarded burn-in, shaded for ensemble 0)",
        fontsize=FONT["title"] - 1,
    )
    fig.tight_layout()
    return fig


def plot_nested_runs(sample, *, bins: int = 40):
    """Each nested run's weighted marginal of every sampled parameter (colour = run; log10 for log-scaled
    parameters): independent runs of a converged posterior lie on top of each other, a run that missed a mode
    shows as a missing peak. The title gives each run's log evidence."""
    import matplotlib.pyplot as plt

    problem = sample.problem
    ndim = problem.ndim
    ncol = 4
    nrow = int(np.ceil(ndim / ncol))
    fig, axes = plt.subplots(nrow, ncol, figsize=(3.2 * ncol, 2.3 * nrow))
    axes = np.atleast_1d(axes).ravel()
    colors = plt.cm.tab10(np.arange(len(sample.runs)))
    shown = [_display(problem, problem.canonical(r.points), range(ndim)) for r in sample.runs]
    labels = shown[0][1]
    pooled = np.concatenate([v for v, _ in shown])
    w = np.concatenate([r.weights for r in sample.runs])
    for j in range(ndim):
        o = np.argsort(pooled[:, j])
        lo, hi = np.interp([0.001, 0.999], np.cumsum(w[o]) / w.sum(), pooled[o, j])
        edges = np.linspace(lo, hi if hi > lo else lo + 1.0, bins + 1)
        for k, ((vals, _), run) in enumerate(zip(shown, sample.runs, strict=True)):
            axes[j].hist(vals[:, j], bins=edges, weights=run.weights, histtype="step", color=colors[k], lw=1.2)
        axes[j].set_xlabel(labels[j], fontsize=9)
        axes[j].set_yticks([])
    for ax in axes[ndim:]:
        ax.set_visible(False)
    runs = ", ".join(f"{r.log_z:.2f} +- {r.log_z_err:.2f}" for r in sample.runs)
    fig.suptitle(f"nested runs (colour = run), weighted marginals; log Z per run: {runs}", fontsize=10)
    fig.tight_layout()
    return fig


def plot_predictive(
    time_s,
    observed,
    model_draws,
    *,
    least_squares_fit=None,
    noisy_draws=None,
    title=None,
    observable: str = "displacement (mm)",
    unit: str = "mm",
):
    """Posterior predictive bands (50 % and 90 %) of the model curve over the data.

    Two panels: the curves, and everything minus the posterior median curve (the bands are too narrow
    to see at the scale of the curve).

    Parameters
    ----------
    time_s, observed : (n_obs,) data.
    model_draws : (n_draws, n_obs) noise-free model predictions for posterior draws.
    least_squares_fit : (n_obs,) prediction at the least-squares estimate.
    noisy_draws : (n_draws, n_obs) predictions with noise (dotted 90 % band of new observations).
    observable, unit : what is observed and its unit, for the axes (``"force on face 1 (mN)"``, ``"mN"``).
    """
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 1, figsize=(7, 6), sharex=True, gridspec_kw={"height_ratios": [3, 2]})
    q = np.quantile(model_draws, [0.05, 0.25, 0.5, 0.75, 0.95], axis=0)
    med = q[2]
    for ax, ref in zip(axes, (0.0, med), strict=True):
        ax.fill_between(time_s, q[0] - ref, q[4] - ref, color="tab:orange", alpha=0.3, lw=0, label="model 90 %")
        ax.fill_between(time_s, q[1] - ref, q[3] - ref, color="tab:orange", alpha=0.7, lw=0, label="model 50 %")
        if noisy_draws is not None:
            qn = np.quantile(noisy_draws, [0.05, 0.95], axis=0)
            ax.plot(time_s, qn[0] - ref, ":", color="tab:purple", lw=1, label="new data 90 %")
            ax.plot(time_s, qn[1] - ref, ":", color="tab:purple", lw=1)
        ax.plot(time_s, observed - ref, ".", color="k", ms=2.5, label="data")
        if least_squares_fit is not None:
            ax.plot(time_s, least_squares_fit - ref, "-", color="tab:blue", lw=1, label="least squares")
    axes[0].set_ylabel(observable)
    axes[1].set_ylabel(f"minus posterior median ({unit})")
    axes[1].set_xlabel("time (s)")
    if title:
        axes[0].set_title(title, fontsize=10)
    axes[0].legend(fontsize=8, loc="lower right")
    fig.tight_layout()
    return fig


def _acf(r, max_lag):
    r = np.asarray(r, dtype=float) - np.mean(r)
    denom = np.sum(r**2)
    return np.array([np.sum(r[k:] * r[: r.size - k]) / denom for k in range(max_lag + 1)])


def plot_residuals(time_s, residuals, *, max_lag: int = 40, title=None, unit: str = "mm"):
    """Residuals over time (in the observed channel's ``unit``) and their autocorrelation function (with the
    white-noise 95 % band)."""
    import matplotlib.pyplot as plt

    fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 3.4), gridspec_kw={"width_ratios": [2, 1]})
    a1.plot(time_s, residuals, ".", ms=2.5, color="k")
    a1.axhline(0, color="0.5", lw=0.8)
    a1.set_xlabel("time (s)")
    a1.set_ylabel(f"data - model ({unit})")
    lag = min(max_lag, len(residuals) - 2)
    acf = _acf(residuals, lag)
    a2.bar(np.arange(lag + 1), acf, color="tab:blue", width=0.8)
    band = 1.96 / np.sqrt(len(residuals))
    a2.axhspan(-band, band, color="0.85", zorder=-1)
    a2.set_xlabel("lag (data steps)")
    a2.set_ylabel("autocorrelation")
    a2.set_title(f"lag-1 autocorrelation {acf[1]:.2f}", fontsize=9)
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return fig


def plot_ls_history(result, *, ax=None, title=None):
    """Scaled parameters :math:`|\\bar\\alpha| = |\\alpha / \\alpha^0|` per iteration, semilog (paper
    Figs. 9 and 11)."""
    import matplotlib.pyplot as plt

    from bayestissue.plotting.style import FONT

    if ax is None:
        _, ax = plt.subplots(figsize=(8.5, 4))
    h = np.abs(result.history_scaled)
    it = np.arange(h.shape[0])
    styles = ["-", "--", ":", "-."]
    for j, name in enumerate(result.names):
        ax.semilogy(it, np.maximum(h[:, j], 1e-12), styles[j % 4], lw=1.2, label=name)
    ax.set_xlabel("iteration", fontsize=FONT["label"])
    ax.set_ylabel("|parameter / initial guess|", fontsize=FONT["label"])
    if title:
        ax.set_title(title, fontsize=FONT["title"])
    # beside the axes, never over the curves
    ax.legend(fontsize=FONT["legend"], loc="center left", bbox_to_anchor=(1.01, 0.5), frameon=False)
    ax.figure.tight_layout()
    return ax.figure


def plot_waterfall(costs, *, labels=None, ax=None, title=None):
    """Final costs of a multi-start least squares, sorted (a *waterfall*); colour = cluster label."""
    import matplotlib.pyplot as plt

    from bayestissue.plotting.style import FONT

    if ax is None:
        _, ax = plt.subplots(figsize=(6, 3.5))
    costs = np.sort(np.asarray(costs, dtype=float))
    labels = np.zeros(costs.size, dtype=int) if labels is None else np.asarray(labels)
    ax.scatter(np.arange(costs.size), costs, c=labels, cmap="tab10", vmin=0, vmax=9, zorder=3)
    ax.plot(np.arange(costs.size), costs, color="0.6", lw=0.8)
    if costs.size and costs.min() > 0 and costs.max() / costs.min() > 10:
        ax.set_yscale("log")
    else:
        ax.ticklabel_format(axis="y", style="sci", scilimits=(-3, 4))
    from matplotlib.ticker import MaxNLocator

    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    ax.set_xlabel("start (sorted by final cost)", fontsize=FONT["label"])
    ax.set_ylabel("final cost F", fontsize=FONT["label"])
    if title:
        ax.set_title(title, fontsize=FONT["title"], pad=12)  # above the axis' offset text
    ax.figure.tight_layout()
    return ax.figure


def calibration_figures(outcome) -> dict:
    """All figures of a :class:`~bayestissue.workflows.CalibrationOutcome`, by name.

    Names: ``ls_history``, ``waterfall``, and with a posterior ``corner``, ``traces`` (emcee) or ``nested_runs``
    (nested), ``predictive_<exp>``, ``residuals_<exp>``. Returns figures; the caller saves and closes them.
    """
    problem = outcome.problem
    figs = {
        "ls_history": plot_ls_history(
            outcome.paper_fit,
            title=f"paper's least squares from its initial guess: cost {outcome.paper_fit.cost:.4g}",
        ),
        "waterfall": plot_waterfall(
            outcome.multistart.costs,
            labels=outcome.multistart.labels,
            title="multi-start least squares (colour = cluster)",
        ),
    }
    ls_pred = problem.predict_material(outcome.best.x[None, :])
    for k, e in enumerate(problem.experiments):
        figs[f"residuals_{e.name}"] = plot_residuals(
            e.time_s, e.observed - ls_pred[k][0], title=f"{e.name}: least-squares residuals", unit=e.unit
        )
    if outcome.sample is None:
        return figs
    refs = {}
    if len(outcome.references) == 1:
        refs = next(iter(outcome.references.values()))
        refs = {k: v for k, v in refs.items() if k in ("paper", "generating")}
    figs["corner"] = plot_corner(problem, outcome.sample.flat(), least_squares=outcome.best, references=refs)
    if hasattr(outcome.sample, "runs"):
        figs["nested_runs"] = plot_nested_runs(outcome.sample)
    else:
        figs["traces"] = plot_traces(outcome.sample)
    pp = outcome.idata.posterior_predictive
    for k, e in enumerate(problem.experiments):
        tag = [v for v in pp.data_vars if not v.endswith("_model")][k]
        model = pp[f"{tag}_model"].values.reshape(-1, e.time_s.size)
        noisy = pp[tag].values.reshape(-1, e.time_s.size)
        figs[f"predictive_{e.name}"] = plot_predictive(
            e.time_s,
            e.observed,
            model,
            least_squares_fit=ls_pred[k][0],
            noisy_draws=noisy,
            title=f"{e.name}: posterior predictive",
            observable=e.meta.get("observable", f"observed ({e.unit})"),
            unit=e.unit,
        )
    return figs


def cut_marginals(cut, *, bins: int = 40):
    """The cut posterior (:mod:`bayestissue.workflows.cut`): each stereology replicate's marginal of every sampled
    parameter (thin, colour = replicate) and the pooled one (black); log10 for log-scaled parameters. Replicates
    that sit apart show how much of the pooled width the stereology's uncertainty makes."""
    import matplotlib.pyplot as plt

    problem = cut.outcomes[0].problem
    ndim = len(cut.names)
    ncol = min(4, ndim)
    nrow = int(np.ceil(ndim / ncol))
    fig, axes = plt.subplots(nrow, ncol, figsize=(3.2 * ncol, 2.4 * nrow), squeeze=False)
    axes = axes.ravel()
    pooled, labels = _display(problem, cut.pooled, range(ndim))
    within = [_display(problem, w, range(ndim))[0] for w in cut.within]
    colors = plt.cm.tab10(np.arange(len(within)) % 10)
    for j in range(ndim):
        lo, hi = np.quantile(pooled[:, j], [0.001, 0.999])
        edges = np.linspace(lo, hi if hi > lo else lo + 1.0, bins + 1)
        for k, w in enumerate(within):
            axes[j].hist(w[:, j], bins=edges, density=True, histtype="step", color=colors[k], lw=0.9)
        axes[j].hist(pooled[:, j], bins=edges, density=True, histtype="step", color="k", lw=1.8)
        axes[j].set_xlabel(labels[j], fontsize=9)
        axes[j].set_yticks([])
    for ax in axes[ndim:]:
        ax.set_visible(False)
    held = "; ".join(
        f"rep {r + 1}: " + (", ".join(f"{k} {v:.3f}" for k, v in h.items()) or "-")
        for r, h in zip(cut.rows, cut.fixed, strict=True)
    )
    fig.suptitle(f"cut posterior: replicates (colour) and pooled (black)\nheld: {held}", fontsize=9)
    fig.tight_layout()
    return fig
