"""Figure of the T1-vs-T2 controls: the tension per planted cause and the verdicts against what was planted."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np

from bayestissue.plotting.style import FONT, tidy_axes

__all__ = ["plot_controls"]


def plot_controls(tensions: dict, table: dict, *, q_threshold: float, label):
    """(a) the tension Q of every pair (``tensions``: scenario -> Q per noise seed; log scale, one dot per seed)
    against the difference threshold;
    (b) the verdicts per scenario (rows: the scenarios of (a); columns: verdict; cell: number of seeds), each row
    with the number of seeds whose verdict contains the planted causes (or, for the negative control, no
    difference). ``label(key)`` turns a verdict key of ``table`` into the column's text."""
    names = list(table)
    fig, (a, b) = plt.subplots(1, 2, figsize=(13, 0.55 * len(names) + 2.6), width_ratios=[1, 1.35])
    for i, name in enumerate(names):
        q = [max(x, 0.1) for x in tensions.get(name, ())]
        a.plot(q, np.full(len(q), i) + np.linspace(-0.12, 0.12, len(q)), "o", color="k", ms=5, alpha=0.7)
    a.axvline(q_threshold, color="tab:red", ls="--", lw=1.3)
    a.text(q_threshold * 1.15, len(names) - 0.6, f"difference if Q > {q_threshold:.1f} (p < 0.001)", color="tab:red",
           fontsize=FONT["tick"], va="bottom")  # fmt: skip
    a.set_xscale("log")
    a.set_yticks(range(len(names)), names)
    a.set_ylim(len(names) - 0.5, -0.7)
    a.set_xlabel("tension Q = chi2 joint - chi2 T1 - chi2 T2 (log scale)", fontsize=FONT["label"])
    a.set_title("(a) tension of each pair (dot: one noise seed)", fontsize=FONT["title"], loc="left")
    cols = ["none"]  # then in order of first appearance down the scenarios: planted causes on the diagonal
    for row in table.values():
        cols += [k for k in row["verdicts"] if k not in cols]
    cols = [c for c in cols if any(c in row["verdicts"] for row in table.values())]
    counts = np.array([[table[n]["verdicts"].get(c, 0) for c in cols] for n in names])
    b.imshow(counts, cmap="Blues", vmin=0, vmax=max(1, counts.max()), aspect="auto")
    for i in range(len(names)):
        for j in range(len(cols)):
            if counts[i, j]:
                dark = counts[i, j] > 0.6 * counts.max()
                b.text(j, i, str(counts[i, j]), ha="center", va="center", fontsize=FONT["label"],
                       color="w" if dark else "k")  # fmt: skip
    b.set_xticks(range(len(cols)), [label(c) for c in cols], rotation=30, ha="right")
    b.set_yticks(range(len(names)), [f"{table[n]['named']}/{table[n]['n']} as planted" for n in names])
    b.set_title("(b) verdict of the fixed rules (cell: noise seeds; rows as in (a))", fontsize=FONT["title"],
                loc="left")  # fmt: skip
    tidy_axes(fig)
    fig.tight_layout()
    return fig
