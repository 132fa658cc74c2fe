"""The nested engine (nautilus) through its own path: prior transform, closed-form posterior and evidence, two
modes with their weights, seeds, checkpoints, options, and the stored result."""

import numpy as np
import pytest
from inference_helpers import PRIOR_SPECS, lopsided_two_mode_problem, prior_only_problem
from linear_model import linear_gaussian_posterior, linear_gaussian_problem
from scipy import stats

from bayestissue._validation import ValidationError
from bayestissue.inference import NestedOptions, assess_nested, sample_nested
from bayestissue.inference.evidence import weighted_ess
from bayestissue.inference.posterior import to_inference_data

#: Small runs: 200 live points and one network per bound keep each test to seconds; the checks' tolerances are
#: stated against the runs' own standard errors.
SMALL = {"n_live": 200, "n_eff": 600, "n_networks": 1}


def _closed_form_log_z(problem, box):
    """log Z of the linear-Gaussian stand-in with known sd and uniform priors on [-box, box]^p:
    :math:`\\log Z = \\log L(\\hat x) + \\tfrac p2 \\log 2\\pi + \\tfrac12 \\log|\\Sigma| - p \\log(2\\,box)`,
    exact up to the box truncation (the box edges lie over 300 posterior sd away: below 1e-300)."""
    mean, cov = linear_gaussian_posterior(problem)
    p = mean.size
    return (
        float(problem.log_likelihood(mean))
        + 0.5 * p * np.log(2 * np.pi)
        + 0.5 * np.linalg.slogdet(cov)[1]
        - p * np.log(2 * box)
    )


def test_prior_transform_is_the_box_prior():
    """Uniform quantiles through ``from_prior_quantiles`` are draws of each box prior, whatever its scale (KS
    test, 20 000 draws, p > 0.01), and the transform is the prior CDF's inverse."""
    from bayestissue.inference import ParameterSet

    pars = ParameterSet(PRIOR_SPECS)
    q = np.random.default_rng(0).random((20000, len(PRIOR_SPECS)))
    x = pars.from_prior_quantiles(q)
    for j, s in enumerate(PRIOR_SPECS):
        assert stats.kstest(x[:, j], s.prior_dist.cdf).pvalue > 0.01, s.name
        np.testing.assert_allclose(s.prior_dist.cdf(x[:, j]), q[:, j], atol=1e-12)


def test_flat_likelihood_returns_the_prior_through_the_engine():
    """A constant likelihood: the engine's equal-weight draws follow every box prior (KS p > 0.01) and log Z is
    the constant (5 zero residuals, sd 1: 5 log N(0 | 0, 1))."""
    problem = prior_only_problem(PRIOR_SPECS)
    sample = sample_nested(problem, options=NestedOptions(**SMALL, n_runs=2), rng=5)
    flat = sample.flat()
    for j, s in enumerate(PRIOR_SPECS):
        assert stats.kstest(flat[:, j], s.prior_dist.cdf).pvalue > 0.01, s.name
    assert sample.log_z == pytest.approx(5 * stats.norm.logpdf(0.0), abs=1e-9)


@pytest.fixture(scope="module")
def linear_run():
    problem, _ = linear_gaussian_problem(n_obs=40, n_params=3, sd=0.1, box=20.0, rng=1)
    sample = sample_nested(problem, options=NestedOptions(**SMALL, n_runs=4), rng=3)
    return problem, sample


def test_linear_gaussian_posterior_and_evidence_match_the_closed_form(linear_run):
    """Posterior mean within 0.15 posterior sd (about 7 standard errors at the pooled ESS of about 2700), sd within
    6 %, log Z within 4 of its standard errors of the closed form; the verdict is CONVERGED. Negative controls: a
    closed form shifted by 0.5 sd, and the evidence of a model whose noise sd is 10 % off, fail the same checks."""
    problem, sample = linear_run
    mean, cov = linear_gaussian_posterior(problem)
    sd = np.sqrt(np.diag(cov))
    flat = sample.flat()
    report = assess_nested(sample)
    assert report.converged, report.verdict()
    assert report.verdict().startswith("CONVERGED")
    assert np.all(np.abs(flat.mean(axis=0) - mean) < 0.15 * sd)
    assert np.all(np.abs(flat.std(axis=0) / sd - 1.0) < 0.06)
    log_z = _closed_form_log_z(problem, 20.0)
    assert abs(sample.log_z - log_z) < 4 * sample.log_z_err
    assert not np.all(np.abs(flat.mean(axis=0) - (mean + 0.5 * sd)) < 0.15 * sd)
    wrong, _ = linear_gaussian_problem(n_obs=40, n_params=3, sd=0.11, box=20.0, rng=1)
    assert abs(sample.log_z - _closed_form_log_z(wrong, 20.0)) > 4 * sample.log_z_err


