"""The hierarchical model's figure: per population parameter, each specimen's own fit beside its shrunken estimate,
each group's typical specimen and the range of a new one; below, each group effect's posterior."""

from __future__ import annotations

import numpy as np

from bayestissue.plotting.style import FONT, reference_handles, tidy_axes

__all__ = ["hierarchy_figure"]

_COLOURS = ("tab:blue", "tab:orange", "tab:green", "tab:purple", "tab:brown", "tab:pink")


def _log_ticks(ax) -> None:
    """A log axis: matplotlib's powers of ten over two decades or more; below that plain numbers at 1, 2, 5 x 10^k
    (the default labels every minor tick there, and they overlap)."""
    from matplotlib.ticker import LogLocator, NullFormatter, ScalarFormatter

    ax.set_xscale("log")
    lo, hi = ax.get_xlim()
    if np.log10(hi / lo) >= 2.0:
        return
    ax.xaxis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
    fmt = ScalarFormatter()
    fmt.set_powerlimits((-3, 4))
    ax.xaxis.set_major_formatter(fmt)
    ax.xaxis.set_minor_formatter(NullFormatter())


def hierarchy_figure(post, stage1, *, truth: dict | None = None, level: float = 0.9):
    """One column per population parameter. Top: a row per specimen (grouped), its own 90 % interval (grey) and
    its shrunken one (the group's colour), then per group its typical specimen (square, 90 % interval) over the
    shaded 90 % range of a new specimen. Bottom (with two or more groups): the effect of each group against the
    reference (ratio on a log scale) with its 90 % interval and P(> 0). ``truth``: name -> per specimen generating
    values (dashed green ticks), for simulated data."""
    import matplotlib.pyplot as plt

    p = len(post.scale.names)
    n_groups = len(post.groups)
    ncol = min(p, 4)
    nrow = -(-p // ncol)
    rows = 2 if n_groups > 1 else 1
    top_h = 2.0 + 0.3 * (len(post.specimens) + 1.5 * n_groups)
    heights = [top_h] * nrow + ([2.4] * nrow if rows == 2 else [])
    fig, grid = plt.subplots(len(heights), ncol, figsize=(4.2 * ncol, sum(heights)), squeeze=False,
                             height_ratios=heights)  # fmt: skip
    axes = np.empty((2, p), dtype=object)
    for j in range(p):
        axes[0, j] = grid[j // ncol, j % ncol]
        if rows == 2:
            axes[1, j] = grid[nrow + j // ncol, j % ncol]
    for k in range(p, nrow * ncol):  # unused cells of the last row
        for r in range(len(heights) // nrow):
            grid[r * nrow + k // ncol, k % ncol].set_axis_off()
    qs = [(1 - level) / 2, 0.5, (1 + level) / 2]
    z = post.flat("z")
    order = np.argsort(post.specimen_group, kind="stable")
    for j, name in enumerate(post.scale.names):
        ax = axes[0, j]
        y, ticks, labels = 0.0, [], []
        for g in range(n_groups):
            colour = _COLOURS[g % len(_COLOURS)]
            members = [i for i in order if post.specimen_group[i] == g]
            top = y
            for i in members:
                own = np.quantile(stage1[i][:, j], qs)
                shr = np.quantile(post.scale.to_theta(z[:, i, j : j + 1])[:, 0], qs)
                ax.plot(own[[0, 2]], [y + 0.15] * 2, color="0.6", lw=2)
                ax.plot(own[1], y + 0.15, "o", color="0.45", ms=4)
                ax.plot(shr[[0, 2]], [y - 0.15] * 2, color=colour, lw=2.5)
                ax.plot(shr[1], y - 0.15, "o", color=colour, ms=4)
                if truth is not None and name in truth:
                    ax.plot([truth[name][i]] * 2, [y - 0.4, y + 0.4], color="tab:green", ls="--", lw=1.2)
                ticks.append(y)
                labels.append(post.specimens[i])
                y += 1.0
            typ = np.quantile(post.scale.to_theta(post.group_mean(g))[:, j], qs)
            new = np.quantile(post.scale.to_theta(post.new_specimen(g, rng=g))[:, j], qs)
            ax.fill_betweenx([top - 0.5, y + 0.5], new[0], new[2], color=colour, alpha=0.12, lw=0)
            ax.plot(typ[[0, 2]], [y] * 2, color=colour, lw=4, solid_capstyle="butt")
            ax.plot(typ[1], y, "s", color=colour, ms=6, mec="k")
            ticks.append(y)
            labels.append(f"{post.groups[g]}: typical")
            y += 1.5
        if post.scale.log[j]:
            _log_ticks(ax)
        ax.set_yticks(ticks, labels, fontsize=FONT["tick"])
        ax.invert_yaxis()
        ax.set_xlabel(name, fontsize=FONT["label"])
        ax.set_title(f"{name}: own fit (grey), shrunken", fontsize=FONT["title"])
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    handles = [Line2D([], [], color="0.6", lw=2, label="own fit, 90 %"),
               Line2D([], [], color=_COLOURS[0], lw=2.5, label="shrunken, 90 %"),
               Line2D([], [], color=_COLOURS[0], lw=4, marker="s", mec="k", label="typical specimen, 90 %"),
               Patch(color=_COLOURS[0], alpha=0.12, label="new specimen, 90 %")]  # fmt: skip
    if truth is not None:
        handles += reference_handles(["generating"])
    fig.legend(handles=handles, fontsize=FONT["legend"] - 1, loc="lower center", ncol=len(handles), frameon=False)
    if rows == 2:
        d = post.flat("d")
        for j, name in enumerate(post.scale.names):
            ax = axes[1, j]
            for g in range(1, n_groups):
                x = d[:, g - 1, j]
                v = np.exp(x) if post.scale.log[j] else x
                lo, med, hi = np.quantile(v, qs)
                bins = np.exp(np.linspace(x.min(), x.max(), 50)) if post.scale.log[j] else 50
                ax.hist(v, bins=bins, density=True, histtype="step", color=_COLOURS[g % len(_COLOURS)], lw=1.5,
                        label=f"{post.groups[g]}/{post.groups[0]} {med:.3g} [{lo:.3g}, {hi:.3g}], "
                              f"P(>{'1' if post.scale.log[j] else '0'}) {np.mean(x > 0):.2f}")  # fmt: skip
                ax.axvspan(lo, hi, color=_COLOURS[g % len(_COLOURS)], alpha=0.1, lw=0)
            ax.axvline(1.0 if post.scale.log[j] else 0.0, color="k", lw=0.8)
            if post.scale.log[j]:
                _log_ticks(ax)
            ax.set_xlabel(f"{name}: {'ratio' if post.scale.log[j] else 'difference'} of typical specimens",
                          fontsize=FONT["label"])  # fmt: skip
            ax.set_yticks([])
            texts = [h.get_label() for h in ax.patches if not h.get_label().startswith("_")]
            ax.set_title("\n".join(texts), fontsize=FONT["legend"])
    tidy_axes(fig)
    fig.tight_layout(rect=(0, 0.06 if rows == 1 else 0.035, 1, 1))
    return fig
