"""Profile likelihood on models with known profiles: linear-Gaussian (exact parabola), a product
(flat),
and a saturating exponential (open on one side)."""

from __future__ import annotations

import numpy as np
import pytest

from bayestissue._validation import ValidationError
from bayestissue.identifiability.profile import (
    CHI2_1_95,
    ProfileOptions,
    classify_profile,
    fit_least_squares,
    profile_likelihood,
)

RNG = np.random.default_rng(42)
X = np.linspace(0, 1, 30)
A = np.stack([np.ones_like(X), X, X**2], axis=1)
SD = 0.1
Y_LIN = A @ np.array([1.0, 2.0, -1.0]) + SD * RNG.normal(size=X.size)


def _lin(theta):
    return (Y_LIN - np.atleast_2d(theta) @ A.T).reshape(np.shape(theta)[:-1] + (X.size,)) / SD


def test_linear_gaussian_profile_is_the_exact_parabola():
    lo, hi = [-10.0] * 3, [10.0] * 3
    th, c2 = fit_least_squares(_lin, np.zeros(3), lower=lo, upper=hi, log=False, batched=True)
    ols, *_ = np.linalg.lstsq(A / SD, Y_LIN / SD, rcond=None)
    np.testing.assert_allclose(th, ols, atol=1e-6)
    cov = np.linalg.inv(A.T @ A) * SD**2
    for i in range(3):
        pr = profile_likelihood(_lin, th, i, lower=lo, upper=hi, log=False, batched=True)
        exact = (pr.values - ols[i]) ** 2 / cov[i, i]
        assert np.all(np.abs(pr.delta_chi2 - exact) < 1e-5 * (1 + exact))
        half = np.sqrt(CHI2_1_95 * cov[i, i])
        assert pr.ci[0] == pytest.approx(ols[i] - half, rel=0.02, abs=0.02 * half)
        assert pr.ci[1] == pytest.approx(ols[i] + half, rel=0.02, abs=0.02 * half)
        assert pr.classification == "identifiable"
        assert pr.open_sides == (False, False)
        assert not pr.improved


T = np.linspace(0.1, 3, 25)
Y_PROD = 3.0 * np.exp(-0.8 * T)


def _prod(theta):
    """y = a*b*exp(-c t): only a*b is determined, a and b each structurally non-identifiable."""
    th = np.atleast_2d(theta)
    y = (th[:, 0] * th[:, 1])[:, None] * np.exp(-th[:, 2:3] * T)
    r = (Y_PROD - y) / 0.01
    return r if np.ndim(theta) == 2 else r[0]


def test_product_parameters_are_structurally_non_identifiable():
    lo, hi = [0.01, 0.001, 0.01], [100.0, 1e4, 10.0]  # b can compensate any a in its range
    th = np.array([1.5, 2.0, 0.8])
    pa = profile_likelihood(_prod, th, 0, lower=lo, upper=hi, batched=True)
    assert pa.classification == "structurally non-identifiable"
    assert np.all(np.isnan(pa.ci))
    assert pa.values[0] == pytest.approx(0.01) and pa.values[-1] == pytest.approx(100.0)
    np.testing.assert_allclose(pa.thetas[:, 0] * pa.thetas[:, 1], 3.0, rtol=1e-4)
    # negative control: with b confined to [0.01, 100], a < 0.03 cannot be compensated: closed below
    lo2 = [0.01, 0.01, 0.01]
    pa2 = profile_likelihood(_prod, th, 0, lower=lo2, upper=[100.0, 100.0, 10.0], batched=True)
    assert pa2.classification == "practically non-identifiable"
    assert pa2.open_sides == (False, True)
    pc = profile_likelihood(_prod, th, 2, lower=lo, upper=hi, batched=True)
    assert pc.classification == "identifiable"  # negative control: c is determined


T_SAT = np.linspace(2, 10, 20)
Y_SAT = 1.0 - np.exp(-5.0 * T_SAT) + 0.01 * np.random.default_rng(3).normal(size=T_SAT.size)


def _sat(theta):
    """y = c (1 - exp(-k t)) observed after saturation: k is bounded below but open above."""
    th = np.atleast_2d(theta)
    y = th[:, 0:1] * (1 - np.exp(-th[:, 1:2] * T_SAT))
    r = (Y_SAT - y) / 0.01
    return r if np.ndim(theta) == 2 else r[0]


def test_saturating_rate_is_practically_non_identifiable_open_above():
    lo, hi = [0.1, 0.01], [10.0, 1000.0]
    th, _ = fit_least_squares(_sat, [[1.0, 5.0], [1.0, 50.0]], lower=lo, upper=hi, batched=True)
    pk = profile_likelihood(_sat, th, 1, lower=lo, upper=hi, batched=True)
    assert pk.classification == "practically non-identifiable"
    assert pk.open_sides == (False, True)
    assert np.isfinite(pk.ci[0]) and np.isnan(pk.ci[1])
    # first point dominates: (exp(-2k)/0.01)^2 = 3.84 gives k = 1.97; the noise realisation shifts
    # it a bit
    assert 1.5 < pk.ci[0] < 3.0
    assert pk.values[-1] == pytest.approx(1000.0)  # explored up to the bound
    pc = profile_likelihood(_sat, th, 0, lower=lo, upper=hi, batched=True)
    assert pc.classification == "identifiable"


def test_classify_profile_cases():
    assert classify_profile([5.0], [4.0])[0] == "identifiable"
    assert classify_profile([5.0], [1.0]) == ("practically non-identifiable", (False, True))
    assert classify_profile([0.01], [0.02])[0] == "structurally non-identifiable"
    assert classify_profile([0.5], [0.2])[0] == "practically non-identifiable"


def test_nan_simulations_do_not_crash_the_profile():
    def res(theta):
        r = _lin(theta)
        return (
            np.where(np.atleast_2d(theta)[..., :1] > 1.5, np.nan, r)
            if np.ndim(theta) == 2
            else (np.full(X.size, np.nan) if theta[0] > 1.5 else r)
        )

    pr = profile_likelihood(res, [1.0, 2.0, -1.0], 1, lower=[-10] * 3, upper=[10] * 3, log=False, batched=True)
    assert np.all(np.isfinite(pr.delta_chi2))


def test_profile_validation():
    with pytest.raises(ValidationError, match="theta"):
        profile_likelihood(_lin, [20.0, 0, 0], 0, lower=[-10] * 3, upper=[10] * 3, log=False)
    with pytest.raises(ValidationError, match="index"):
        profile_likelihood(_lin, [0.0, 0, 0], 3, lower=[-10] * 3, upper=[10] * 3, log=False)
    with pytest.raises(ValidationError, match="lower"):
        profile_likelihood(_lin, [1.0, 1, 1], 0, lower=[-10] * 3, upper=[10] * 3, log=True)
    with pytest.raises(ValidationError, match="step0"):
        ProfileOptions(step0=5.0)
    with pytest.raises(ValidationError, match="max_steps"):
        ProfileOptions(max_steps=0)
    with pytest.raises(ValidationError, match="threshold"):
        ProfileOptions(threshold=-1)
