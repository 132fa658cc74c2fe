"""Posterior-versus-prior measures against Gaussians with closed forms."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import norm

from bayestissue._validation import ValidationError
from bayestissue.identifiability.posterior import (
    batch_means,
    bhattacharyya,
    bound_flags,
    contraction,
    correlation_matrix,
    kl_divergence,
    principal_angles,
    uninformed,
    uninformed_mc,
)

N = 40_000


def _kl_normal(m1, s1, m0, s0):
    return np.log(s0 / s1) + (s1**2 + (m1 - m0) ** 2) / (2 * s0**2) - 0.5


def test_contraction_and_kl_match_closed_forms():
    rng = np.random.default_rng(1)
    m0, s0 = 0.0, 2.0
    post = np.column_stack([rng.normal(0.5, 0.5, N), rng.normal(-1.0, 1.0, N), rng.normal(0, 2.0, N)])
    prior = rng.normal(m0, s0, size=(4 * N, 3))
    c = contraction(post, prior)
    np.testing.assert_allclose(c, [1 - 0.25 / 4, 1 - 1 / 4, 0.0], atol=0.02)
    np.testing.assert_allclose(contraction(post, prior_var=[4.0] * 3), c, atol=0.02)
    exact = [_kl_normal(0.5, 0.5, m0, s0), _kl_normal(-1, 1, m0, s0), 0.0]
    kl_pdf = kl_divergence(post, prior_logpdf=lambda x: norm.logpdf(x, m0, s0))
    np.testing.assert_allclose(kl_pdf, exact, atol=0.02)
    kl_draws = kl_divergence(post, prior)
    np.testing.assert_allclose(kl_draws, exact, atol=0.03)
    assert list(uninformed(post, prior)) == [False, False, True]


def test_correlation_and_principal_angles():
    rng = np.random.default_rng(2)
    z = rng.normal(size=(N, 2))
    x = np.column_stack([z[:, 0], 0.6 * z[:, 0] + 0.8 * z[:, 1]])
    assert correlation_matrix(x)[0, 1] == pytest.approx(0.6, abs=0.02)
    e = np.eye(3)
    np.testing.assert_allclose(principal_angles(e[:, :1], e[:, :2]), [0.0], atol=1e-8)
    np.testing.assert_allclose(principal_angles(e[:, :1], e[:, 1:2]), [90.0], atol=1e-8)
    v = np.array([[1.0], [1.0], [0.0]]) / np.sqrt(2)
    np.testing.assert_allclose(principal_angles(e[:, :1], v), [45.0], atol=1e-8)


def test_bhattacharyya_matches_normal_closed_form():
    rng = np.random.default_rng(3)
    for (m1, s1), (m2, s2) in [((0, 1), (0, 1)), ((0, 1), (1.5, 0.7)), ((0, 0.1), (5, 0.1))]:
        a = rng.normal(m1, s1, (N, 1))
        b = rng.normal(m2, s2, (N, 1))
        v = s1**2 + s2**2
        exact = np.sqrt(2 * s1 * s2 / v) * np.exp(-((m1 - m2) ** 2) / (4 * v))
        assert bhattacharyya(a, b)[0] == pytest.approx(exact, abs=0.02)


def test_bound_flags():
    rng = np.random.default_rng(4)
    flat = rng.uniform(0, 1, N)
    piled = 1 - np.abs(rng.normal(0, 0.03, N))
    mid = rng.normal(0.5, 0.1, N)
    f = bound_flags(np.column_stack([flat, piled, mid]), 0.0, 1.0)
    assert list(f["at_upper"]) == [False, True, False]
    assert list(f["at_lower"]) == [False, False, False]
    assert f["share_upper"][1] == pytest.approx(2 * norm.cdf(0.02 / 0.03) - 1, abs=0.01)  # half-normal


def test_posterior_validation():
    with pytest.raises(ValidationError, match="post"):
        contraction(np.full((5, 2), np.nan), prior_var=[1, 1])
    with pytest.raises(ValidationError, match="prior"):
        contraction(np.ones((5, 2)))
    with pytest.raises(ValidationError, match="prior_var"):
        contraction(np.ones((5, 2)), prior_var=[1.0, 0.0])
    with pytest.raises(ValidationError, match="prior"):
        kl_divergence(np.ones((5, 2)))
    with pytest.raises(ValidationError, match="n_bins"):
        kl_divergence(np.ones((5, 2)), np.ones((5, 2)), n_bins=1)
    with pytest.raises(ValidationError, match="prior"):
        kl_divergence(np.ones((5, 2)), np.ones((5, 3)))
    with pytest.raises(ValidationError, match="upper"):
        bound_flags(np.ones((5, 1)), 1.0, 0.0)
    with pytest.raises(ValidationError, match="edge"):
        bound_flags(np.ones((5, 1)), 0.0, 1.0, edge=0.7)
    with pytest.raises(ValidationError, match="b"):
        bhattacharyya(np.ones((5, 1)), np.ones((5, 2)))
    with pytest.raises(ValidationError, match="A, B"):
        principal_angles(np.ones((3, 1)), np.ones((2, 1)))


def _ar1(rng, n, rho, k):
    """k independent AR(1) series of unit marginal variance, as an (n, k) array."""
    x = np.empty((n, k))
    x[0] = rng.normal(size=k)
    e = rng.normal(size=(n, k)) * np.sqrt(1 - rho**2)
    for i in range(1, n):
        x[i] = rho * x[i - 1] + e[i]
    return x


def test_batch_means_error_of_an_ar1_mean_and_the_kl_bias():
    rng = np.random.default_rng(5)
    n, rho = 20_000, 0.9
    x = _ar1(rng, n, rho, 4)
    r = batch_means(x, lambda d: d.mean(axis=0), n_batches=20)
    exact = np.sqrt((1 + rho) / (1 - rho) / n)  # sd of the mean of an AR(1) series
    assert np.median(r["se"]) == pytest.approx(exact, rel=0.3)
    # negative control: the iid formula underestimates it 4.4-fold
    assert np.median(r["se"]) > 3 * (1 / np.sqrt(n))
    # plug-in KL of uniform draws against the uniform prior: bias (n_bins - 1)/(2n) removed
    u = rng.uniform(size=(4000, 3))
    k = batch_means(u, lambda d: kl_divergence(d, prior_logpdf=lambda v: np.zeros_like(v), n_bins=30), n_batches=10)
    assert np.all(k["estimate"] > 0.5 * 29 / 8000)
    assert np.all(np.abs(k["corrected"]) < 3 * k["se"] + 1e-3)
    with pytest.raises(ValidationError, match="n_batches"):
        batch_means(u, np.mean, n_batches=1)


def test_uninformed_mc_passes_the_prior_and_fails_an_informed_marginal():
    rng = np.random.default_rng(6)
    n = 3000
    # walkers-like ordering: autocorrelated but stationary uniform draws via the AR(1) copula
    flat = norm.cdf(_ar1(rng, n, 0.5, 2))
    narrow = np.clip(0.5 + 0.15 * _ar1(rng, n, 0.5, 1), 0, 1)  # contraction 1 - 0.0225 * 12 = 0.73
    slight = norm.cdf(0.8 * _ar1(rng, n, 0.5, 1))  # contraction 0.235 (numerically), below the old 0.3
    u = np.column_stack([flat, narrow, slight])
    r = uninformed_mc(u, prior_var=[1 / 12] * 4, prior_logpdf=lambda v: np.zeros_like(v))
    assert r["t"] == pytest.approx(3.25, abs=0.01)
    assert list(r["uninformed"]) == [True, True, False, False]
    assert r["contraction"][2] == pytest.approx(0.73, abs=0.05)
    assert np.all(r["tol_contraction"][:2] < 0.15)  # the tolerance is the Monte Carlo error, not 0.3
    assert r["contraction"][3] == pytest.approx(0.235, abs=0.05)  # passed the old |c| < 0.3 rule
    with pytest.raises(ValidationError, match="level"):
        uninformed_mc(u, prior_var=[1 / 12] * 4, prior_logpdf=lambda v: np.zeros_like(v), level=1.0)
