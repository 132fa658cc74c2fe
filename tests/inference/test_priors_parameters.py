"""Box priors, parameter specifications and the unconstrained transform with its log-Jacobian."""

import numpy as np
import pytest
from inference_helpers import PRIOR_SPECS, prior_only_problem
from scipy import integrate, stats

from bayestissue.inference import (
    LogUniformPrior,
    ParameterSet,
    ParameterSpec,
    SamplerOptions,
    UniformPrior,
    initial_walkers,
    run_ensemble,
)
from bayestissue.inference.priors import make_prior
from bayestissue.workflows import paper_parameter_set


@pytest.mark.parametrize("prior", [UniformPrior(0.1, 0.95), LogUniformPrior(1e-3, 1e3)])
def test_prior_density_normalised_and_cdf_inverts_ppf(prior):
    total, _ = integrate.quad(lambda x: np.exp(prior.logpdf(x)), prior.lower, prior.upper, limit=200, points=[1e-2, 1])
    assert total == pytest.approx(1.0, rel=1e-6)
    q = np.linspace(0.01, 0.99, 7)
    np.testing.assert_allclose(prior.cdf(prior.ppf(q)), q, rtol=1e-12)
    assert prior.logpdf(prior.upper * 1.01) == -np.inf


def test_prior_errors():
    with pytest.raises(ValueError, match="lower < upper"):
        UniformPrior(2.0, 1.0)
    with pytest.raises(ValueError, match="log-uniform prior lower bound"):
        LogUniformPrior(0.0, 1.0)
    with pytest.raises(ValueError, match="prior: expected one of"):
        make_prior("gaussian", 0, 1)


def test_transform_round_trip_and_log_jacobian_matches_finite_differences():
    pars = ParameterSet(PRIOR_SPECS)
    rng = np.random.default_rng(0)
    theta = pars.sample_prior(50, rng=rng)
    z = pars.to_unconstrained(theta)
    np.testing.assert_allclose(pars.from_unconstrained(z), theta, rtol=1e-10)
    h = 1e-6
    for j in range(pars.n_sampled):
        dz = np.zeros_like(z)
        dz[:, j] = h
        num = (pars.from_unconstrained(z + dz)[:, j] - pars.from_unconstrained(z - dz)[:, j]) / (2 * h)
        if j == 0:
            total = np.log(np.abs(num))
        else:
            total = total + np.log(np.abs(num))
    np.testing.assert_allclose(pars.log_abs_det_jacobian(z), total, rtol=1e-5, atol=1e-6)


def _prior_draws(problem, rng, n_steps=2500):
    opts = SamplerOptions(n_walkers=32, max_steps=n_steps, check_every=n_steps, prune_rounds=0, tau_factor=1e9)
    p0 = initial_walkers(problem, problem.parameters.initial, 32, rng=rng)
    res = run_ensemble(problem, p0, options=opts, seed=int(rng.integers(2**31)))
    z, _ = res.kept()
    step = max(1, int(np.ceil(3 * np.max(res.tau) / res.store_thin)))  # ~independent draws
    z = z[::step].reshape(-1, problem.ndim)
    return problem.parameters.from_unconstrained(z)


def test_prior_marginals_through_the_sampler_pass_ks():
    """Draw from the prior through the sampler's own path (z-space target with log-Jacobian)."""
    problem = prior_only_problem(PRIOR_SPECS)
    x = _prior_draws(problem, np.random.default_rng(11))
    assert x.shape[0] > 800
    for j, spec in enumerate(PRIOR_SPECS):
        p = stats.kstest(x[:, j], spec.prior_dist.cdf).pvalue
        assert p > 1e-3, (spec.name, p)


def test_ks_catches_the_classic_jacobian_mistake(monkeypatch):
    """Negative control: without the log-Jacobian the sampler targets the wrong prior."""
    problem = prior_only_problem(PRIOR_SPECS[2:3])  # uniform prior on a log-scaled box
    monkeypatch.setattr(ParameterSet, "log_abs_det_jacobian", lambda self, z: np.zeros(np.shape(z)[:-1]))
    # Without any Jacobian the target in z is improper (flat tails): the walkers drift to infinity,
    # which emcee reports, or, if they have not got there yet, the KS test rejects.
    with np.errstate(all="ignore"):
        try:
            x = _prior_draws(problem, np.random.default_rng(12), n_steps=1000)
        except ValueError as exc:
            assert "infinite" in str(exc)
            return
    assert stats.kstest(x[:, 0], PRIOR_SPECS[2].prior_dist.cdf).pvalue < 1e-6


def test_partial_jacobian_mistake_is_caught(monkeypatch):
    """Dropping only the log x term of a log-scaled box (uniform prior) is caught as well."""
    problem = prior_only_problem(PRIOR_SPECS[2:3])
    original = ParameterSet.log_abs_det_jacobian

    def without_log_x(self, z):
        x = self.from_unconstrained(z)
        return original(self, z) - np.log(x).sum(axis=-1)

    monkeypatch.setattr(ParameterSet, "log_abs_det_jacobian", without_log_x)
    x = _prior_draws(problem, np.random.default_rng(13), n_steps=1500)
    assert stats.kstest(x[:, 0], PRIOR_SPECS[2].prior_dist.cdf).pvalue < 1e-6


