"""Noise models against scipy's densities; the calibration problem (several experiments, failures)."""

import numpy as np
import pytest
from scipy import stats

from bayestissue.inference import (
    AR1Noise,
    CalibrationProblem,
    ExperimentTerm,
    GaussianNoise,
    ParameterSet,
    ParameterSpec,
    StudentTNoise,
    make_noise,
)
from tests.inference.linear_model import LinearForward, linear_gaussian_problem

RNG = np.random.default_rng(5)
RESID = RNG.normal(0, 0.3, (3, 25))


def test_gaussian_matches_scipy():
    ll = GaussianNoise().loglik_pointwise(RESID, np.full((3, 1), 0.3))
    np.testing.assert_allclose(ll, stats.norm.logpdf(RESID, scale=0.3), rtol=1e-12)
    known = GaussianNoise(sd=0.2).loglik_pointwise(RESID, np.empty((3, 0)))
    np.testing.assert_allclose(known, stats.norm.logpdf(RESID, scale=0.2), rtol=1e-12)


def test_ar1_total_equals_multivariate_normal():
    sd, rho = 0.3, 0.7
    n = RESID.shape[1]
    lags = np.abs(np.subtract.outer(np.arange(n), np.arange(n)))
    cov = sd**2 * rho**lags
    ll = AR1Noise().loglik_pointwise(RESID, np.array([[sd, rho]] * 3)).sum(axis=1)
    ref = stats.multivariate_normal(np.zeros(n), cov).logpdf(RESID)
    np.testing.assert_allclose(ll, ref, rtol=1e-10)
    zero = AR1Noise(rho=0.0).loglik_pointwise(RESID, np.array([[sd]] * 3))
    np.testing.assert_allclose(zero, stats.norm.logpdf(RESID, scale=sd), rtol=1e-12)


def test_student_t_matches_scipy():
    ll = StudentTNoise(nu=3.0).loglik_pointwise(RESID, np.full((3, 1), 0.25))
    np.testing.assert_allclose(ll, stats.t.logpdf(RESID, 3.0, scale=0.25), rtol=1e-12)


def test_noise_simulation_has_the_declared_sd_and_correlation():
    sim = AR1Noise().simulate(4000, np.array([[0.5, 0.6]] * 4), rng=1)
    assert sim.std() == pytest.approx(0.5, rel=0.05)
    r = np.mean([np.corrcoef(s[1:], s[:-1])[0, 1] for s in sim])
    assert r == pytest.approx(0.6, abs=0.03)


def test_nuisance_parameters_named_per_experiment():
    specs = AR1Noise().nuisance_specs("T1", np.linspace(0, 2, 10))
    assert [s.name for s in specs] == ["sigma_T1", "rho_T1"]
    assert specs[0].upper == pytest.approx(2.0) and specs[0].prior == "loguniform"
    assert GaussianNoise(sd=0.02).nuisance_specs("T1", [0, 1]) == ()


def test_noise_errors():
    with pytest.raises(ValueError, match="noise model: expected one of"):
        make_noise("cauchy")
    with pytest.raises(ValueError, match="gaussian noise options: expected options among"):
        make_noise("gaussian", nu=3)
    with pytest.raises(ValueError, match="noise sd: expected a number > 0"):
        GaussianNoise(sd=-1.0)
    with pytest.raises(ValueError, match="rho_bounds: expected -1 < lower < upper < 1"):
        AR1Noise(rho_bounds=(-1.0, 0.5))
    with pytest.raises(ValueError, match="noise sd_bounds: expected 0 < lower < upper"):
        GaussianNoise(sd_bounds=(1.0, 0.5))
    with pytest.raises(ValueError, match="Student-t nu: expected a number > 0"):
        StudentTNoise(nu=0)


def test_failed_forward_gives_minus_inf_and_is_counted():
    problem, truth = linear_gaussian_problem(fail_above=0.5, rng=2)
    theta = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.2, 0.1, 0.0]])
    lp = problem.log_posterior(theta)
    assert np.isfinite(lp[[0, 2]]).all() and lp[1] == -np.inf
    assert problem.n_failed == 1 and problem.n_evaluations == 3
    z = problem.parameters.to_unconstrained(theta)
    assert problem.log_posterior_unconstrained(z)[1] == -np.inf


