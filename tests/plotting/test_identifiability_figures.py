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
        plot_rate_study([0.1, 1, 10], {"beta2": np.array([1.0, 2.0, np.inf])}, marks={"beta2": np.array([1, 0, -1])}),
    ]
    assert [len([ax for ax in f.axes if ax.get_visible()]) for f in figs] == [3, 1, 1, 1, 3, 1, 1]
    assert figs[0].axes[0].get_xlabel() == "a"  # the parameter (with its unit, when it has one)
    assert "100 %" in figs[5].axes[0].get_title()
    for f in figs:
        plt.close(f)
