"""Least squares (the paper's method), Wald intervals, multi-start, against the linear closed form."""

import numpy as np
import pytest

from bayestissue.inference import fit_least_squares, fit_multistart
from bayestissue.inference.warmstart import cluster_optima, latin_hypercube, wald_interval
from tests.inference.linear_model import linear_gaussian_posterior, linear_gaussian_problem


@pytest.mark.parametrize("space", ["natural", "unit"])
def test_least_squares_and_wald_recover_the_closed_form(space):
    problem, _ = linear_gaussian_problem(rng=4)
    mean, cov = linear_gaussian_posterior(problem)
    res = fit_least_squares(problem, x0=np.array([0.5, -0.5, 0.3]), space=space)
    np.testing.assert_allclose(res.x, mean, atol=1e-7)
    # known sd: residuals are scaled by it, so cov = s2 (J^T J)^-1 with s2 ~ 1
    np.testing.assert_allclose(res.cov / res.s2, cov, rtol=1e-4, atol=1e-9)
    assert res.rank == 3 and not res.active.any()
    assert res.history_scaled.shape == (res.nit + 1, 3)
    assert res.history_cost[-1] == pytest.approx(res.cost, rel=1e-9)
    z = 1.6448536269514722
    np.testing.assert_allclose(res.wald_upper - res.x, z * np.sqrt(np.diag(res.cov)), rtol=1e-10)


def test_wald_interval_of_a_positive_parameter_is_taken_in_log_space():
    """The linear-model box straddles 0 (linear intervals, above); a positive box gives the log-space interval:
    positive, symmetric in log, and equal to the linear one to first order when sd << the estimate."""
    z = 1.6448536269514722
    lo, hi = wald_interval([2.18, 0.5, -3.0], [0.002, 0.4, 1.0], z, positive=np.array([True, True, False]))
    assert np.all(lo[:2] > 0)
    np.testing.assert_allclose(np.log(hi[:2]) - np.log([2.18, 0.5]), np.log([2.18, 0.5]) - np.log(lo[:2]))
    # equal to first order; the second-order term (z sd)^2 / (2 x) is 2.5e-6 here
    np.testing.assert_allclose([lo[0], hi[0]], [2.18 - z * 0.002, 2.18 + z * 0.002], rtol=2e-6)
    np.testing.assert_allclose([lo[2], hi[2]], [-3.0 - z, -3.0 + z])
    # an estimate at its lower bound with a huge sd (mu = 0.001001, sd 211 kPa): [0, inf], never negative
    lo, hi = wald_interval([0.001001], [211.0], z, positive=np.array([True]))
    assert lo[0] == 0.0 and hi[0] == np.inf


def test_active_bound_is_reported():
    problem, truth = linear_gaussian_problem(rng=4)
    mat = problem.material.updated(bounds={"x0": [truth[0] + 0.5, 20.0]})
    problem2 = type(problem)(problem.experiments, mat)
    res = fit_least_squares(problem2, x0=np.array([truth[0] + 1.0, 0.0, 0.0]))
    assert res.active[0] == -1
    assert res.active_names() == ["x0 (lower)"]
    assert res.x[0] == pytest.approx(truth[0] + 0.5)


def test_multistart_finds_one_cluster_on_a_convex_problem():
    problem, _ = linear_gaussian_problem(rng=4)
    mean, _ = linear_gaussian_posterior(problem)
    ms = fit_multistart(problem, n_starts=5, rng=0, space="unit")
    assert len(ms.results) == 6
    assert np.all(np.diff(ms.costs) >= 0)
    assert set(ms.labels) == {0}
    np.testing.assert_allclose(ms.best.x, mean, atol=1e-6)
    assert ms.best_cluster_spread(problem).max() < 1e-6


def test_multistart_redraws_starts_the_fit_cannot_leave():
    # every forward solve fails where x0 > 0: a start there has no step (nit 0) and is drawn again
    problem, truth = linear_gaussian_problem(rng=4, fail_above=0.0)
    mean, _ = linear_gaussian_posterior(problem)
    stuck = fit_multistart(problem, n_starts=6, rng=1, space="unit", max_redraws=0)
    assert stuck.n_redrawn == 0
    assert sum(r.nit == 0 for r in stuck.results) == 3  # the Latin hypercube put 3 of 6 starts above 0
    ms = fit_multistart(problem, n_starts=6, rng=1, space="unit")
    assert len(ms.results) == 7 and ms.n_redrawn >= 3
    random_starts = [r for r in ms.results if r.x0[0] != problem.material.initial[0]]
    assert all(r.nit > 0 and r.x0[0] < 0 for r in random_starts)
    np.testing.assert_allclose(ms.best.x, mean, atol=1e-6)
    again = fit_multistart(problem, n_starts=6, rng=1, space="unit")  # same seed, same starts
    np.testing.assert_array_equal([r.x0 for r in again.results], [r.x0 for r in ms.results])


def test_cluster_labels_and_latin_hypercube():
    labels = cluster_optima([1.0, 1.0000001, 2.0, 2.0001, 5.0])
    assert labels.tolist() == [0, 0, 1, 1, 2]
    u = latin_hypercube(10, 3, rng=0)
    for j in range(3):  # one point per stratum
        assert sorted(np.floor(u[:, j] * 10).astype(int)) == list(range(10))


def test_warmstart_errors():
    problem, _ = linear_gaussian_problem(rng=4)
    with pytest.raises(ValueError, match="initial guess x1: expected a value inside the box"):
        fit_least_squares(problem, x0=np.array([0.0, 50.0, 0.0]))
    with pytest.raises(ValueError, match=r"x0: expected shape \(3,\)"):
        fit_least_squares(problem, x0=np.zeros(2))
    with pytest.raises(ValueError, match="space: expected 'natural'"):
        fit_least_squares(problem, space="log")
    with pytest.raises(ValueError, match="x_scale: expected 'initial', 'jac' or 3 positive"):
        fit_least_squares(problem, x_scale=np.array([1.0, -1.0, 1.0]))
    with pytest.raises(ValueError, match="n_starts: expected an integer >= 0"):
        fit_multistart(problem, n_starts=-1)
    with pytest.raises(ValueError, match="max_redraws: expected an integer >= 0"):
        fit_multistart(problem, n_starts=2, max_redraws=-1)