def test_runs_are_checked_against_a_known_peak(linear_run):
    """The runs reach the exact peak (the least-squares optimum) within d/2; a peak 5 higher than any run reached
    (what a run that lost the peak region looks like) makes the verdict say so."""
    problem, sample = linear_run
    mean, _ = linear_gaussian_posterior(problem)
    peak = float(problem.log_likelihood(mean))
    assert assess_nested(sample, reference_log_l=peak).converged
    missed = assess_nested(sample, reference_log_l=peak + 5.0)
    assert not missed.converged
    assert "missed the peak" in missed.verdict()


def test_quantile_errors_match_the_run_to_run_scatter_and_the_closed_form(linear_run):
    """Each run's own (bootstrap) errors of its 5/50/95 % quantiles against the exact quantiles of the Gaussian
    posterior: the standardised deviations (4 runs x 3 parameters x 3 levels) have an sd of about 1 (0.6-1.6: the
    sd of 36 draws of N(0, 1) lies within 0.75-1.25 with probability 0.99, wider here because the 3 levels of one run
    share its points), the runs' scatter is consistent with those errors, and the pooled quantiles lie within 4
    Monte Carlo errors of the exact ones. Negative control: one run's points moved by 0.5 posterior sd make the
    verdict fail on the quantiles and name them."""
    import dataclasses

    from scipy.special import ndtri

    from bayestissue.inference.evidence import LEVELS, weighted_quantile

    problem, sample = linear_run
    mean, cov = linear_gaussian_posterior(problem)
    exact = mean[:, None] + np.sqrt(np.diag(cov))[:, None] * ndtri(np.array(LEVELS))[None, :]
    report = assess_nested(sample)
    z = (report.q_runs - exact[None]) / report.q_errs
    assert 0.6 < z.std() < 1.6, z.std()
    assert report.quantiles_ok and np.min(report.quantile_p) > 0.01 / 9
    pts, w, _ = sample.weighted()
    pooled = np.array([weighted_quantile(pts[:, j], w, LEVELS) for j in range(pts.shape[1])])
    assert np.all(np.abs(pooled - exact) < 4 * report.quantile_mc_error)
    assert "quantiles consistent with their own errors" in report.verdict()
    # the summary reports the quantiles those errors are of: the runs' weighted ones averaged over the runs
    from bayestissue.inference.summary import summary_table
    from bayestissue.inference.warmstart import fit_least_squares

    cols = summary_table(problem, fit_least_squares(problem), sample, report)["columns"]
    table = np.stack([cols["q05"], cols["median"], cols["q95"]], axis=1)
    np.testing.assert_array_equal(table, report.q_runs.mean(axis=0))
    np.testing.assert_array_equal(np.stack([cols["mcse_q05"], cols["mcse_median"], cols["mcse_q95"]], 1),
                                  report.quantile_mc_error)  # fmt: skip
    assert np.all(np.abs(table - exact) < 4 * report.quantile_mc_error)
    moved = list(sample.runs)
    shift = np.zeros(pts.shape[1])
    shift[1] = 0.5 * np.sqrt(cov[1, 1])
    moved[0] = dataclasses.replace(moved[0], points=moved[0].points + shift)
    bad = assess_nested(dataclasses.replace(sample, runs=moved))
    assert not bad.quantiles_ok and not bad.converged
    assert "runs disagree beyond their own Monte Carlo errors" in bad.verdict()
    assert "quantile of x1" in bad.verdict() and "quantile of x0" not in bad.verdict()


def test_two_modes_recovered_with_their_weights():
    """Modes of mass 0.3 and 0.7 (exact, see lopsided_two_mode_problem): every run finds both, the pooled weight of
    the heavier is 0.7 within 0.04 (about 4 standard errors at the pooled ESS)."""
    problem = lopsided_two_mode_problem(0.7)
    sample = sample_nested(problem, options=NestedOptions(**SMALL, n_runs=4), rng=5)
    pts, w, _ = sample.weighted()
    assert abs(np.sum(w[pts[:, 0] > 0]) - 0.7) < 0.04
    for run in sample.runs:
        right = run.points[:, 0] > 0
        assert 0.55 < run.weights[right].sum() < 0.85
        assert np.any(np.abs(run.points[~right, 0] + 2.0 / (0.7 / 0.3)) < 0.05)
    assert assess_nested(sample).converged


