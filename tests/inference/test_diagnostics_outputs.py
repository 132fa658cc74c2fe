"""Diagnostics (R-hat between ensembles, ESS), InferenceData/NetCDF with provenance, summary, config."""

from dataclasses import replace

import numpy as np
import pytest

from bayestissue._validation import ValidationError
from bayestissue.inference import SamplerOptions, sample_posterior
from bayestissue.inference.diagnostics import (
    ConvergenceReport,
    ensembles_apart,
    ess_walkers,
    import_arviz,
    rhat_ensembles,
    runs_mean_error,
)
from bayestissue.inference.posterior import to_inference_data
from bayestissue.inference.summary import generating_fit, summary_table, table_markdown
from bayestissue.inference.warmstart import fit_least_squares
from bayestissue.io.results import (
    file_sha256,
    provenance,
    read_config,
    read_inference_data,
    write_inference_data,
)
from bayestissue.workflows import load_config
from tests.inference.linear_model import linear_gaussian_posterior, linear_gaussian_problem


def test_rhat_between_ensembles_detects_a_shifted_ensemble():
    rng = np.random.default_rng(0)
    draws = rng.standard_normal((4, 200, 10, 2))
    assert np.all(rhat_ensembles(draws) < 1.01)
    shifted = draws.copy()
    shifted[0] += 0.5
    assert np.all(rhat_ensembles(shifted) > 1.01)  # fails the verdict
    ess = ess_walkers(draws)
    assert np.all(ess > 0.7 * 8000)
    with pytest.raises(ValueError, match="draws: expected shape"):
        rhat_ensembles(draws[:1])


def test_ensembles_apart_tells_a_second_mode_from_a_stuck_ensemble():
    """Two modes of a bimodal target: ensemble 2 samples the other mode. Equal log-posterior -> a
    separate mode of similar height; log-posterior 30 lower -> a lower mode. Parameter 1 is shared by
    both modes and must not be named; agreeing ensembles give nothing."""
    rng = np.random.default_rng(1)
    draws = rng.standard_normal((4, 100, 8, 2))
    lp = -0.5 * np.sum(draws**2, axis=-1)
    assert ensembles_apart(draws, lp) == []
    draws[2, :, :, 0] += 6.0
    (e, idx, dlp), *rest = ensembles_apart(draws, lp)
    assert (e, idx, rest) == (2, [0], [])
    assert abs(dlp) < 1.0
    lower = lp.copy()
    lower[2] -= 30.0
    (_, _, dlp_low), *_ = ensembles_apart(draws, lower)
    assert dlp_low == pytest.approx(dlp - 30.0)
    report = ConvergenceReport(
        names=("a", "b"),
        rhat=rhat_ensembles(draws),
        ess_bulk=np.full(2, 1e4),
        ess_tail=np.full(2, 1e4),
        tau=np.ones((4, 2)),
        n_steps=np.full(4, 100),
        length_ok=np.ones(4, bool),
        acceptance=np.full((4, 8), 0.3),
        stuck=np.zeros((4, 8), bool),
        n_draws=3200,
        rhat_max=1.01,
        ess_min=400.0,
        tau_factor=50.0,
        time_s=1.0,
        apart=tuple(ensembles_apart(draws, lower)),
    )
    text = report.verdict()
    assert text.startswith("NOT CONVERGED") and "ensemble 2 apart from the others in ['a']" in text
    assert "lower mode it is stuck in" in text
    same = replace(report, apart=tuple(ensembles_apart(draws, lp))).verdict()
    assert "a region as high as theirs" in same and "lower mode" not in same
    higher = lp.copy()
    higher[2] += 30.0  # the lone ensemble found a higher region: not "within 2" of the others
    text = replace(report, apart=tuple(ensembles_apart(draws, higher))).verdict()
    assert "above theirs: a higher region the others have not reached" in text and "within 2" not in text
    with pytest.raises(ValueError, match="log_prob"):
        ensembles_apart(draws, lp[:, :, :4])


@pytest.fixture(scope="module")
def small_run():
    problem, truth = linear_gaussian_problem(rng=1)
    mean, cov = linear_gaussian_posterior(problem)
    ls = fit_least_squares(problem)
    opts = SamplerOptions(n_walkers=8, max_steps=400, check_every=100, prune_steps=50)
    sample = sample_posterior(problem, ls.x, cov=ls.cov, options=opts, rng=3)
    return problem, truth, ls, sample


def test_inference_data_round_trip_with_provenance(small_run, tmp_path):
    problem, truth, ls, sample = small_run
    cfg = tmp_path / "cfg.toml"
    cfg.write_text('[sampler]\nseed = 3\n[likelihood]\nnoise = "gaussian"\n')
    data = tmp_path / "data.csv"
    data.write_text("time_s,displacement_mm\n0,0\n")
    attrs = provenance(seed=3, config_path=cfg, data_paths=[data])
    idata = to_inference_data(sample, least_squares=ls, attrs=attrs, max_draws=600, rng=0)
    assert set(idata.groups()) >= {
        "posterior",
        "sample_stats",
        "log_likelihood",
        "posterior_predictive",
        "observed_data",
        "constant_data",
    }
    n_chain = idata.posterior.sizes["chain"]
    assert n_chain == 4 * 8 and n_chain * idata.posterior.sizes["draw"] <= 600
    assert idata.log_likelihood["E1"].shape[-1] == 40
    path = write_inference_data(idata, tmp_path / "post.nc")
    back = read_inference_data(path)
    assert back.posterior.attrs["config_sha256"] == file_sha256(cfg)
    assert back.posterior.attrs[f"data_sha256:{data.name}"] == file_sha256(data)
    assert back.posterior.attrs["seed"] == 3
    assert "bayestissue_version" in back.posterior.attrs
    np.testing.assert_allclose(back.posterior["x0"].values, idata.posterior["x0"].values)
    np.testing.assert_allclose(back.constant_data["least_squares_estimate"].values, ls.x)
    az = import_arviz()
    loo = az.loo(back)
    assert np.isfinite(loo.elpd_loo)


