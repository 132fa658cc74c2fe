"""Ensemble sampling against the closed-form linear-Gaussian posterior; seeds; checkpoint/resume."""

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import emcee
import numpy as np
import pytest
from inference_helpers import two_mode_problem

from bayestissue.inference import (
    GaussianNoise,
    SamplerOptions,
    initial_walkers,
    run_ensemble,
    sample_posterior,
)
from bayestissue.inference.diagnostics import assess_convergence, stuck_walkers
from tests.inference.linear_model import linear_gaussian_posterior, linear_gaussian_problem

ROOT = Path(__file__).resolve().parents[2]


def _matches(draws, ess, mean, cov, k=4.0) -> bool:
    """Posterior mean, variances and correlations equal to the closed form within k MC errors."""
    sd = np.sqrt(np.diag(cov))
    m_ok = np.all(np.abs(draws.mean(axis=0) - mean) < k * sd / np.sqrt(ess))
    v_ok = np.all(np.abs(draws.var(axis=0) / sd**2 - 1) < k * np.sqrt(2 / ess))
    c_true = cov / np.outer(sd, sd)
    c_est = np.corrcoef(draws.T)
    c_ok = np.all(np.abs(c_est - c_true) < k / np.sqrt(ess.min()))
    return bool(m_ok and v_ok and c_ok)


def test_closed_form_posterior_recovered_and_wrong_target_fails():
    problem, _ = linear_gaussian_problem(rng=1)
    mean, cov = linear_gaussian_posterior(problem)
    # tau_rtol relaxed from the default 1 % to keep the test short; 50 tau and R-hat/ESS still apply
    opts = SamplerOptions(n_walkers=8, max_steps=3000, check_every=100, n_processes=2, tau_rtol=0.05, prune_steps=100)
    sample = sample_posterior(problem, mean, cov=cov, options=opts, rng=7)
    report = assess_convergence(sample)
    assert report.converged, report.verdict()
    assert _matches(sample.flat(), report.ess_bulk, mean, cov)
    # negative control: the same machinery on a wrong target (noise sd 30 % too large)
    wrong, _ = linear_gaussian_problem(rng=1, noise=GaussianNoise(sd=0.13))
    opts2 = SamplerOptions(n_walkers=8, max_steps=1000, check_every=100, n_ensembles=2, tau_rtol=0.05, prune_steps=100)
    bad = sample_posterior(wrong, mean, cov=cov, options=opts2, rng=7)
    assert not _matches(bad.flat(), assess_convergence(bad).ess_bulk, mean, cov)


def test_mixture_moves_recover_the_closed_form_posterior():
    """The adaptive independence proposal (fitted during discarded rounds, then frozen) through the
    same path: closed-form mean and covariance within 4 MC errors."""
    problem, _ = linear_gaussian_problem(rng=1)
    mean, cov = linear_gaussian_posterior(problem)
    opts = SamplerOptions(
        n_walkers=8,
        moves="mixture",
        max_steps=3000,
        check_every=100,
        n_processes=2,
        tau_rtol=0.05,
        prune_steps=100,
        adapt_rounds=2,
        adapt_steps=200,
    )
    sample = sample_posterior(problem, mean, cov=cov, options=opts, rng=8)
    report = assess_convergence(sample)
    assert report.converged, report.verdict()
    assert _matches(sample.flat(), report.ess_bulk, mean, cov)


def test_same_seed_same_chain_and_walkers_are_independent():
    problem, _ = linear_gaussian_problem(rng=1)
    mean, cov = linear_gaussian_posterior(problem)
    p0 = initial_walkers(problem, mean, 10, cov=cov, rng=3)
    import emcee

    assert emcee.ensemble.walkers_independent(p0)
    opts = SamplerOptions(n_walkers=10, max_steps=200, check_every=100, prune_rounds=1)
    a = run_ensemble(problem, p0, options=opts, seed=42)
    b = run_ensemble(problem, p0, options=opts, seed=42)
    c = run_ensemble(problem, p0, options=opts, seed=43)
    np.testing.assert_array_equal(a.chain_z, b.chain_z)
    assert not np.array_equal(a.chain_z, c.chain_z)


def test_stuck_walkers_flagged():
    acc = np.array([0.3, 0.28, 0.31, 0.0, 0.29, 0.05])
    assert stuck_walkers(acc).tolist() == [False, False, False, True, False, True]


class _Interrupt(Exception):
    pass


def _opts(moves="de_snooker"):
    return SamplerOptions(
        n_walkers=10,
        max_steps=300,
        check_every=50,
        tau_factor=1e9,
        prune_rounds=1,
        prune_steps=20,
        moves=moves,
        adapt_rounds=2,
        adapt_steps=100,
    )


