"""The nested engine's peak reference (inference/sampling/peak.py): the runs' likelihood climbed from the
least-squares optima, checked on a tilted Gaussian and on two tests of very different noise, where the least-squares
optimum lies far below the peak of the likelihood with the noise sds integrated out."""

from types import SimpleNamespace

import numpy as np
import pytest
from scipy.optimize import minimize

from bayestissue.inference import fit_least_squares
from bayestissue.inference.likelihood import GaussianNoise
from bayestissue.inference.marginal_noise import MarginalNoise
from bayestissue.inference.parameters import ParameterSet, ParameterSpec
from bayestissue.inference.problem import CalibrationProblem, ExperimentTerm
from bayestissue.inference.sampling import NestedOptions
from bayestissue.inference.sampling import peak as P
from tests.inference.linear_model import LinearForward


def test_the_climb_reaches_a_peak_inside_the_box_and_meets_one_outside_at_its_bound(monkeypatch):
    """A tilted Gaussian in box coordinates (a log-uniform and a uniform parameter) with its peak at u = (0.3, 0.8),
    far from the start (0.9, 0.1): the climb reaches the peak's value; with the peak at u = (1.4, 0.8), outside
    the box, it ends on the bound u = 1 (value 40 - 50 x 0.4^2)."""
    lo, hi = np.array([0.01, 0.0]), np.array([100.0, 10.0])

    def unit(x):
        return np.array([np.log(x[0] / lo[0]) / np.log(hi[0] / lo[0]), (x[1] - lo[1]) / (hi[1] - lo[1])])

    box = SimpleNamespace(to_unit=unit, from_unit=lambda u: np.array([lo[0] * (hi[0] / lo[0]) ** u[0], 10 * u[1]]))
    for peak_u, expected in (((0.3, 0.8), 40.0), ((1.4, 0.8), 40.0 - 50.0 * 0.4**2)):

        def log_l(x, peak_u=peak_u):
            u = np.array([unit(row) for row in np.atleast_2d(x)])
            return 40.0 - 50.0 * np.sum((u - np.asarray(peak_u)) ** 2 * [1.0, 4.0], axis=1)

        monkeypatch.setattr(P, "nested_target", lambda problem, options, f=log_l: (2, None, f, None))
        problem = SimpleNamespace(material=box, n_material=2)
        got = P.climb_log_likelihood(problem, None, box.from_unit(np.array([0.9, 0.1])))
        assert got == pytest.approx(expected, abs=1e-6)


def test_failed_solves_in_the_climb_are_walked_around_without_a_warning(monkeypatch):
    """A log-likelihood that is -inf (a failed forward solve) on the half u_1 > 0.5 of the box, with its finite peak
    at u = (0.3, 0.4): the climb from inside the finite half reaches the peak, and Powell's line search through the
    infinite half raises no RuntimeWarning (this suite turns warnings into errors; the T1 11-parameter fit of
    tests/cli/test_fit_cli.py met it on this machine's arithmetic)."""
    box = SimpleNamespace(to_unit=lambda x: np.asarray(x, float), from_unit=lambda u: np.asarray(u, float))

    def log_l(x):
        u = np.atleast_2d(x)
        value = 10.0 - 20.0 * np.sum((u - [0.3, 0.4]) ** 2, axis=1)
        return np.where(u[:, 0] > 0.5, -np.inf, value)

    monkeypatch.setattr(P, "nested_target", lambda problem, options: (2, None, log_l, None))
    problem = SimpleNamespace(material=box, n_material=2)
    got = P.climb_log_likelihood(problem, None, np.array([0.45, 0.9]))
    assert got == pytest.approx(10.0, abs=1e-6)


def _two_tests(rng):
    """Two linear tests of one parameter vector, noise sd 0.01 and 1.0, both sds unknown (integrated out)."""
    truth = np.array([0.5, -1.0, 2.0])
    t = np.linspace(0.0, 1.0, 60)
    specs = tuple(ParameterSpec(f"x{i}", "1", -20.0, 20.0, prior="uniform", value=0.0) for i in range(3))
    terms, designs = [], []
    for k, sd in enumerate((0.01, 1.0)):
        a = np.column_stack([np.ones_like(t), np.cos((k + 1) * np.pi * t), np.sin(np.pi * t + k)])
        y = a @ truth + sd * rng.standard_normal(t.size)
        terms.append(ExperimentTerm(f"E{k + 1}", t, y, LinearForward(a), GaussianNoise(sd=None), {"synthetic": True}))
        designs.append((a, y))
    return CalibrationProblem(terms, ParameterSet(specs, {"model": "linear stand-in"})), designs


def test_on_two_tests_of_different_noise_the_reference_is_the_likelihoods_peak_not_the_least_squares_optimum():
    """Least squares weighs both tests' residuals alike, so the noisy test pulls its optimum away from the precise
    test; the runs' likelihood, :math:`-\\sum_i n_i/2 \\ln SSR_i`, is far higher at its own peak. The reference equals
    that peak as found independently (BFGS on the closed form from the precision-weighted least-squares solution)
    to 1e-6 nats (the climb's tolerances are 1e-8 in box units), and the optimum's value lies more than d/2 below
    it: a reference taken there would make the peak check unable to fail."""
    problem, designs = _two_tests(np.random.default_rng(3))
    options = NestedOptions(sampler="ultranest")
    best = fit_least_squares(problem)
    peak = P.peak_reference(problem, options, [problem.nuisance_estimate(best.x)])

    def minus_profile(x):
        return sum(0.5 * y.size * np.log(np.sum((y - a @ x) ** 2)) for a, y in designs)

    w = [1e4, 1.0]  # precision weights of the simulated sds
    lhs = sum(wi * a.T @ a for wi, (a, _) in zip(w, designs, strict=True))
    x0 = np.linalg.solve(lhs, sum(wi * a.T @ y for wi, (a, y) in zip(w, designs, strict=True)))
    x_star = minimize(minus_profile, x0, method="BFGS", options={"gtol": 1e-10}).x
    expected = float(MarginalNoise(problem).log_likelihood(x_star[None, :])[0])
    assert peak.climbed[0] == pytest.approx(expected, abs=1e-6)
    assert peak.value == peak.climbed[0]
    assert peak.value - peak.at_optima[0] > 0.5 * problem.n_material
    assert "climbed to" in peak.text() and f"{peak.value:.2f}" in peak.text()


def test_without_integrating_the_noise_out_the_climb_runs_over_the_sds_too():
    """Where the runs sample the sds (noise not integrated out), the climb searches them as well: its value is at
    more than d/2 above that of the runs' likelihood at the least-squares optimum with its plug-in sds (here 111
    nats above)."""
    problem, _ = _two_tests(np.random.default_rng(4))
    options = NestedOptions(sampler="ultranest", marginalise_noise=False)
    best = fit_least_squares(problem)
    peak = P.peak_reference(problem, options, [problem.nuisance_estimate(best.x)])
    assert np.isfinite(peak.value) and peak.climbed[0] > peak.at_optima[0] + 0.5 * problem.ndim
