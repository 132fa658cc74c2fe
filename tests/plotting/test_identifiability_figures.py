"""Smoke tests of the identifiability figures: each returns a Figure with the expected panels."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from bayestissue.identifiability.profile import ProfileResult  # noqa: E402
from bayestissue.plotting.identifiability import (  # noqa: E402
    plot_collinearity,
    plot_contraction,
    plot_cross_prediction,
    plot_marginals_overlay,
    plot_profiles,
    plot_rate_study,
    plot_singular_values,
)

NAMES = ("a", "b", "c")


def _profile(name):
    v = np.logspace(-1, 1, 9)
    return ProfileResult(
        name, 0, v, (np.log(v)) ** 2 * 4, np.ones((9, 3)), 1.0, 10.0, (0.4, 2.5), (False, False), "identifiable"
    )


def test_figures_are_built_and_labelled():
    figs = [
        plot_profiles({"T1": [_profile(n) for n in NAMES]}, NAMES),
        plot_singular_values({"T1": np.array([10.0, 1.0, 1e-9])}),
        plot_collinearity({"T1": [((0, 1), 3.0), ((0, 1, 2), np.inf)]}),
        plot_contraction({"T1": np.array([0.9, 0.1, -0.1])}, NAMES),
        plot_marginals_overlay({"T1": np.random.default_rng(0).uniform(size=(200, 3))}, NAMES),
        plot_cross_prediction(
            np.arange(5.0),
            np.arange(5.0),
            (np.arange(5.0) - 1, np.arange(5.0) + 1),
            np.arange(5.0),
            coverage=1.0,
            title="x",
        ),
        plot_rate_study(
            [0.1, 1, 10],
            {"gamma2": np.array([0.01, 0.1, np.inf]), "beta2": np.array([0.1, 1.0, np.inf])},
            {
                0.1: {
                    "gamma2": "identifiable",
                    "ci_gamma2": [0.85, 0.9],
                    "beta2": "identifiable",
                    "ci_beta2": [1e-4, 1e-3],
                },
                1.0: {
                    "gamma2": "practically non-identifiable",
                    "ci_gamma2": [0.8, None],  # None (JSON) or NaN: open
                    "beta2": "practically non-identifiable",
                    "ci_beta2": [float("nan"), 2e-3],
                },
            },
            {"gamma2": 0.88, "beta2": 4e-4},
            {"gamma2": (0.1, 0.95), "beta2": (1e-5, 2.5)},
            [  # further truths at T2's rate: one closed, one open below (None, as read from JSON)
                {"truth": {"beta2": 3e-4}, "ci": {"beta2": (2e-4, 5e-4)}, "classification": {"beta2": "identifiable"}},
                {
                    "truth": {"beta2": 1e-3},
                    "ci": {"beta2": (None, 4e-3)},
                    "classification": {"beta2": "practically non-identifiable"},
                },
            ],
        ),  # fmt: skip
    ]
    assert [len([ax for ax in f.axes if ax.get_visible()]) for f in figs] == [3, 1, 1, 1, 3, 1, 3]
    assert figs[6].axes[2].get_xlabel().startswith("truth: a draw of T1's posterior")
    assert figs[0].axes[0].get_xlabel() == "a"  # the parameter (with its unit, when it has one)
    assert "100 %" in figs[5].axes[0].get_title()
    # the rate figure: an open side runs to the box bound and ends in an arrow there
    g_ax, b_ax, d_ax = figs[6].axes
    # the truths panel, sorted by truth: the open draw (second) runs from the lower bound to its upper end, its truth
    # a dot on it
    assert any(list(ln.get_xdata()) == [1, 1] and list(ln.get_ydata()) == [1e-5, 4e-3] for ln in d_ax.lines)
    assert any(ln.get_marker() == "o" and list(ln.get_xdata()) == [1] and list(ln.get_ydata()) == [1e-3]
               for ln in d_ax.lines)  # fmt: skip
    assert g_ax.get_ylabel() == "gamma2 (1)" and b_ax.get_ylabel() == "beta2 (1/s)"
    bars = [ln for ln in b_ax.lines if len(ln.get_xdata()) == 2 and ln.get_xdata()[0] == 1.0]
    assert bars and bars[0].get_ydata()[0] == 1e-5 and bars[0].get_ydata()[1] == 2e-3
    assert any(ln.get_marker() == "v" and ln.get_ydata()[0] == 1e-5 for ln in b_ax.lines)
    assert any(ln.get_marker() == "^" and ln.get_ydata()[0] == 0.95 for ln in g_ax.lines)
    for f in figs:
        plt.close(f)