@pytest.mark.parametrize("moves", ["de_snooker", "mixture"])
def test_resume_after_interruption_gives_the_unbroken_chain(tmp_path, moves):
    """With ``mixture`` the resumed run must propose from the stored (not a refitted) mixture."""
    problem, _ = linear_gaussian_problem(rng=1)
    mean, cov = linear_gaussian_posterior(problem)
    p0 = initial_walkers(problem, mean, 10, cov=cov, rng=3)
    full = run_ensemble(problem, p0, options=_opts(moves), seed=5)

    def stop_at_150(k, n, nmax, phase):
        if phase == "sampling" and n >= 150:
            raise _Interrupt

    path = tmp_path / "chain.h5"
    with pytest.raises(_Interrupt):
        run_ensemble(problem, p0, options=_opts(moves), seed=5, backend_path=path, progress=stop_at_150)
    resumed = run_ensemble(problem, p0, options=_opts(moves), seed=5, backend_path=path, resume=True)
    assert resumed.resumed_at == 150
    np.testing.assert_array_equal(resumed.chain_z, full.chain_z)
    np.testing.assert_array_equal(resumed.log_prob, full.log_prob)


_CHILD = textwrap.dedent(
    """
    import sys
    import numpy as np
    from bayestissue.inference import SamplerOptions, initial_walkers, run_ensemble
    from tests.inference.linear_model import linear_gaussian_posterior, linear_gaussian_problem

    problem, _ = linear_gaussian_problem(rng=1)
    mean, cov = linear_gaussian_posterior(problem)
    p0 = initial_walkers(problem, mean, 10, cov=cov, rng=3)
    opts = SamplerOptions(n_walkers=10, max_steps=100000, check_every=50, tau_factor=1e9,
                          prune_rounds=1, prune_steps=50)
    run_ensemble(problem, p0, options=opts, seed=5, backend_path=sys.argv[1],
                 progress=lambda k, n, m, phase: phase == "sampling" and print(n, flush=True))
    """
)


@pytest.mark.slow
def test_sigkill_and_resume_gives_the_unbroken_chain(tmp_path):
    script = tmp_path / "child.py"
    script.write_text(_CHILD)
    path = tmp_path / "chain.h5"
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", PYTHONPATH=str(ROOT))
    proc = subprocess.Popen([sys.executable, str(script), str(path)], stdout=subprocess.PIPE, text=True, env=env)
    t0 = time.time()
    for line in proc.stdout:
        if int(line) >= 250 or time.time() - t0 > 60:
            break
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    proc.stdout.close()
    assert proc.returncode == -signal.SIGKILL
    problem, _ = linear_gaussian_problem(rng=1)
    mean, cov = linear_gaussian_posterior(problem)
    p0 = initial_walkers(problem, mean, 10, cov=cov, rng=3)
    opts = SamplerOptions(n_walkers=10, max_steps=600, check_every=50, tau_factor=1e9, prune_rounds=1, prune_steps=50)
    resumed = run_ensemble(problem, p0, options=opts, seed=5, backend_path=path, resume=True)
    assert resumed.resumed_at >= 250
    full = run_ensemble(problem, p0, options=opts, seed=5)
    np.testing.assert_array_equal(resumed.chain_z, full.chain_z)


def test_sampler_option_errors():
    with pytest.raises(ValueError, match="moves: expected one of"):
        SamplerOptions(moves="hmc")
    with pytest.raises(ValueError, match="max_steps: expected an integer >= 1"):
        SamplerOptions(max_steps=0)
    with pytest.raises(ValueError, match="n_walkers: expected an integer >= 4"):
        SamplerOptions(n_walkers=2)
    with pytest.raises(ValueError, match="tau_factor: expected a number > 0"):
        SamplerOptions(tau_factor=-1)
    with pytest.raises(ValueError, match=r"proposal: expected one of \['own', 'shared'\]"):
        SamplerOptions(proposal="pooled")
    problem, _ = linear_gaussian_problem(rng=1)
    with pytest.raises(ValueError, match=r"center: expected shape \(3,\)"):
        initial_walkers(problem, np.zeros(2), 8)
    with pytest.raises(ValueError, match=r"p0: expected \(n_walkers, 3\)"):
        run_ensemble(problem, np.zeros((8, 2)))
    dependent = np.outer(np.arange(8.0), np.ones(3))  # all walkers on one line
    with pytest.raises(ValueError, match="initial walkers: expected independent walkers"):
        run_ensemble(problem, dependent, options=SamplerOptions(max_steps=10, prune_rounds=0))


def test_resuming_a_finished_run_adds_no_steps(tmp_path):
    problem, _ = linear_gaussian_problem(rng=1)
    mean, cov = linear_gaussian_posterior(problem)
    p0 = initial_walkers(problem, mean, 10, cov=cov, rng=3)
    opts = SamplerOptions(n_walkers=10, max_steps=5000, check_every=50, tau_factor=5, tau_rtol=0.5, prune_steps=20)
    path = tmp_path / "chain.h5"
    first = run_ensemble(problem, p0, options=opts, seed=5, backend_path=path)
    assert first.converged_length and first.n_steps < 5000
    again = run_ensemble(problem, p0, options=opts, seed=5, backend_path=path, resume=True)
    assert again.n_steps == first.n_steps and again.converged_length


