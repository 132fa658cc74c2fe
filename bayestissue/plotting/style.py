"""One look for the figures: font sizes, and how reference parameter values are marked.

Every figure that marks reference values draws them the same way, so that a reader learns the legend once:
least squares a solid blue line, the paper's values a dotted red line, the generating values of a synthetic
replica a dashed green line. Where the paper's and the generating values coincide (the replicas are generated
from the paper's Table 1) the dotted red line is drawn over the dashed green one and both stay visible.
"""

from __future__ import annotations

__all__ = ["FONT", "REFERENCES", "reference_handles", "reference_style", "tidy_axes"]

#: Font sizes (points) of axis labels, tick labels, titles and legends.
FONT = {"label": 10, "tick": 8, "title": 11, "legend": 9}

#: label -> line style of a reference value (matplotlib keywords); the order is the drawing order (later on top).
REFERENCES = {
    "least squares": {"color": "tab:blue", "ls": "-", "lw": 1.4, "zorder": 3},
    "generating": {"color": "tab:green", "ls": "--", "lw": 1.6, "zorder": 4},
    "paper": {"color": "tab:red", "ls": ":", "lw": 2.0, "zorder": 5},
}


def reference_style(label: str) -> dict:
    """Line keywords of the reference ``label`` (black dash-dot for a label not in :data:`REFERENCES`)."""
    return dict(REFERENCES.get(label, {"color": "k", "ls": "-.", "lw": 1.2, "zorder": 3}))


def reference_handles(labels) -> list:
    """Legend handles of the references ``labels``, in :data:`REFERENCES` order."""
    from matplotlib.lines import Line2D

    order = [k for k in REFERENCES if k in labels] + [k for k in labels if k not in REFERENCES]
    return [Line2D([], [], label=k, **{a: v for a, v in reference_style(k).items() if a != "zorder"}) for k in order]


def tidy_axes(fig) -> None:
    """Tick labels of every axes at :data:`FONT` ``tick`` size."""
    for ax in fig.axes:
        ax.tick_params(labelsize=FONT["tick"])