def test_same_seed_same_result():
    problem, _ = linear_gaussian_problem(n_obs=20, n_params=2, sd=0.1, box=20.0, rng=2)
    opts = NestedOptions(**SMALL, n_runs=1)
    a = sample_nested(problem, options=opts, rng=11)
    b = sample_nested(problem, options=opts, rng=11)
    c = sample_nested(problem, options=opts, rng=12)
    assert a.log_z == b.log_z
    np.testing.assert_array_equal(a.flat(), b.flat())
    assert a.log_z != c.log_z


def test_a_looser_network_tolerance_changes_the_run_not_the_evidence(linear_run):
    """``network_tol`` reaches nautilus's networks (the same seed gives another run than at 0) and a run at 1e-2,
    a hundred times the tendon preset's 1e-4, still has the closed-form evidence within 4 of its standard errors
    (the networks only shape the bounds whose volumes nautilus measures)."""
    problem, _ = linear_run
    loose = sample_nested(problem, options=NestedOptions(**SMALL, n_runs=2, network_tol=1e-2), rng=3)
    tight = sample_nested(problem, options=NestedOptions(**SMALL, n_runs=2), rng=3)
    assert loose.log_z != tight.log_z
    assert abs(loose.log_z - _closed_form_log_z(problem, 20.0)) < 4 * loose.log_z_err


def test_capped_run_is_not_converged_and_resumes_from_its_checkpoint(tmp_path):
    """A run stopped by ``max_evaluations`` says so; resuming from its nautilus file goes on from the stored
    evaluations (not from zero) and finishes. The noise sd is sampled (integrated out by the runs), so completing
    the points with sd draws runs the forward model once more: those evaluations are not the run's."""
    from bayestissue.inference import GaussianNoise

    problem, _ = linear_gaussian_problem(n_obs=20, n_params=2, sd=0.1, box=20.0, noise=GaussianNoise(), rng=2)
    capped = NestedOptions(**SMALL, n_runs=1, max_evaluations=1500, report_every=500)
    seen = []
    first = sample_nested(problem, options=capped, checkpoint=tmp_path, rng=4, progress=lambda *msg: seen.append(msg))
    assert not first.runs[0].finished
    assert "stopped at the evaluation cap" in assess_nested(first).verdict()
    assert (tmp_path / "nested_0.h5").is_file()
    assert [m[1] for m in seen] == [500, 1000, 1500]
    assert first.runs[0].n_like == 1500  # the run's evaluations, not those that complete its points
    resumed = sample_nested(problem, options=NestedOptions(**SMALL, n_runs=1), checkpoint=tmp_path, resume=True, rng=4)
    assert resumed.runs[0].finished
    # the resumed run evaluated fewer points than a fresh one needs: it kept the stored 1500
    fresh = sample_nested(problem, options=NestedOptions(**SMALL, n_runs=1), rng=4)
    run = resumed.runs[0]
    assert run.n_like_resumed == 1500 and run.n_like - 1500 < fresh.runs[0].n_like
    assert run.time_s > first.runs[0].time_s  # both sessions' seconds (the cost ledger)


def test_weighted_ess_of_equal_weights_is_the_sample_size_and_drops_with_uneven_weights():
    x = np.random.default_rng(0).normal(size=(5000, 2))
    bulk, tail = weighted_ess(x, np.ones(5000))
    np.testing.assert_allclose(bulk, 5000, rtol=1e-9)
    np.testing.assert_allclose(tail, 5000, rtol=1e-9)
    w = np.where(np.arange(5000) < 100, 50.0, 1.0)  # 100 points carry half the weight
    bulk, _ = weighted_ess(x, w)
    assert np.all(bulk < 500)
    w = np.full(5000, 1e-12)
    w[7] = 1.0  # one point carries all the weight: one effective draw, however the delta method reads it
    bulk, tail = weighted_ess(x, w)
    assert np.all(bulk < 1.01) and np.all(tail < 1.01)


