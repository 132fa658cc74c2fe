"""The one least-squares routine: its Jacobian against the exact one, its optimum against a closed form."""

import numpy as np

from bayestissue.inference.optimize import ForwardDifferences, least_squares_trf


def _exp_model(V):
    """r_j(a, b) = a exp(-b t_j) - y_j for a batch of (a, b) rows."""
    t = np.linspace(0.0, 2.0, 7)
    y = 1.5 * np.exp(-0.7 * t)
    return V[:, :1] * np.exp(-V[:, 1:2] * t) - y


def test_forward_differences_match_the_exact_jacobian_and_step_away_from_the_upper_bound():
    t = np.linspace(0.0, 2.0, 7)
    v = np.array([2.0, 0.5])
    exact = np.column_stack([np.exp(-v[1] * t), -v[0] * t * np.exp(-v[1] * t)])
    fd = ForwardDifferences(_exp_model, [10.0, 10.0], rel_step=1e-7, step_floor=1.0)
    fd.fun(v)
    # forward-difference error ~ h |r''| / 2 with h = 2e-7: below 1e-6 here
    np.testing.assert_allclose(fd.jac(v), exact, atol=1e-6)
    calls = []
    at_bound = ForwardDifferences(lambda V: calls.append(V.copy()) or _exp_model(V), v, rel_step=1e-7, step_floor=1.0)
    np.testing.assert_allclose(at_bound.jac(v), exact, atol=1e-6)  # backward steps, same accuracy
    assert np.all(calls[-1] <= v)  # no evaluated point beyond the upper bound


def test_linear_least_squares_reaches_the_normal_equations_solution_inside_and_the_bound_when_active():
    rng = np.random.default_rng(0)
    A, y = rng.normal(size=(20, 3)), rng.normal(size=20)

    def batch(V):
        return V @ A.T - y

    exact = np.linalg.lstsq(A, y, rcond=None)[0]
    sol = least_squares_trf(batch, np.zeros(3), exact - 5, exact + 5, rel_step=1e-8)
    np.testing.assert_allclose(sol.x, exact, atol=1e-7)
    # an upper bound below the unconstrained optimum in the first coordinate becomes active
    upper = exact + 5
    upper[0] = exact[0] - 0.5
    sol = least_squares_trf(batch, exact - 1, exact - 5, upper, rel_step=1e-8)
    assert sol.active_mask[0] == 1 and abs(sol.x[0] - upper[0]) < 1e-12  # TRF stays strictly inside
    # the other two: least squares with the first held at its bound (closed form)
    rest = np.linalg.lstsq(A[:, 1:], y - A[:, 0] * upper[0], rcond=None)[0]
    np.testing.assert_allclose(sol.x[1:], rest, atol=1e-7)
