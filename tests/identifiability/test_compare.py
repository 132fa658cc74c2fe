"""Tension, coverage and leave-one-experiment-out on linear-Gaussian experiments with known
answers."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import chi2

from bayestissue._validation import ValidationError
from bayestissue.identifiability.compare import (
    coverage,
    gaussian_loglik,
    log_predictive_density,
    predictive_band,
    psis_leave_out,
    tension,
)


def _chi2_min(A, y):
    x, *_ = np.linalg.lstsq(A, y, rcond=None)
    r = y - A @ x
    return float(r @ r)


def _two_experiments(rng, shift):
    """Two unit-noise linear experiments sharing 2 parameters; B's truth is shifted by ``shift``."""
    A = rng.normal(size=(40, 2))
    B = rng.normal(size=(30, 2))
    th = np.array([1.0, -0.5])
    ya = A @ th + rng.normal(size=40)
    yb = B @ (th + shift) + rng.normal(size=30)
    return A, ya, B, yb


def test_tension_is_chi2_distributed_without_shift_and_large_with():
    rng = np.random.default_rng(5)
    qs = []
    for _ in range(400):
        A, ya, B, yb = _two_experiments(rng, 0.0)
        qj = _chi2_min(np.vstack([A, B]), np.concatenate([ya, yb]))
        qs.append(tension(qj, [_chi2_min(A, ya), _chi2_min(B, yb)], 2)["Q"])
    qs = np.array(qs)
    assert np.mean(qs) == pytest.approx(2.0, abs=0.3)  # chi2(2) has mean 2
    assert np.mean(chi2.sf(qs, 2) < 0.05) == pytest.approx(0.05, abs=0.03)
    A, ya, B, yb = _two_experiments(rng, np.array([2.0, 2.0]))  # negative control: E[Q] ~ 8/(1/40+1/30)
    qj = _chi2_min(np.vstack([A, B]), np.concatenate([ya, yb]))
    t = tension(qj, [_chi2_min(A, ya), _chi2_min(B, yb)], 2)
    assert t["p_value"] < 1e-4 and t["sigma"] > 3.5


def test_coverage_of_a_correct_and_a_wrong_predictive():
    rng = np.random.default_rng(6)
    mean = np.linspace(0, 1, 500)
    y = mean + 0.1 * rng.normal(size=500)
    pred = np.tile(mean, (2000, 1))
    assert coverage(y, pred, noise_sd=0.1, rng=1) == pytest.approx(0.9, abs=0.04)
    assert coverage(y, pred + 0.5, noise_sd=0.1, rng=1) < 0.05
    lo, hi = predictive_band(pred + 0.1 * rng.normal(size=pred.shape), level=0.9)
    np.testing.assert_allclose(hi - lo, 2 * 1.645 * 0.1, rtol=0.1)


def test_leave_out_elpd_exact_and_psis():
    rng = np.random.default_rng(7)
    # conjugate normal mean: prior N(0, 10^2), unit noise; blocks A (20 points) and B (5 points)
    ya = 1.0 + rng.normal(size=20)
    yb = 1.0 + rng.normal(size=5)

    def post(y):
        prec = 1 / 100 + y.size
        return y.sum() / prec, 1 / np.sqrt(prec)

    m_a, s_a = post(ya)
    m_j, s_j = post(np.concatenate([ya, yb]))
    th_a = rng.normal(m_a, s_a, 20_000)
    th_j = rng.normal(m_j, s_j, 20_000)
    ll_a = gaussian_loglik(yb, th_a[:, None] * np.ones(5), 1.0)
    exact = log_predictive_density(ll_a)
    # closed form: y_B ~ N(m_a 1, I + s_a^2 11^T)
    cov = np.eye(5) + s_a**2
    d = yb - m_a
    closed = -0.5 * (d @ np.linalg.solve(cov, d) + np.linalg.slogdet(cov)[1] + 5 * np.log(2 * np.pi))
    assert exact == pytest.approx(closed, abs=0.02)
    ps = psis_leave_out(gaussian_loglik(yb, th_j[:, None] * np.ones(5), 1.0))
    assert ps["khat"] < 0.7
    assert ps["elpd"] == pytest.approx(closed, abs=0.05)


def test_compare_validation():
    with pytest.raises(ValidationError, match="n_shared"):
        tension(10.0, [1.0, 2.0], 0)
    with pytest.raises(ValidationError, match="chi2"):
        tension(np.nan, [1.0], 1)
    with pytest.raises(ValidationError, match="level"):
        predictive_band(np.ones((5, 3)), level=1.0)
    with pytest.raises(ValidationError, match="pred"):
        predictive_band(np.ones(5))
    with pytest.raises(ValidationError, match="pred"):
        coverage(np.ones(3), np.ones((5, 4)))
    with pytest.raises(ValidationError, match="noise_sd"):
        gaussian_loglik(np.ones(3), np.ones((2, 3)), 0.0)
    with pytest.raises(ValidationError, match="loglik"):
        log_predictive_density([])
    with pytest.raises(ValidationError, match="loglik_left_out"):
        psis_leave_out(np.ones(3))
    with pytest.raises(ValidationError, match="r_eff"):
        psis_leave_out(np.ones(30), r_eff=0)
