"""Scaled sensitivities, SVD and Brun et al. (2001) collinearity on models with known answers."""

from __future__ import annotations

import numpy as np
import pytest

from bayestissue._validation import ValidationError
from bayestissue.identifiability.sensitivity import (
    analyse_sensitivities,
    collinearity_index,
    collinearity_table,
    informed_directions,
    largest_identifiable_subsets,
    scaled_sensitivities,
)

T = np.linspace(0.0, 5.0, 50)


def _model(thetas):
    """y = a*b*exp(-c t) + d t: a and b enter only as their product (exactly collinear); e has no
    effect."""
    th = np.atleast_2d(thetas)
    a, b, c, d, _e = th.T
    y = (a * b)[:, None] * np.exp(-c[:, None] * T) + d[:, None] * T
    return y if np.ndim(thetas) == 2 else y[0]


THETA = np.array([2.0, 1.5, 0.7, 0.3, 4.0])
NAMES = ("a", "b", "c", "d", "e")


def test_sensitivities_match_analytic_derivatives():
    sd = 0.05
    S = scaled_sensitivities(_model, THETA, noise_sd=sd)
    a, b, c, d, _ = THETA
    ab = a * b * np.exp(-c * T)
    exact = np.stack([ab, ab, -c * T * ab, d * T, 0 * T], axis=1) / sd
    np.testing.assert_allclose(S, exact, rtol=1e-6, atol=1e-8)
    S2 = scaled_sensitivities(lambda t: _model(t), THETA, noise_sd=sd, batched=False)
    np.testing.assert_allclose(S2, S, rtol=1e-12)


def test_collinear_pair_is_flagged_and_excluded():
    S = scaled_sensitivities(_model, THETA, noise_sd=0.05)
    assert collinearity_index(S, [0, 1]) == np.inf  # a, b exactly collinear
    assert collinearity_index(S, [4]) == np.inf  # no sensitivity
    g_cd = collinearity_index(S, [2, 3])
    assert 1.0 <= g_cd < 10
    # gamma for two columns with normalised inner product rho is 1/sqrt(1 - |rho|)
    u, v = S[:, 2] / np.linalg.norm(S[:, 2]), S[:, 3] / np.linalg.norm(S[:, 3])
    assert g_cd == pytest.approx(1 / np.sqrt(1 - abs(u @ v)), rel=1e-10)
    table = dict(collinearity_table(S))
    assert len(table) == 2**5 - 1 - 5
    assert table[(0, 2, 3)] < 10 and table[(1, 2, 3)] < 10 and table[(0, 1, 2)] == np.inf
    best = largest_identifiable_subsets(list(table.items()), threshold=10)
    assert {s for s, _ in best} == {(0, 2, 3), (1, 2, 3)}


def test_analysis_svd_and_standard_errors():
    S = scaled_sensitivities(_model, THETA, noise_sd=0.05)
    res = analyse_sensitivities(S, THETA, NAMES)
    assert res.singular_values[-1] < 1e-6 * res.singular_values[0]  # two null directions
    assert res.singular_values[-2] < 1e-6 * res.singular_values[0]
    null = res.directions[-2:]
    # the null space is spanned by (1, -1, 0, 0, 0)/sqrt(2) and e_5
    P = null.T @ null
    for v in (np.array([1, -1, 0, 0, 0]) / np.sqrt(2), np.eye(5)[4]):
        np.testing.assert_allclose(P @ v, v, atol=1e-6)
    assert np.isinf(res.std_error_log[4])  # no sensitivity
    assert np.all(res.std_error_log[[0, 1]] > 1e3 / res.singular_values[0])  # exactly collinear pair
    assert np.all(np.isfinite(res.std_error_log[[2, 3]]))
    assert res.condition_number == np.inf or res.condition_number > 1e6
    assert {s for s, _ in res.largest_subsets} == {("a", "c", "d"), ("b", "c", "d")}
    assert res.gamma(("a", "b")) == np.inf
    assert informed_directions(S, threshold=1.0).shape == (5, 3)


def test_negative_control_independent_columns_are_identifiable():
    rng = np.random.default_rng(0)
    S = rng.normal(size=(200, 4))
    res = analyse_sensitivities(S, np.ones(4), ("w", "x", "y", "z"))
    assert res.largest_subsets[0][0] == ("w", "x", "y", "z")
    assert res.largest_subsets[0][1] < 1.5


def test_sensitivity_validation():
    with pytest.raises(ValidationError, match="theta"):
        scaled_sensitivities(_model, [1.0, -1, 1, 1, 1], noise_sd=1)
    with pytest.raises(ValidationError, match="noise_sd"):
        scaled_sensitivities(_model, THETA, noise_sd=0)
    with pytest.raises(ValidationError, match="predict output"):
        scaled_sensitivities(lambda t: np.full((len(t), 3), np.nan), THETA, noise_sd=1)
    with pytest.raises(ValidationError, match="predict output"):
        scaled_sensitivities(lambda t: np.ones(3), THETA, noise_sd=1)
    with pytest.raises(ValidationError, match="rel_step"):
        scaled_sensitivities(_model, THETA, noise_sd=1, rel_step=0)
    with pytest.raises(ValidationError, match="subset"):
        collinearity_index(np.ones((3, 2)), [])
    with pytest.raises(ValidationError, match="min_size"):
        collinearity_table(np.ones((3, 2)), min_size=3)
    with pytest.raises(ValidationError, match="S"):
        analyse_sensitivities(np.ones((3, 2)), [1, 1, 1], "abc")
    with pytest.raises(ValidationError, match="threshold"):
        largest_identifiable_subsets([], threshold=0)


def test_round_off_sized_column_counts_as_zero():
    rng = np.random.default_rng(1)
    S = rng.normal(size=(100, 3))
    S[:, 2] = 1e-13 * rng.normal(size=100)  # finite-difference noise of an insensitive parameter
    assert collinearity_index(S, [0, 2]) == np.inf
    assert dict(collinearity_table(S))[(0, 2)] == np.inf
    res = analyse_sensitivities(S, np.ones(3), ("x", "y", "z"))
    assert res.std_error_log[2] == np.inf
    assert res.largest_subsets[0][0] == ("x", "y")
