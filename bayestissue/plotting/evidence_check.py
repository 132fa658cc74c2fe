"""The figure of the evidence check (:mod:`bayestissue.analyses.evidence_check`): per data set, each model's nested
runs of the model-choice record with their own errors, beside its evidence by importance sampling and the nautilus
run whose draws the proposal was fitted to."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np

from bayestissue.plotting.evidence import MODEL_COLOURS
from bayestissue.plotting.style import FONT, tidy_axes

__all__ = ["plot_evidence_check"]


def _panel(ax, case, nested) -> None:
    for i, (model, c) in enumerate(case.checks.items()):
        colour = MODEL_COLOURS.get(model, "0.4")
        e = nested.models.get(model) if nested is not None else None
        if e is not None:
            x = i - 0.15 + np.linspace(-0.08, 0.08, len(e.log_z))
            ax.errorbar(x, e.log_z, yerr=e.log_z_err, fmt="o", ms=4, color=colour, capsize=2,
                        label="nested runs (own errors)" if i == 0 else None)  # fmt: skip
        ax.plot(i + 0.05, c.proposal_log_z, "v", mfc="none", color=colour, ms=7,
                label="nautilus run (the proposal's draws)" if i == 0 else None)  # fmt: skip
        ax.errorbar(i + 0.2, c.log_z, yerr=max(c.log_z_err, 1e-9), fmt="D", color="k", mfc=colour, ms=7, capsize=4,
                    label="importance sampling (+- its error)" if i == 0 else None)  # fmt: skip
        mark = "" if c.trusted else " NOT TRUSTED"
        ax.annotate(f"{c.log_z:.2f} +- {c.log_z_err:.2f}\nk-hat {c.k_hat:.2f}{mark}", (i + 0.28, c.log_z),
                    fontsize=FONT["legend"] - 1, va="center")  # fmt: skip
    ax.set_xticks(range(len(case.checks)), list(case.checks))
    ax.set_xlim(-0.5, len(case.checks) + 0.2)  # room for the last label
    title = [f"{case.data}"] + [f"ln B {f['a']} over {f['b']} = {f['log_b']:.2f} +- {f['err']:.2f}"
                                + ("" if f["trusted"] else " (not both trusted)")
                                for f in (case.factor(a, b) for a, b in case.factors_run)]  # fmt: skip
    ax.set_title("\n".join(title), fontsize=FONT["title"])
    ax.set_ylabel("log evidence", fontsize=FONT["label"])
    ax.margins(y=0.1)


def plot_evidence_check(rec, nested, path) -> None:
    """One panel per data set of ``rec`` (:class:`~bayestissue.analyses.evidence_check.EvidenceCheckRecord`), with
    the runs of ``nested`` (:class:`~bayestissue.analyses.model_choice.ModelChoiceRecord`, or None) where it has
    the model; saved to ``path``."""
    cases = rec.ordered()
    fig, axes = plt.subplots(1, len(cases), figsize=(max(5.2 * len(cases), 8.0), 4.8), squeeze=False)
    for ax, case in zip(axes[0], cases, strict=True):
        _panel(ax, case, nested.cases.get(case.data) if nested is not None else None)
    axes[0][0].legend(fontsize=FONT["legend"] - 1, loc="upper center", bbox_to_anchor=(0.5, -0.1), ncol=1)
    tidy_axes(fig)
    fig.suptitle("The evidence two ways: nested runs against importance sampling", fontsize=FONT["title"] + 1)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
