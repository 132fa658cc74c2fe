"""The two-stage population sampler (inference.hierarchy) against the exact posterior of a Gaussian hierarchy.

Specimen i has a Gaussian likelihood in z with known sd sigma_i, so its stage-1 posterior under a flat prior is
N(y_i, sigma_i^2) and the population posterior of (m, d, s) is known given s: the marginal
y_i ~ N(m + d_g, s^2 + sigma_i^2) with Gaussian priors on (m, d) integrates them out exactly, and s is one
dimension (quadrature on a 4000-point grid: bayestissue.inference.hierarchy_reference). Tolerances: the sampler's
Monte Carlo error. With 4 chains x 2500 draws the bulk ESS of d is about 800 and of s about 150 (s mixes slowly
near 0, the hierarchy's funnel); the 5 % / 95 % quantiles of d then have an MC sd of about 0.02 and the median of s
about 0.01: we allow 3 sd.
"""

import numpy as np
import pytest

from bayestissue._validation import ValidationError
from bayestissue.inference.hierarchy import check_population_parameters, population_scale, sample_population
from bayestissue.inference.hierarchy_reference import gaussian_population_quantiles
from bayestissue.inference.ordering import OrderedGroup
from bayestissue.inference.parameters import ParameterSpec

GROUPS = ["a", "a", "a", "b", "b", "b", "b"]
SIG = np.array([0.3, 0.5, 0.2, 0.4, 0.3, 0.6, 0.25])
TRUE_Z = np.array([0.0, 0.5, -0.4, 1.5, 1.2, 2.0, 1.6])


def exact_quantiles(y, sig, width):
    """(d, s, m) quantiles 5/50/95 % of the exact posterior (inference.hierarchy_reference)."""
    q = gaussian_population_quantiles(y, sig, [int(g == "b") for g in GROUPS], centre=0.0, width=width,
                                      sd_scale=width / 4, effect_scale=width / 4, s_max=8.0)  # fmt: skip
    return q["d[1]"], q["s"], q["m"]


@pytest.fixture(scope="module")
def data():
    rng = np.random.default_rng(5)
    return TRUE_Z + SIG * rng.standard_normal(7), rng


def _check(post, y, width):
    d_exact, s_exact, m_exact = exact_quantiles(y, SIG, width)
    np.testing.assert_allclose(np.quantile(post.flat("m")[:, 0], [0.05, 0.5, 0.95]), m_exact, atol=0.06)
    d = post.flat("d")[:, 0, 0]
    s = post.flat("s")[:, 0]
    np.testing.assert_allclose(np.quantile(d, [0.05, 0.5, 0.95]), d_exact, atol=0.06)
    assert abs(np.median(s) - s_exact[1]) < 0.03
    assert abs(np.quantile(s, 0.95) - s_exact[2]) < 0.1


def test_flat_prior_matches_exact_posterior(data):
    y, rng = data
    spec = ParameterSpec("x", "-", -50.0, 50.0, prior="uniform")
    stage1 = [(yi + si * rng.standard_normal(8000))[:, None] for yi, si in zip(y, SIG, strict=True)]
    post = sample_population(stage1, [spec], GROUPS, n_chains=4, n_warmup=500, n_draws=2500, seed=1)
    _check(post, y, 100.0)
    assert np.all((post.acceptance > 0.1) & (post.acceptance < 1.0))


def test_uniform_prior_on_log_scale_needs_the_jacobian(data):
    """A positive parameter with a uniform (not log-uniform) stage-1 prior: on the log scale pi_0(z) is
    proportional to e^z, so the stage-1 posterior of a likelihood N(z; y, sigma) is N(y + sigma^2, sigma). Stage 2
    must divide that factor out and recover the same population posterior as the flat case."""
    y, rng = data
    spec = ParameterSpec("k", "kPa", np.exp(-25.0), np.exp(25.0), prior="uniform")
    stage1 = [np.exp(yi + si**2 + si * rng.standard_normal(8000))[:, None] for yi, si in zip(y, SIG, strict=True)]
    post = sample_population(stage1, [spec], GROUPS, n_chains=4, n_warmup=500, n_draws=2500, seed=2)
    assert post.scale.log[0]
    _check(post, y, 50.0)  # without the Jacobian m would sit about mean(sigma_a^2) = 0.13 too high: fails


def test_same_seed_same_draws(data):
    y, rng = data
    spec = ParameterSpec("x", "-", -50.0, 50.0, prior="uniform")
    stage1 = [(yi + si * rng.standard_normal(500))[:, None] for yi, si in zip(y, SIG, strict=True)]
    a = sample_population(stage1, [spec], GROUPS, n_chains=2, n_warmup=50, n_draws=100, seed=7)
    b = sample_population(stage1, [spec], GROUPS, n_chains=2, n_warmup=50, n_draws=100, seed=7)
    np.testing.assert_array_equal(a.s, b.s)
    np.testing.assert_array_equal(a.z, b.z)


def test_population_scale_round_trip():
    specs = [ParameterSpec("k", "kPa", 1.0, 1e4, prior="loguniform"), ParameterSpec("a", "-", -30.0, 30.0)]
    sc = population_scale(specs)
    theta = np.array([[50.0, -20.0], [2.0, 3.0]])
    np.testing.assert_allclose(sc.to_theta(sc.to_z(theta)), theta)
    assert sc.log.tolist() == [True, False]
    # a log-uniform prior is flat on the log scale: log pi_0 differs by nothing between two points
    assert abs(sc.log_prior0(sc.to_z([[50.0, 1.0]])) - sc.log_prior0(sc.to_z([[2.0, 1.0]]))) < 1e-12


def test_refusals():
    sampled = ("k1_1", "beta1", "beta1_2", "gamma1")
    with pytest.raises(ValidationError, match=r"did you mean 'beta1'"):
        check_population_parameters(["beta"], sampled)
    group = OrderedGroup((("beta1",), ("beta1_2",)), exchangeable=False)
    with pytest.raises(ValidationError, match="all or none of the ordered keys beta1 > beta1_2"):
        check_population_parameters(["beta1"], sampled, [group])
    check_population_parameters(["beta1", "beta1_2"], sampled, [group])
    spec = ParameterSpec("x", "-", -5.0, 5.0)
    with pytest.raises(ValidationError, match="stage-1 draws of specimen 2"):
        sample_population([np.zeros((50, 1)), np.full((50, 1), np.nan)], [spec], ["a", "b"])
    with pytest.raises(ValidationError, match="reference group"):
        sample_population([np.zeros((50, 1))] * 2, [spec], ["a", "b"], reference="c")
