"""Orientation tensor, Watson distribution and Watson mixtures: normalisation, MLE and EM recovery."""

import numpy as np
import pytest
from scipy import stats
from scipy.special import hyp1f1

from bayestissue._validation import ValidationError
from bayestissue.paper import PAPER_DIRECTIONS
from bayestissue.stereology.axial import (
    WatsonMixture,
    axial_angle,
    fit_watson,
    fit_watson_mixture,
    goh_dispersion,
    orientation_tensor,
    principal_axes,
    sample_watson,
    watson_log_normaliser,
    watson_mean_t2,
    watson_pdf,
)
from bayestissue.stereology.uncertainty import align_axes


def _sphere_grid(n_theta=400, n_phi=800):
    """Midpoint quadrature nodes and weights on the unit sphere."""
    th = (np.arange(n_theta) + 0.5) * np.pi / n_theta
    ph = (np.arange(n_phi) + 0.5) * 2 * np.pi / n_phi
    T, F = np.meshgrid(th, ph, indexing="ij")
    x = np.stack([np.sin(T) * np.cos(F), np.sin(T) * np.sin(F), np.cos(T)], axis=-1).reshape(-1, 3)
    w = (np.sin(T) * (np.pi / n_theta) * (2 * np.pi / n_phi)).ravel()
    return x, w


def test_watson_pdf_integrates_to_one():
    x, w = _sphere_grid()
    mu = np.array([0.3, -0.5, 0.8])
    for kappa in (-5.0, 0.0, 1e-5, 1.0, 10.0, 80.0):
        assert np.sum(watson_pdf(x, mu, kappa) * w) == pytest.approx(1.0, abs=2e-4)


def test_normaliser_matches_kummer_function():
    for kappa in (-20.0, -1.0, 1e-4, 0.5, 5.0, 50.0, 300.0):
        expected = np.log(4 * np.pi * hyp1f1(0.5, 1.5, kappa))
        assert watson_log_normaliser(kappa) == pytest.approx(expected, rel=1e-10)
    assert np.isfinite(watson_log_normaliser(5000.0))  # hyp1f1 overflows there


def test_mean_t2_is_derivative_of_log_normaliser():
    for kappa in (-10.0, -0.5, 2e-4, 0.7, 12.0, 200.0):
        h = 1e-5 * max(1.0, abs(kappa))
        fd = (watson_log_normaliser(kappa + h) - watson_log_normaliser(kappa - h)) / (2 * h)
        assert watson_mean_t2(kappa) == pytest.approx(fd, rel=1e-5)


def test_sampler_matches_density_and_mle_recovers_kappa():
    mu = np.array([1.0, 1.0, 0.0]) / np.sqrt(2)
    for kappa in (2.0, 10.0, 60.0):
        x = sample_watson(6000, mu, kappa, rng=int(kappa))
        assert np.allclose(np.linalg.norm(x, axis=1), 1.0)
        t = np.abs(x @ mu)
        # CDF of |t| on [0, 1]: F(s) = int_0^s e^{k u^2} du / int_0^1 e^{k u^2} du (numerical)
        grid = np.linspace(0, 1, 20001)
        dens = np.exp(kappa * (grid**2 - 1))
        cdf = np.concatenate([[0], np.cumsum(0.5 * (dens[1:] + dens[:-1]) * np.diff(grid))])
        cdf /= cdf[-1]
        assert stats.kstest(t, lambda s, g=grid, c=cdf: np.interp(s, g, c)).pvalue > 1e-3
        mu_hat, k_hat = fit_watson(x)
        assert axial_angle(mu_hat, mu) < 3.0
        assert k_hat == pytest.approx(kappa, rel=0.08)


def test_orientation_tensor_and_goh():
    d = np.array([[1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0]])
    T = orientation_tensor(d, weights=[2.0, 1.0, 1.0])
    np.testing.assert_allclose(T, np.diag([0.5, 0.25, 0.25]))
    lam, vec = principal_axes(T)
    assert lam[0] == pytest.approx(0.5) and abs(vec[0, 0]) == pytest.approx(1.0)
    assert goh_dispersion(orientation_tensor(d)) == pytest.approx(1 / 3)
    assert goh_dispersion(orientation_tensor([[0, 0, 1.0], [0, 0, -2.0]])) == pytest.approx(0.0)


def test_mixture_pdf_integrates_to_one_and_samples():
    x, w = _sphere_grid(300, 600)
    mix = WatsonMixture(PAPER_DIRECTIONS, [20.0, 25.0, 25.0], [0.45, 0.275, 0.275])
    assert np.sum(mix.pdf(x) * w) == pytest.approx(1.0, abs=5e-4)
    s, lab = mix.sample(4000, rng=1)
    assert np.bincount(lab, minlength=3) / 4000 == pytest.approx([0.45, 0.275, 0.275], abs=0.03)
    r = mix.responsibilities(s)
    assert np.allclose(r.sum(axis=1), 1.0)


