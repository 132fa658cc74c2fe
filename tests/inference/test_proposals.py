"""The Student-t mixture proposal (inference.proposals): density against scipy, draws against the
closed-form moments, HDF5 round trip, and the independence move's Hastings factor through emcee."""

import emcee
import numpy as np
import pytest
from scipy import stats

from bayestissue.inference.proposals import MixtureMove, TMixture, fit_t_mixture


def _mixture():
    rng = np.random.default_rng(0)
    a = rng.standard_normal((3, 3, 3))
    covs = np.einsum("kij,klj->kil", a, a) + 0.5 * np.eye(3)
    return TMixture(np.array([0.5, 0.3, 0.2]), rng.standard_normal((3, 3)) * 3, covs, df=5.0)


def test_logpdf_equals_scipy_multivariate_t_mixture():
    mix = _mixture()
    x = np.random.default_rng(1).standard_normal((50, 3)) * 4
    ref = np.log(
        sum(
            w * stats.multivariate_t(m, c, df=5.0).pdf(x)
            for w, m, c in zip(mix.weights, mix.means, mix.covs, strict=True)
        )
    )
    np.testing.assert_allclose(mix.logpdf(x), ref, rtol=1e-10)


def test_draws_have_the_closed_form_moments():
    """Mixture mean sum w m and covariance sum w (nu/(nu-2) S + m m^T) - mean mean^T; 200 000 draws
    give relative errors ~0.5 %, tolerance 3 %."""
    mix = _mixture()
    y = mix.sample(200_000, np.random.RandomState(2))
    mean = mix.weights @ mix.means
    cov = sum(
        w * (5.0 / 3.0 * c + np.outer(m, m)) for w, m, c in zip(mix.weights, mix.means, mix.covs, strict=True)
    ) - np.outer(mean, mean)
    sd = np.sqrt(np.diag(cov))
    np.testing.assert_allclose(y.mean(axis=0), mean, atol=0.02 * sd.max())
    np.testing.assert_allclose(np.cov(y.T), cov, atol=0.03 * np.outer(sd, sd).max())


def test_fit_recovers_two_clusters_and_round_trips_through_hdf5(tmp_path):
    rng = np.random.default_rng(3)
    x = np.vstack([rng.normal(-5, 1, (2000, 2)), rng.normal(5, 0.5, (1000, 2))])
    mix = fit_t_mixture(x, n_components=2, widen=1.0, seed=1)
    order = np.argsort(mix.means[:, 0])
    np.testing.assert_allclose(mix.weights[order], [2 / 3, 1 / 3], atol=0.02)
    np.testing.assert_allclose(mix.means[order], [[-5, -5], [5, 5]], atol=0.1)
    path = tmp_path / "m.h5"
    mix.to_hdf5(path, "p")
    back = TMixture.from_hdf5(path, "p")
    np.testing.assert_array_equal(back.covs, mix.covs)
    assert TMixture.from_hdf5(path, "absent") is None


def test_fit_errors():
    with pytest.raises(ValueError, match="mixture draws: expected finite values of shape"):
        fit_t_mixture(np.array([[0.0, np.nan]] * 100))
    with pytest.raises(ValueError, match="mixture draws: expected at least 8"):
        fit_t_mixture(np.zeros((5, 3)))
    with pytest.raises(ValueError, match="t mixture"):
        TMixture(np.array([0.5, 0.6]), np.zeros((2, 2)), np.stack([np.eye(2)] * 2), df=5.0)


def _run(move, seed=4, n=6000):
    """Independence moves alone on a 2-D standard normal from a deliberately shifted, wide proposal."""
    sampler = emcee.EnsembleSampler(16, 2, lambda x: -0.5 * np.sum(x * x, axis=1), vectorize=True, moves=move)
    sampler.random_state = np.random.RandomState(seed).get_state()
    sampler.run_mcmc(np.random.default_rng(seed).standard_normal((16, 2)), n, progress=False)
    return sampler.get_chain(discard=200, flat=True)


def test_independence_move_targets_the_posterior_and_needs_the_hastings_factor(monkeypatch):
    q = TMixture(np.array([1.0]), np.array([[1.0, -0.5]]), np.array([np.eye(2) * 2.0]), df=5.0)
    x = _run(MixtureMove(q))
    # ~94 000 draws, tau of a few steps: MC error of the mean ~0.01, of the variance ~0.015
    np.testing.assert_allclose(x.mean(axis=0), [0, 0], atol=0.05)
    np.testing.assert_allclose(x.var(axis=0), [1, 1], atol=0.06)
    # negative control: without log q(x) - log q(y) the chain targets p q (mean pulled to 1/3 of q's)
    monkeypatch.setattr(MixtureMove, "_propose", lambda self, c, r: (self.mixture.sample(c.shape[0], r), 0.0))
    bad = _run(MixtureMove(q))
    assert np.abs(bad.mean(axis=0) - [0, 0]).max() > 0.2