def test_inference_data_carries_draws_weights_and_evidence(linear_run):
    problem, sample = linear_run
    idata = to_inference_data(sample, max_draws=800, n_predictive=40, rng=0)
    assert idata.posterior.sizes["chain"] == 4
    assert idata.posterior.sizes["draw"] == 200
    imp = idata.importance_sample
    assert imp["weight"].sum() == pytest.approx(1.0)
    assert imp.sizes["point"] == sum(r.log_w.size for r in sample.runs)
    assert idata.posterior.attrs["log_evidence"] == pytest.approx(sample.log_z)
    assert idata.posterior.attrs["log_evidence_err"] == pytest.approx(sample.log_z_err)
    np.testing.assert_allclose(idata.posterior.attrs["log_evidence_runs"], [r.log_z for r in sample.runs])
    lp = idata.sample_stats["lp"].values.ravel()
    assert np.all(np.isfinite(lp))


@pytest.mark.parametrize(
    "kw, field",
    [
        ({"n_live": 5}, "n_live"),
        ({"n_runs": 0}, "n_runs"),
        ({"f_live": 1.5}, "f_live"),
        ({"f_live": True}, "f_live"),
        ({"max_evaluations": 0}, "max_evaluations"),
        ({"n_eff": 1.5}, "n_eff"),
        ({"discard_exploration": "yes"}, "discard_exploration"),
        ({"network_tol": 0.5}, "network_tol"),
        ({"network_tol": -1e-4}, "network_tol"),
        ({"network_tol": True}, "network_tol"),
    ],
)
def test_nested_option_errors_name_the_field(kw, field):
    with pytest.raises(ValidationError, match=field):
        NestedOptions(**kw)


@pytest.mark.parametrize("prior", ["loguniform", "uniform"])
@pytest.mark.parametrize("rss, n, box", [(0.04, 100, (1e-4, 1.0)), (3.0, 37, (0.05, 0.4)), (1e-3, 400, (1e-6, 2.0))])
def test_marginal_gaussian_likelihood_matches_quadrature(prior, rss, n, box):
    """The closed form (incomplete gamma) against adaptive quadrature over log sigma of the Gaussian likelihood
    times the box prior, to 1e-8 in log L (quad's tolerance, far below any sampling error), and the conditional
    sd draws against the quadrature CDF (KS, 4000 draws, p > 0.01)."""
    from scipy import integrate

    from bayestissue.inference.marginal_noise import draw_sd, log_marginal_gaussian

    lo, hi = box
    dens = (lambda s: 1 / (s * np.log(hi / lo))) if prior == "loguniform" else (lambda s: 1 / (hi - lo))
    peak = np.sqrt(rss / n)

    def log_integrand(s):
        return -0.5 * n * np.log(2 * np.pi * s**2) - rss / (2 * s**2) + np.log(dens(s))

    ref = max(log_integrand(np.clip(peak, lo, hi)), -1e300)

    def mass(upper, epsrel):  # integral from lo to upper, over log sigma, scaled by exp(-ref)
        val, _ = integrate.quad(
            lambda ls: np.exp(log_integrand(np.exp(ls)) - ref) * np.exp(ls),
            np.log(lo),
            np.log(upper),
            points=[np.log(np.clip(peak, lo, upper))],
            epsabs=0,
            epsrel=epsrel,
            limit=200,
        )
        return val

    val = mass(hi, 1e-11)
    got = log_marginal_gaussian(np.array([rss]), n, lo, hi, prior)[0]
    assert got == pytest.approx(ref + np.log(val), abs=1e-8)
    draws = draw_sd(np.full(4000, rss), n, lo, hi, prior, rng=0)

    def cdf(s):
        return mass(s, 1e-10) / val

    grid = np.quantile(draws, np.linspace(0.01, 0.99, 60))
    emp = np.searchsorted(np.sort(draws), grid, side="right") / draws.size
    assert np.max(np.abs(emp - np.array([cdf(s) for s in grid]))) < 1.63 / np.sqrt(draws.size)  # KS 1 %