def test_outside_box_is_minus_inf_without_calling_the_forward_model():
    problem, _ = linear_gaussian_problem(rng=2)
    assert problem.log_posterior(np.array([100.0, 0, 0])) == -np.inf
    assert problem.n_evaluations == 0


def test_experiments_share_material_parameters():
    problem, truth = linear_gaussian_problem(n_experiments=2, rng=3)
    theta = truth[None, :] + 0.01
    parts = problem.log_likelihood_pointwise(theta)
    singles = []
    for e in problem.experiments:
        p1 = CalibrationProblem([e], problem.material)
        singles.append(p1.log_likelihood(theta)[0])
    assert len(parts) == 2
    assert problem.log_likelihood(theta)[0] == pytest.approx(sum(singles), rel=1e-12)
    unknown = CalibrationProblem(
        [ExperimentTerm(e.name, e.time_s, e.observed, e.forward, AR1Noise()) for e in problem.experiments],
        problem.material,
    )
    assert unknown.names[-4:] == ("sigma_E1", "rho_E1", "sigma_E2", "rho_E2")


def test_problem_errors():
    fwd = LinearForward(np.ones((4, 1)))
    mat = ParameterSet((ParameterSpec("x0", "1", -1, 1),))
    with pytest.raises(ValueError, match="experiment T1 observed data: expected finite"):
        ExperimentTerm("T1", np.arange(4.0), np.array([0, np.nan, 1, 2]), fwd)
    with pytest.raises(ValueError, match="experiment T1 data: expected two 1-D arrays"):
        ExperimentTerm("T1", np.arange(3.0), np.zeros(4), fwd)
    with pytest.raises(ValueError, match="experiment T1 forward: expected a callable"):
        ExperimentTerm("T1", np.arange(4.0), np.zeros(4), "simulate")
    term = ExperimentTerm("T1", np.arange(4.0), np.zeros(4), fwd)
    with pytest.raises(ValueError, match="experiment names: expected unique names"):
        CalibrationProblem([term, term], mat)
    with pytest.raises(ValueError, match="experiments: expected a non-empty sequence"):
        CalibrationProblem([], mat)
    problem = CalibrationProblem([term], mat)
    with pytest.raises(ValueError, match=r"theta: expected shape \(n_sets, 2\)"):
        problem.log_posterior(np.zeros(3))
    bad = CalibrationProblem([ExperimentTerm("T1", np.arange(4.0), np.zeros(4), LinearForward(np.ones((5, 1))))], mat)
    with pytest.raises(ValueError, match=r"experiment T1 forward output: expected \(n_sets, 4\)"):
        bad.predict(np.zeros((1, 2)))


def test_exchangeable_groups_fold_the_label_switching_mode():
    from tests.inference.linear_model import LinearForward

    t = np.linspace(0, 1, 30)
    design = np.column_stack([np.ones_like(t), t, t])  # x1 and x2 enter symmetrically
    specs = tuple(ParameterSpec(f"x{i}", "1", -5, 5, value=0.0) for i in range(3))
    term = ExperimentTerm("E", t, 1 + 0.5 * t, LinearForward(design), GaussianNoise(sd=0.1))
    plain = CalibrationProblem([term], ParameterSet(specs))
    folded = CalibrationProblem([term], ParameterSet(specs), exchangeable=[["x1"], ["x2"]])
    theta = np.array([[1.0, 0.4, 0.1], [1.0, 0.1, 0.4]])
    assert plain.log_likelihood(theta)[0] == pytest.approx(plain.log_likelihood(theta)[1])
    lp = folded.log_posterior(theta)
    assert np.isfinite(lp[0]) and lp[1] == -np.inf
    assert lp[0] == pytest.approx(plain.log_posterior(theta)[0] + np.log(2))
    np.testing.assert_allclose(folded.canonical(theta), [[1.0, 0.4, 0.1], [1.0, 0.4, 0.1]])
    with pytest.raises(ValueError, match="exchangeable: expected two parameter groups"):
        CalibrationProblem([term], ParameterSet(specs), exchangeable=[["x1"], ["x2", "x0"]])
    with pytest.raises(ValueError, match="exchangeable parameter names: expected sampled"):
        CalibrationProblem([term], ParameterSet(specs), exchangeable=[["x1"], ["nu"]])