def test_em_recovers_known_mixture():
    mix = WatsonMixture(PAPER_DIRECTIONS, [20.0, 25.0, 25.0], [0.45, 0.275, 0.275])
    x, _ = mix.sample(1500, rng=2)
    fit = fit_watson_mixture(x, 3, n_init=3, rng=3)
    aligned, order = align_axes(fit.axes, PAPER_DIRECTIONS)
    assert np.all(axial_angle(aligned, PAPER_DIRECTIONS) < 3.0)
    assert fit.weights[np.argsort(order)] == pytest.approx([0.45, 0.275, 0.275], abs=0.05)
    assert fit.kappas[order] == pytest.approx([20.0, 25.0, 25.0], rel=0.25)
    # length weights: doubling the weight of family-1 axes doubles its share (approximately)
    lab = np.argmax(mix.responsibilities(x), axis=1)
    w = np.where(lab == 0, 2.0, 1.0)
    fit_w = fit_watson_mixture(x, 3, weights=w, init_axes=fit.axes, n_init=0, rng=4)
    _, o2 = align_axes(fit_w.axes, PAPER_DIRECTIONS)
    assert fit_w.weights[o2[0]] == pytest.approx(0.9 / 1.45, abs=0.05)


def test_uniform_background_integrates_samples_and_is_recovered():
    """A mixture with half its axes uniform (as traced pieces of packed cells, docs/verification.md): density
    integrates to 1 (quadrature, 5e-4), the sampler draws the background's share, and EM with ``background=True``
    recovers axes (3 degrees, as the plain test above) and the background weight (0.05, about 4 binomial sds at
    n = 2000)."""
    x, w = _sphere_grid(300, 600)
    mix = WatsonMixture(PAPER_DIRECTIONS, [20.0, 25.0, 25.0], [0.25, 0.15, 0.15], background=0.45)
    assert np.sum(mix.pdf(x) * w) == pytest.approx(1.0, abs=5e-4)
    s, lab = mix.sample(2000, rng=5)
    assert np.mean(lab == 3) == pytest.approx(0.45, abs=0.05)
    assert np.all(mix.responsibilities(s).sum(axis=1) <= 1.0 + 1e-12)  # the background takes the rest
    fit = fit_watson_mixture(s, 3, background=True, rng=6)
    aligned, _ = align_axes(fit.axes, PAPER_DIRECTIONS)
    assert np.all(axial_angle(aligned, PAPER_DIRECTIONS) < 3.0)
    assert fit.background == pytest.approx(0.45, abs=0.05)
    assert fit.weights.sum() + fit.background == pytest.approx(1.0, abs=1e-9)
    # no background in the data: its weight goes to about 0 and the axes are the plain fit's
    clean, _ = WatsonMixture(PAPER_DIRECTIONS, [20.0, 25.0, 25.0], [0.45, 0.275, 0.275]).sample(2000, rng=7)
    plain, robust = fit_watson_mixture(clean, 3, rng=8), fit_watson_mixture(clean, 3, background=True, rng=8)
    assert robust.background < 0.02
    assert np.all(axial_angle(align_axes(robust.axes, plain.axes)[0], plain.axes) < 0.5)
    with pytest.raises(ValidationError, match="weights: expected 3 weights >= 0 summing to 1 - background"):
        WatsonMixture(PAPER_DIRECTIONS, [20.0, 25.0, 25.0], [0.45, 0.275, 0.275], background=0.2)


def test_axial_errors():
    with pytest.raises(ValidationError, match="non-zero finite directions"):
        orientation_tensor([[0, 0, 0], [1, 0, 0]])
    with pytest.raises(ValidationError, match="an \\(n, 3\\) array"):
        orientation_tensor([1, 0, 0])
    with pytest.raises(ValidationError, match="weights >= 0"):
        orientation_tensor([[1, 0, 0], [0, 1, 0]], weights=[1.0, -1.0])
    with pytest.raises(ValidationError, match="kappa"):
        sample_watson(10, [0, 0, 1], -1.0)
    with pytest.raises(ValidationError, match="mu"):
        watson_pdf(np.eye(3), [0, 0, 0], 1.0)
    with pytest.raises(ValidationError, match="weights >= 0 summing to 1"):
        WatsonMixture(np.eye(3), [1, 1, 1], [0.5, 0.5, 0.5])
    with pytest.raises(ValidationError, match="concentrations >= 0"):
        WatsonMixture(np.eye(3), [1, -1, 1], [0.2, 0.3, 0.5])
    with pytest.raises(ValidationError, match="n_components"):
        fit_watson_mixture(np.eye(3), 5)
    with pytest.raises(ValidationError, match="n_init"):
        fit_watson_mixture(np.eye(3), 2, n_init=0)