def test_unknown_noise_sd_integrated_out_gives_the_joint_posterior_and_its_evidence():
    """Linear-Gaussian stand-in with the noise sd sampled (log-uniform box): the runs integrate it out; the
    evidence equals a one-dimensional quadrature over sigma of the closed-form Gaussian integral over x (4 standard
    errors), and the completed sd draws follow sigma's exact marginal posterior (KS p > 0.01 on 1000 of them)."""
    from scipy import integrate

    from bayestissue.inference import GaussianNoise

    problem, _ = linear_gaussian_problem(n_obs=40, n_params=3, sd=0.1, box=20.0, noise=GaussianNoise(), rng=1)
    sample = sample_nested(problem, options=NestedOptions(**SMALL, n_runs=4), rng=8)
    e = problem.experiments[0]
    a, y = np.asarray(e.forward.design), e.observed
    n, p = a.shape
    xhat = np.linalg.lstsq(a, y, rcond=None)[0]
    rss = float(np.sum((y - a @ xhat) ** 2))
    spec = problem.parameters.sampled[-1]
    lo, hi = spec.lower, spec.upper
    logdet = np.linalg.slogdet(a.T @ a)[1]

    def log_joint(s):  # log of p(sigma) * integral over x of L(x, sigma) p(x)
        return (
            -np.log(s * np.log(hi / lo))
            - 0.5 * n * np.log(2 * np.pi * s**2)
            - rss / (2 * s**2)
            + 0.5 * p * np.log(2 * np.pi * s**2)
            - 0.5 * logdet
            - p * np.log(40.0)
        )

    s0 = np.sqrt(rss / (n - p))
    ref = log_joint(s0)
    val, _ = integrate.quad(lambda s: np.exp(log_joint(s) - ref), lo, hi, points=[s0], epsrel=1e-11, limit=200)
    assert abs(sample.log_z - (ref + np.log(val))) < 4 * sample.log_z_err
    sig = sample.flat()[:1000, -1]

    def cdf(x):
        return integrate.quad(lambda s: np.exp(log_joint(s) - ref), lo, x, points=[min(s0, x)], limit=200)[0] / val

    assert stats.kstest(sig, np.vectorize(cdf)).pvalue > 0.01
    assert assess_nested(sample).converged


@pytest.mark.parametrize(
    "nu, t", [(20.0, 5000.0), (204.0, 3000.0), (204.0, 250.0), (1.5, 900.0), (20.0, 1e-40), (204.0, 1.0)]
)
def test_incomplete_gamma_tails_in_log_space(nu, t):
    """log Q (continued fraction) and log P (series) where scipy's values underflow, against quadrature of
    x^(nu-1) e^-x in shifted log space, to 1e-9: the marginal likelihood of a prior draw whose residuals are far
    outside the sd box is finite and ordered (nested sampling needs its rank), not -inf."""
    from scipy import integrate
    from scipy.special import gammaln

    from bayestissue.inference.marginal_noise import _log_lower, _log_upper

    def log_f(x):
        return (nu - 1) * np.log(x) - x

    upper = t > nu
    ref = log_f(t) if upper or t < nu - 1 else log_f(nu - 1)
    lo, hi = (t, np.inf) if upper else (0.0, t)
    val, _ = integrate.quad(lambda x: np.exp(log_f(x) - ref), lo, hi, epsrel=1e-12, limit=500)
    got = (_log_upper if upper else _log_lower)(nu, np.array([t]))[0]
    assert got == pytest.approx(ref + np.log(val) - gammaln(nu), abs=1e-9, rel=1e-12)


def test_exchangeable_groups_are_folded_and_the_evidence_is_that_of_the_restricted_prior():
    """Label-switched modes (2, 1) and (1, 2): the runs sample the whole box, the stored draws are folded (a >= b,
    a near 2), and log Z equals a direct quadrature of the likelihood over the restricted prior (density doubled on
    a >= b) within 4 standard errors."""
    from inference_helpers import exchangeable_problem
    from scipy import integrate

    problem = exchangeable_problem()
    sample = sample_nested(problem, options=NestedOptions(**SMALL, n_runs=4), rng=2)
    flat = sample.flat()
    assert np.all(flat[:, 0] >= flat[:, 1])
    assert abs(np.median(flat[:, 0]) - 2.0) < 0.05 and abs(np.median(flat[:, 1]) - 1.0) < 0.05
    pts, _, _ = sample.weighted()
    assert np.all(pts[:, 0] >= pts[:, 1])
    peak = float(problem.log_likelihood(np.array([2.0, 1.0])))

    def integrand(b, a):  # restricted prior 2 / 16 on a >= b
        return np.exp(float(problem.log_likelihood(np.array([a, b]))) - peak) * 2.0 / 16.0

    val, _ = integrate.dblquad(integrand, 1.7, 2.3, 0.7, 1.3, epsabs=0, epsrel=1e-8)
    assert abs(sample.log_z - (peak + np.log(val))) < 4 * sample.log_z_err