def test_one_centre_per_ensemble():
    problem, _ = linear_gaussian_problem(rng=1)
    mean, cov = linear_gaussian_posterior(problem)
    opts = SamplerOptions(n_walkers=8, max_steps=100, n_ensembles=2, n_processes=1, prune_rounds=0)
    centres = np.array([mean - 0.05, mean + 0.05])
    sample = sample_posterior(problem, centres, cov=[cov, cov], options=opts, rng=1)
    starts = [e.chain_z[0].mean(axis=0) for e in sample.ensembles]
    z = problem.parameters.to_unconstrained(centres)
    assert np.linalg.norm(starts[0] - z[0]) < np.linalg.norm(starts[0] - z[1])
    with pytest.raises(ValueError, match=r"center: expected \(3,\) or \(2, 3\)"):
        sample_posterior(problem, np.zeros((3, 3)), options=opts)
    with pytest.raises(ValueError, match="cov: expected one matrix or 2"):
        sample_posterior(problem, mean, cov=[cov], options=opts)


def test_initial_walkers_next_to_a_failing_region_are_redrawn_around_valid_ones():
    # only z0 < centre - 1.5 sd is valid (6.7 % of draws around the centre): 20 rounds of redrawing
    # around the centre alone leave some of 40 walkers invalid; redrawing near valid walkers succeeds
    problem, _ = linear_gaussian_problem(rng=1)
    mean, cov = linear_gaussian_posterior(problem)
    z_c = problem.coordinates.to_unconstrained(mean[None, :])[0]
    p_scale = initial_walkers(problem, mean, 400, cov=cov, rng=0)[:, 0].std()
    inner = problem.log_posterior_unconstrained

    def lp(z):
        return np.where(z[:, 0] < z_c[0] - 1.5 * p_scale, inner(z), -np.inf)

    problem.log_posterior_unconstrained = lp
    p0 = initial_walkers(problem, mean, 40, cov=cov, rng=2)
    assert np.all(np.isfinite(lp(p0))) and emcee.ensemble.walkers_independent(p0)


def _two_mode_run(proposal, tmp_path=None, max_steps=600, resume=False):
    problem = two_mode_problem()
    opts = SamplerOptions(
        n_walkers=8,
        moves="mixture",
        proposal=proposal,
        max_steps=max_steps,
        min_steps=600,
        check_every=100,
        n_processes=2,
        prune_steps=50,
        adapt_rounds=1,
        adapt_steps=200,
    )
    centres = np.array([[2.0, 0.5], [-2.0, 0.5], [2.0, 0.5], [-2.0, 0.5]])
    return sample_posterior(problem, centres, options=opts, checkpoint=tmp_path, resume=resume, rng=4)


def test_a_shared_proposal_carries_ensembles_between_modes_their_own_cannot():
    """Four ensembles started two and two in the modes of a two-mode posterior (equal masses): with
    their own proposals each stays where it started (R-hat of x0 far above 1.01); with the shared
    one, fitted to all ensembles' adaptation draws, every ensemble spends about half of its draws in
    each mode (binomial sd of the fraction over ~24 independent visits is 0.1, bound 0.5 +- 0.2)."""
    own = _two_mode_run("own")
    frac_own = [np.mean(d[..., 0] > 0) for d in own.draws()]
    assert frac_own == [1.0, 0.0, 1.0, 0.0]
    assert assess_convergence(own).rhat[0] > 1.5
    shared = _two_mode_run("shared")
    frac = [np.mean(d[..., 0] > 0) for d in shared.draws()]
    assert all(0.3 <= f <= 0.7 for f in frac), frac
    rep = assess_convergence(shared)
    assert rep.rhat[0] < 1.05, rep.verdict()
    # the evaluations of the separate preparation (pruning, adaptation) are counted
    assert shared.n_evaluations >= own.n_evaluations - 4 * 8


def test_shared_proposal_resumes_to_the_unbroken_chain(tmp_path):
    """A run stopped at its cap and resumed with a higher cap proposes from the stored shared mixture
    and gives the chain of an unbroken run."""
    full = _two_mode_run("shared", max_steps=800)
    _two_mode_run("shared", tmp_path, max_steps=600)
    resumed = _two_mode_run("shared", tmp_path, max_steps=800, resume=True)
    assert [e.resumed_at for e in resumed.ensembles] == [600] * 4
    for a, b in zip(resumed.ensembles, full.ensembles, strict=True):
        np.testing.assert_array_equal(a.chain_z, b.chain_z)
