"""The figure of the model choice (:mod:`bayestissue.analyses.model_choice`): each run's evidence with its own error,
and each parameter's 90 % interval per run and merged, in box coordinates."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np

from bayestissue.plotting.style import FONT, tidy_axes

__all__ = ["MODEL_COLOURS", "plot_model_choice"]

#: One colour per model, the same in both panels.
MODEL_COLOURS = {"mirror": "tab:blue", "full": "tab:orange", "scale": "tab:green"}


def _label(name: str, names) -> str:
    """``name``, its material parameters and its noise sds (one per test)."""
    sds = sum(n.startswith("sigma") for n in names)
    return f"{name}\n{len(names) - sds} parameters\n+ {sds} noise sd{'s' if sds != 1 else ''}"


def _evidence(ax, case) -> None:
    for i, (name, e) in enumerate(case.models.items()):
        x = i + np.linspace(-0.25, 0.25, len(e.log_z))
        c = MODEL_COLOURS.get(name, "0.4")
        ax.errorbar(x, e.log_z, yerr=e.log_z_err, fmt="o", color=c, capsize=3, label=f"{name}: runs (own errors)")
        z, s = e.merged
        ax.axhspan(z - s, z + s, color=c, alpha=0.18, lw=0)
        ax.axhline(z, color=c, lw=1.2, label=f"{name}: merged {z:.2f} +- {s:.2f}")
    ax.set_xticks(range(len(case.models)), [_label(n, e.names) for n, e in case.models.items()])
    ax.set_ylabel("log evidence per run", fontsize=FONT["label"])
    pairs = [(a, b) for a, b in case.factors if {a, b} <= case.models.keys()]
    if pairs:
        lines = [f"ln B {a} over {b} = {v:.2f} +- {s:.2f}" + ("" if case.factor_decides(a, b) else
                                                                " (runs disagree: no verdict)")
                 for a, b in pairs for v, s in [case.log_bayes(a, b)]]  # fmt: skip
        ax.set_title("\n".join(lines), fontsize=FONT["title"])
    ax.margins(y=0.08)
    # below the axes: runs that lost the peak sit far below the others, so no corner of the panel is always free
    ax.legend(fontsize=FONT["legend"] - 1, loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=2)


def _intervals(ax, case) -> None:
    names = list(dict.fromkeys(n for e in sorted(case.models.values(), key=lambda e: -len(e.names)) for n in e.names))
    rows = {n: len(names) - 1 - i for i, n in enumerate(names)}
    half = 0.1 * len(case.models)  # the models' rows spread over +- half around each parameter's
    for j, (name, e) in enumerate(case.models.items()):
        c = MODEL_COLOURS.get(name, "0.4")
        shift = half - 2 * half * j / max(len(case.models) - 1, 1)
        for p, u in zip(e.names, e.unit_quantiles, strict=True):
            y = rows[p] + shift
            runs = [r[e.names.index(p)] for r in e.run_unit_quantiles]
            for k, r in enumerate(runs):
                yk = y + (k - (len(runs) - 1) / 2) * 0.06
                ax.plot([r[0], r[2]], [yk, yk], color=c, lw=0.8, alpha=0.6)
            ax.plot([u[0], u[2]], [y - 0.12, y - 0.12], color=c, lw=3.0, solid_capstyle="butt",
                    label=f"{name}: merged 90 %" if p == e.names[0] else None)  # fmt: skip
            ax.plot(u[1], y - 0.12, "|", color="k", ms=8)
    ax.set_yticks(list(rows.values()), list(rows))
    ax.set_xlim(0, 1)
    ax.set_xlabel("position in the prior box (log scale where log-uniform)", fontsize=FONT["label"])
    ax.set_title("90 % interval per run (thin) and merged (thick, | median)", fontsize=FONT["title"])
    # below the axes, like the evidence panel's: inside, it hid the lowest rows' intervals
    ax.legend(fontsize=FONT["legend"] - 1, loc="upper center", bbox_to_anchor=(0.5, -0.1), ncol=len(case.models))


#: How the title names each factor's pair (numerator, denominator).
PAIR_WORDS = {("mirror", "full"): "the mirror model against the paper's 11 parameters",
              ("scale", "mirror"): "a T2 stiffness scale against shared parameters"}  # fmt: skip


def _title(case) -> str:
    """The factors the figure shows, and the models of the data set not run yet (they run in separate sessions)."""
    shown = [PAIR_WORDS.get((a, b), f"{a} against {b}") for a, b in case.factors_run]
    missing = case.missing
    if not missing:
        return ", and ".join(shown)
    wait = f"the {' and '.join(missing)} {'model' if len(missing) == 1 else 'models'} not run yet"
    return ", and ".join(shown) + f" ({wait})" if shown else f"{', '.join(case.models)} model runs; {wait}"


def plot_model_choice(case, mode: str, path):
    """Write the two-panel figure of one data set's :class:`~bayestissue.analyses.model_choice.DataChoice` (a ``mode``
    run) to ``path``; returns the (closed) figure."""
    fig, (a, b) = plt.subplots(1, 2, figsize=(12, 6.2), gridspec_kw={"width_ratios": [1, 1.5]})
    _evidence(a, case)
    _intervals(b, case)
    tidy_axes(fig)
    fig.suptitle(f"{case.data}: {_title(case)} ({mode} run)", fontsize=FONT["title"] + 1)
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)
    return fig
