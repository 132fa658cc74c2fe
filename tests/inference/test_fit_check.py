"""The posterior predictive check (bayestissue/inference/fit_check.py): noise ratio, residual autocorrelation, band."""

import arviz as az
import numpy as np
import pytest

from bayestissue.inference.fit_check import data_noise_sd, fit_check, fit_check_text, lag1_autocorrelation

T = np.linspace(0.0, 1200.0, 401)
CURVE = 1.0 - 0.6 * np.exp(-T / 300.0)  # a creep-like curve (mm)


def test_difference_estimate_recovers_the_noise_sd():
    """Unbiased, and over 20 seeds within 20 % of the true sd: its relative sd at n = 401 is 6.6 % (measured over
    200 seeds: mean ratio 1.0005, range 0.83-1.19), so 20 % is 3 sd."""
    for seed in range(20):
        y = CURVE + 0.02 * np.random.default_rng(seed).normal(size=T.size)
        assert data_noise_sd(y) == pytest.approx(0.02, rel=0.2)


def test_lag1_autocorrelation():
    r = np.random.default_rng(0).normal(size=401)
    assert abs(lag1_autocorrelation(r)) < 4 / np.sqrt(401)
    assert lag1_autocorrelation(np.sin(T / 100.0)) > 0.95
    assert np.isnan(lag1_autocorrelation(np.zeros(5)))


def _idata(model, sigma, y, rng):
    """A results file in the layout of to_inference_data: 2 chains x 50 draws."""
    model = np.broadcast_to(model, (2, 50, y.size))
    sig = np.full((2, 50), sigma)
    noisy = model + sig[..., None] * rng.normal(size=model.shape)
    return az.from_dict(
        posterior={"mu": rng.normal(size=(2, 50)), "sigma_T1": sig},
        posterior_predictive={"T1": noisy, "T1_model": np.array(model)},
        observed_data={"T1": y},
    )


def test_a_fitting_posterior_passes_and_an_inflated_one_is_a_misfit():
    rng = np.random.default_rng(1)
    y = CURVE + 0.02 * rng.normal(size=T.size)
    good = fit_check(_idata(CURVE, 0.02, y, rng))["T1"]
    assert not good["misfit"] and good["noise_ratio"] == pytest.approx(1.0, abs=0.15)
    assert 0.85 < good["coverage"] < 0.95
    assert fit_check_text({"T1": good}).startswith("FITS")
    # a model that misses the curve's shape by +-0.3 mm, its noise sd inflated to cover it: the band still covers
    # the data (coverage alone would pass it), the noise ratio and the residual runs do not
    wrong = CURVE + 0.3 * np.cos(T / 200.0)
    bad = fit_check(_idata(wrong, 0.25, y, rng))["T1"]
    assert bad["coverage"] > 0.85
    assert bad["misfit"] and bad["noise_ratio"] > 10 and bad["lag1"] > 0.9
    text = fit_check_text({"T1": bad})
    assert text.startswith("MISFIT: T1 noise sd") and "autocorrelation" in text


def test_a_file_without_predictive_is_not_checked():
    idata = az.from_dict(posterior={"mu": np.zeros((2, 5))})
    assert fit_check(idata) == {}
    assert fit_check_text({}).startswith("NOT CHECKED")