def test_paper_parameter_set_defaults():
    pars = paper_parameter_set()
    assert pars.names[:3] == ("mu", "kappa", "ginf1")
    assert {s.name: s.prior for s in pars.specs}["gamma2"] == "uniform"
    assert {s.name: s.prior for s in pars.specs}["beta3"] == "loguniform"
    np.testing.assert_allclose(pars.initial[:2], [10, 50])
    uni = paper_parameter_set(prior="uniform")
    assert all(s.prior == "uniform" for s in uni.specs)


def test_fixed_parameters_expand():
    pars = paper_parameter_set().updated(fixed={"ginf1": 125.0, "gamma1": 0.75})
    assert pars.n_sampled == 9
    full = pars.expand(np.ones((2, 9)))
    assert full.shape == (2, 11)
    np.testing.assert_allclose(full[:, 2:4], [[125.0, 0.75]] * 2)


def test_parameter_errors():
    with pytest.raises(ValueError, match="mu bounds: expected lower < upper"):
        ParameterSpec("mu", "kPa", 10.0, 1.0)
    with pytest.raises(ValueError, match="mu initial/fixed value: expected a value inside the box"):
        ParameterSpec("mu", "kPa", 1.0, 10.0, value=20.0)
    with pytest.raises(ValueError, match="mu value: expected a value for a fixed parameter"):
        ParameterSpec("mu", "kPa", 1.0, 10.0, fixed=True)
    with pytest.raises(ValueError, match="parameter name: expected a Python identifier"):
        ParameterSpec("m u", "kPa", 1.0, 10.0)
    with pytest.raises(ValueError, match="mu prior: expected one of"):
        ParameterSpec("mu", "kPa", 1.0, 10.0, prior="normal")
    with pytest.raises(ValueError, match="mu scale: expected one of"):
        ParameterSpec("mu", "kPa", 1.0, 10.0, scale="sqrt")
    with pytest.raises(ValueError, match="mu lower bound: expected a number > 0 for a log-uniform"):
        ParameterSpec("mu", "kPa", 0.0, 10.0, prior="loguniform")
    spec = ParameterSpec("mu", "kPa", 1.0, 10.0)
    with pytest.raises(ValueError, match="parameter names: expected unique names"):
        ParameterSet((spec, spec))
    pars = paper_parameter_set()
    with pytest.raises(ValueError, match=r"fixed parameter names: expected names among"):
        pars.updated(fixed=["nu"])
    with pytest.raises(ValueError, match="expected each parameter either fixed or sampled"):
        pars.updated(fixed=["mu"], sampled=["mu"])
    with pytest.raises(ValueError, match="mu bounds: expected lower < upper"):
        pars.updated(bounds={"mu": [10.0, 1.0]})
    with pytest.raises(ValueError, match="mu initial/fixed value: expected a value inside the box"):
        pars.updated(initial={"mu": 5000.0})
    with pytest.raises(ValueError, match="theta: expected shape"):
        pars.expand(np.ones(3))


def test_tied_parameters_take_the_value_of_their_target():
    pars = paper_parameter_set().updated(tied={"ginf3": "ginf2", "gamma3": "gamma2", "beta3": "beta2"})
    assert pars.n_sampled == 8
    assert pars.tied == {"ginf3": "ginf2", "gamma3": "gamma2", "beta3": "beta2"}
    assert pars.tied_text == "ginf3=ginf2, gamma3=gamma2, beta3=beta2"
    assert paper_parameter_set().tied_text == "none"
    theta = np.arange(1.0, 9.0)[None] / 10
    full = pars.expand(theta)
    names = pars.names
    for a, b in pars.tied.items():
        assert full[0, names.index(a)] == full[0, names.index(b)]
    np.testing.assert_array_equal(full[0, : names.index("ginf3")], theta[0])
    # tied to a fixed parameter: takes the held value
    held = paper_parameter_set().updated(fixed={"ginf2": 7.0}, tied={"ginf3": "ginf2"})
    assert held.expand(np.ones((1, held.n_sampled)))[0, names.index("ginf3")] == 7.0


def test_tied_parameter_errors():
    pars = paper_parameter_set()
    with pytest.raises(ValueError, match=r"tied parameter names: expected names among"):
        pars.updated(tied={"ginf9": "ginf2"})
    with pytest.raises(ValueError, match=r"tied-to parameter names: expected names among"):
        pars.updated(tied={"ginf3": "ginf9"})
    with pytest.raises(ValueError, match="parameters: expected each parameter either tied, fixed or sampled"):
        pars.updated(tied={"ginf3": "ginf2"}, fixed=["ginf3"])
    with pytest.raises(ValueError, match=r"ginf3 tied_to: expected a parameter in the same unit \(kPa\)"):
        pars.updated(tied={"ginf3": "gamma2"})
    with pytest.raises(ValueError, match="ginf3 tied_to: expected an untied parameter"):
        pars.updated(tied={"ginf3": "ginf2", "ginf2": "mu"})
    with pytest.raises(ValueError, match="mu tied_to: expected the name of another parameter"):
        ParameterSpec("mu", "kPa", 1.0, 10.0, tied_to="mu")
