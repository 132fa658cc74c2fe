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
    fit_residuals,
    profile_likelihood,
)
from bayestissue.identifiability.restarts import profile_all

RNG = np.random.default_rng(42)
X = np.linspace(0, 1, 30)
A = np.stack([np.ones_like(X), X, X**2], axis=1)
SD = 0.1
Y_LIN = A @ np.array([1.0, 2.0, -1.0]) + SD * RNG.normal(size=X.size)


def _lin(theta):
    return (Y_LIN - np.atleast_2d(theta) @ A.T).reshape(np.shape(theta)[:-1] + (X.size,)) / SD


def test_linear_gaussian_profile_is_the_exact_parabola():
    lo, hi = [-10.0] * 3, [10.0] * 3
    th, c2 = fit_residuals(_lin, np.zeros(3), lower=lo, upper=hi, log=False, batched=True)
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
    th, _ = fit_residuals(_sat, [[1.0, 5.0], [1.0, 50.0]], lower=lo, upper=hi, batched=True)
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


def _two_wells(theta):
    """Two minima in a: chi2 = 1.44 (a^2 - 1)^2 + 0.25 (a - 1)^2 + ((b - a)/0.1)^2, global at a = b = 1
    (chi2 = 0), local at a = b = -0.904 (chi2 = 0.954); the barrier at a = 0 is 0.736 above the local
    minimum, below the 3.84 threshold, so a profile started in the worse well walks into the
    better one."""
    th = np.atleast_2d(theta)
    a, b = th[:, 0], th[:, 1]
    r = np.stack([1.2 * (a**2 - 1), 0.5 * (a - 1), (b - a) / 0.1], axis=1)
    return r if np.ndim(theta) == 2 else r[0]


def test_profile_all_restarts_from_a_better_optimum_found_by_a_profile():
    lo, hi = [-3.0, -3.0], [3.0, 3.0]
    kw = dict(lower=lo, upper=hi, log=False, batched=True)
    th_local, c2_local = fit_residuals(_two_wells, [-1.0, -1.0], **kw)
    assert th_local[0] < 0 and c2_local == pytest.approx(0.9544, abs=1e-4)  # stuck in the worse well
    # the defect: a single profile from the local optimum dips 0.954 below 0
    old = profile_likelihood(_two_wells, th_local, 0, **kw)
    assert old.improved and old.delta_chi2.min() < -0.9
    ps = profile_all(_two_wells, th_local, **kw)
    assert ps.chi2_start == pytest.approx(c2_local, abs=1e-6)
    assert ps.n_restarts == 1 and ps.converged
    assert ps.improvements[0] == pytest.approx(c2_local, abs=1e-6)
    np.testing.assert_allclose(ps.theta_hat, [1.0, 1.0], atol=1e-5)
    assert ps.chi2_min == pytest.approx(0.0, abs=1e-8)
    for p in ps.profiles:
        assert p.delta_chi2.min() >= -ps.improvement_tol
        assert not p.improved
        assert p.theta_hat == pytest.approx(1.0, abs=1e-5)
    # CI of a from the global optimum: 1.44 (a^2-1)^2 + 0.25 (a-1)^2 = 3.84 at a = -1.502 and 1.616
    # (piecewise-linear crossing between profile steps of 0.05-0.2: a few hundredths)
    pa = ps.profiles[0]
    assert pa.classification == "identifiable"
    # the old profile crossed 3.84 above the wrong reference (chi2 = 4.80): an interval too wide
    assert ps.first_classifications[0] == old.classification == "identifiable"
    assert old.ci[0] < pa.ci[0] - 0.05 and old.ci[1] > pa.ci[1] + 0.05
    assert pa.ci[0] == pytest.approx(-1.502, abs=0.03) and pa.ci[1] == pytest.approx(1.616, abs=0.03)
    # negative control: started in the global well there is nothing to restart
    ps_good = profile_all(_two_wells, [0.9, 0.9], **kw)
    assert ps_good.n_restarts == 0 and ps_good.improvements == ()
    np.testing.assert_allclose(ps_good.profiles[0].ci, pa.ci, atol=1e-3)
    # the cap: no restart allowed, the defect is reported instead of hidden
    ps_cap = profile_all(_two_wells, th_local, [0], max_restarts=0, **kw)
    assert not ps_cap.converged and ps_cap.n_restarts == 0


def test_profile_all_uses_the_given_map_and_validates():
    calls = []

    def my_map(func, args, kwargs):
        calls.append(len(args))
        return [func(*a, **kwargs) for a in args]

    ps = profile_all(_lin, [1.0, 2.0, -1.0], [1, 2], lower=[-10] * 3, upper=[10] * 3, log=False, map_fn=my_map)
    assert calls == [2] and [p.index for p in ps.profiles] == [1, 2]
    with pytest.raises(ValidationError, match="indices"):
        profile_all(_lin, [1.0, 2.0, -1.0], [3], lower=[-10] * 3, upper=[10] * 3, log=False)
    with pytest.raises(ValidationError, match="max_restarts"):
        profile_all(_lin, [1.0, 2.0, -1.0], max_restarts=-1, lower=[-10] * 3, upper=[10] * 3, log=False)
    with pytest.raises(ValidationError, match="improvement_tol"):
        ProfileOptions(improvement_tol=0.0)