def test_summary_flags(small_run):
    problem, truth, ls, sample = small_run
    table = summary_table(problem, ls, sample, None, references={"E1": {"generating": truth}})
    cols = table["columns"]
    assert list(cols["parameter"]) == ["x0", "x1", "x2"]
    np.testing.assert_allclose(cols["generating"], truth)
    assert np.all(cols["contraction"] > 0.99)
    assert all(f == "-" for f in cols["flags"])
    # a least-squares estimate far from the posterior is flagged
    moved = type(ls)(**{**ls.__dict__, "x": ls.x + 1.0})
    flagged = summary_table(problem, moved, sample, None)["columns"]["flags"]
    assert all("ls_outside_90" in f for f in flagged)
    md = table_markdown(table, title="t")
    assert md.startswith("# t") and "| x0 |" in md
    # the failed forward solves are reported, not only counted (issue 36)
    n_f, n_e = sample.n_failed, sample.n_evaluations
    assert n_e > 0 and table["meta"]["failed_forward_solves"].startswith(f"{n_f} of {n_e} evaluations")


def test_config_errors(tmp_path):
    assert read_config(None) == {}
    with pytest.raises(FileNotFoundError, match="configuration file"):
        read_config(tmp_path / "missing.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("[sampler\nseed = 1\n")
    with pytest.raises(ValueError, match="configuration bad.toml: expected valid TOML"):
        read_config(bad)
    unknown = tmp_path / "unknown.toml"
    unknown.write_text("[mcmc]\nseed = 1\n")
    assert read_config(unknown) == {"mcmc": {"seed": 1}}  # plain data; the schema is the workflow's
    with pytest.raises(ValueError, match=r"configuration unknown.toml section: expected one of \['parameters', 'likel"):
        load_config(unknown)
    typo = tmp_path / "typo.toml"
    typo.write_text("[sampler]\nmax_step = 10\n")
    with pytest.raises(ValueError, match=r"configuration typo.toml \[sampler\] key: expected one of \['seed'"):
        load_config(typo)


def test_generating_fit_places_the_truth_among_the_draws_and_a_moved_truth_below(small_run):
    """Linear-Gaussian stand-in: the generating values are a typical posterior draw (flat prior), so their
    log-likelihood lies inside the draws' range; moved by 5 posterior sd along every axis they fit far
    worse than every draw (negative control). The draws' log-likelihood is the pointwise group summed,
    checked against the problem's own log-likelihood of the stored draws."""
    problem, truth, ls, sample = small_run
    idata = to_inference_data(sample, least_squares=ls, max_draws=600, rng=0)
    fit = generating_fit(problem, idata, truth)
    assert fit["q05"] <= fit["log_lik"] <= fit["max"] and 0.05 < fit["share_below"] < 0.95
    draws = np.stack([idata.posterior[n].values for n in problem.names], axis=-1).reshape(-1, problem.ndim)
    ll = problem.log_likelihood(draws)
    np.testing.assert_allclose([np.percentile(ll, 5), ll.max()], [fit["q05"], fit["max"]], rtol=0, atol=1e-9)
    sd = draws.std(axis=0)
    moved = generating_fit(problem, idata, truth + 5.0 * sd)
    assert moved["share_below"] == 0.0 and moved["log_lik"] < fit["q05"] - 20.0
    with pytest.raises(ValidationError, match="theta: expected 3 values"):
        generating_fit(problem, idata, truth[:2])


def test_quantile_mcse_of_independent_normal_draws():
    """For independent N(0, 1) draws with ESS n the error of the p quantile tends to sqrt(p(1-p)/n) / phi(z_p)
    (2.113 / sqrt(n) at 5 and 95 %, 1.253 / sqrt(n) at the median); from 200 000 draws within 6 % (the inverse CDF
    read off the draws over +-sigma_p); an ESS 4 times smaller doubles it."""
    from scipy.stats import norm

    from bayestissue.inference.diagnostics import quantile_mcse

    x = np.random.default_rng(3).normal(size=(200_000, 2))
    n = np.array([4000.0, 1000.0])
    got = quantile_mcse(x, n, n)
    expect = np.array([np.sqrt(p * (1 - p)) / norm.pdf(norm.ppf(p)) for p in (0.05, 0.5, 0.95)])
    np.testing.assert_allclose(got * np.sqrt(n)[:, None], np.tile(expect, (2, 1)), rtol=0.06)


def test_runs_mean_error_takes_the_own_errors_or_the_scatter_whichever_is_larger():
    """sqrt(sum sigma_k^2) / n where the runs agree (4 runs of error 0.2 within 0.01: 0.1), s / sqrt(n) where they
    scatter (values 0, 1, 2, 3: s = 1.291, / 2 = 0.645); per column for quantile arrays; one run: its own error."""
    assert runs_mean_error([1.0, 1.01, 0.99, 1.0], [0.2] * 4) == pytest.approx(0.1)
    assert runs_mean_error([0.0, 1.0, 2.0, 3.0], [0.2] * 4) == pytest.approx(np.sqrt(5.0 / 3.0) / 2.0)
    both = runs_mean_error(np.array([[1.0, 0.0], [1.01, 1.0], [0.99, 2.0], [1.0, 3.0]]), np.full((4, 2), 0.2))
    np.testing.assert_allclose(both, [0.1, np.sqrt(5.0 / 3.0) / 2.0])
    assert runs_mean_error([5.0], [0.3]) == pytest.approx(0.3)
