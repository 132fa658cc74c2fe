"""The law comparison's measures: band share, relative error, Bayes factors with errors, the law swap."""

from pathlib import Path

import numpy as np
import pytest

from bayestissue.analyses.law_choice import (
    MATERIALS,
    OGDEN,
    bayes_factors,
    relative_rms,
    with_matrix,
)
from bayestissue.identifiability.compare import coverage
from bayestissue.mechanics import load_experiment
from bayestissue.mechanics.forward import ForwardModel

ROOT = Path(__file__).resolve().parents[2]


def test_band_share_counts_points_inside_the_pointwise_band():
    """The transfer's band share is identifiability.compare.coverage on the noisy predictive draws."""
    rng = np.random.default_rng(0)
    draws = rng.standard_normal((20000, 4))
    observed = np.array([0.0, 1.6, 1.7, -3.0])  # inside, inside (q95 = 1.645), outside, outside
    lo, hi = np.quantile(draws, [0.05, 0.95], axis=0)
    expected = np.mean((observed >= lo) & (observed <= hi))
    assert coverage(observed, draws) == pytest.approx(expected)
    assert coverage(observed, draws) == pytest.approx(0.5)
    assert coverage(np.zeros(4), draws, level=0.5) == 1.0


def test_relative_rms_is_over_the_curves_range():
    obs = np.array([0.0, 1.0, 2.0, 4.0])
    assert relative_rms(obs + 0.4, obs) == pytest.approx(0.1)
    assert relative_rms(obs, obs) == 0.0


def test_bayes_factors_of_the_best_law_with_errors_in_quadrature():
    best, f = bayes_factors({"a": -10.0, "b": -4.0, "c": -4.5}, {"a": 0.3, "b": 0.4, "c": 0.0})
    assert best == "b"
    assert f["b"] == (0.0, 0.0)
    assert f["a"] == pytest.approx((6.0, 0.5))
    assert f["c"] == pytest.approx((0.5, 0.4))


def test_with_matrix_swaps_only_the_law():
    """Ogden with one term at alpha = 2 is neo-Hookean: the same curve through the swapped experiment."""
    material = MATERIALS[0]
    exp = load_experiment(ROOT / "data" / "measured" / material.files[1])  # equibiaxial
    og = with_matrix(exp, OGDEN[0])
    nh = with_matrix(exp, material.laws[0])
    assert og.tissue.matrix.name == "ogden" and nh.tissue.matrix.name == "neo_hookean"
    assert og.tissue.bulk_kpa == exp.tissue.bulk_kpa and og.protocol is exp.protocol
    u_og = ForwardModel(og)(np.array([300.0, 2.0]))
    u_nh = ForwardModel(nh)(np.array([300.0]))
    np.testing.assert_allclose(u_og, u_nh, rtol=1e-9, atol=1e-9)
    assert np.ptp(u_og) > 100.0  # kPa: a real curve, not zeros
