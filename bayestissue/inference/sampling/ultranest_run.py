"""One run of the nested engine by UltraNest: classic nested sampling over the batched forward model.

UltraNest (Buchner 2021, JOSS 6, 3001, doi:10.21105/joss.03001) integrates

.. math:: Z = \\int_0^1 L(X)\\, dX, \\qquad X_i \\approx e^{-i/n},

replacing the worst of :math:`n` live points by a new point drawn from the prior inside the contour
:math:`L > L_i`. The new points come from a vectorised population slice sampler
(``ultranest.popstepsampler.PopulationSliceSampler``; ``directions``: along the principal axes of the MLFriends
region, or with equal odds such an axis or the difference of two random live points, UltraNest's mixture, which its
documentation names the best of the step samplers compared by Buchner, arXiv:2211.09426): ``population`` chains
advance together, so every call of :meth:`CalibrationProblem.log_likelihood` is one batch,
and each chain takes ``slice_steps`` slice steps (default :math:`2d`) from a live point before its end point is
accepted. Too few steps leave the new point correlated with its start and bias the run towards the start's
contour; that is what the insertion-order test sees.

**Insertion-order test** (Fowlie, Handley & Su 2020, MNRAS 497, 5256, doi:10.1093/mnras/staa2345; in UltraNest's
form, Buchner 2023, Statistics Surveys 17, 169, sec. 4.5.2): if every new point is a fair draw inside its
contour, its rank among the live points' likelihoods is uniform on :math:`0..n-1`. UltraNest accumulates a
Mann-Whitney-Wilcoxon :math:`z` of the ranks, restarting it whenever :math:`|z| > 4`; an unbiased run restarts
about once in :math:`10^{5.5}` iterations. UltraNest passes a run with up to one restart per :math:`10^{5.5}`
iterations begun, so one alarm in a run of a few thousand iterations passes; here any alarm in a run shorter than
:math:`10^{5.5}` iterations fails it (``insertion_ok`` False; ``insertion_run`` the shortest stretch between
restarts in iterations, infinite when there was none). The test has little power on short runs: on the 3-parameter
linear-Gaussian stand-in (200 live points) one slice step per point raised log Z by 0.75 on average over 4 runs
and only one of them raised an alarm.

The run's log-evidence error is UltraNest's (bootstrap over the live points' shrinkage, plus the remainder); the
weighted points are its dead and final live points, with the replicate weights of that bootstrap (100
replicates), from which :func:`~bayestissue.inference.evidence.quantile_errors` takes each quantile's error.

UltraNest draws from numpy's global random state: the run seeds it and restores it afterwards (same seed, same
run). Its log directory (``checkpoint``) holds the points (``results/points.hdf5``, attribute ``ncalls``); a
resumed run replays them without calling the likelihood, and its calls, failed solves and seconds are those of all
its sessions (:func:`~.checkpoints.earlier_cost`).
A failed forward solve is :math:`\\log L = -10^{100}` (UltraNest refuses non-finite values), counted.

**A stalled run ends with an error.** UltraNest's population slice sampler can stop producing points while it goes
on calling the likelihood (UltraNest issues #166 and #177: the same point evaluated over and over; resuming runs a
little further, then stalls again). Seen here on the tendon relaxation preset with three branches (population 10,
22 steps): no new point after the first 60 iterations and 1.5 M calls in 12 minutes. A run makes at most about
``population * slice_steps`` calls per new point when it works (each walker's steps, a few shrinkages each); after
:data:`STALL_FACTOR` times that many calls without a new point the run raises :class:`SamplerStalled`, naming the
run, the calls and the iteration reached; what it checkpointed is kept.
"""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np
from scipy.special import logsumexp

from bayestissue.inference.sampling.checkpoints import cost_meter, earlier_cost, write_cost

__all__ = ["SamplerStalled", "STALL_FACTOR", "run_ultranest", "slice_steps", "stall_limit"]

#: stand-in for log L = -inf (UltraNest's own choice for non-finite values)
_FLOOR = -1e100
#: UltraNest's bootstrap replicates (its default 30 leaves a quantile error's own error at about 13 %)
_N_BOOT = 100
#: iterations per expected 4-sigma alarm of the insertion test in an unbiased run (Buchner 2023, sec. 4.5.2)
_QUIET_ITERATIONS = 10**5.5


#: calls without a new point, in units of ``population * slice_steps``, after which a run counts as stalled
STALL_FACTOR = 200


class SamplerStalled(RuntimeError):
    """Raised by a run of the UltraNest engine whose step sampler stopped producing points (module docstring)."""


#: :data:`~.nested.SLICE_DIRECTIONS` -> UltraNest's direction generator (``ultranest.stepfuncs``)
_DIRECTIONS = {"region": "generate_region_oriented_direction", "mixture": "generate_mixture_random_direction"}


def slice_steps(options, n_dim: int) -> int:
    """Slice steps of each new point: ``options.slice_steps``, or two per sampled dimension ``n_dim``
    (:func:`~.nested.nested_target`'s: without the noise sds where they are integrated out)."""
    return options.slice_steps or 2 * n_dim


def stall_limit(options, n_dim: int) -> int:
    """Likelihood calls without a new point after which a run has stalled: :data:`STALL_FACTOR` x ``population``
    x :func:`slice_steps`."""
    return STALL_FACTOR * options.population * slice_steps(options, n_dim)


def _counting(step_class):
    """``step_class`` (a population step sampler) counting the points it hands to the integrator (``produced``:
    a step returns ``logl`` None while no walker has finished)."""

    class Counting(step_class):
        produced = 0

        def __next__(self, *args, **kwargs):
            out = super().__next__(*args, **kwargs)
            if out[2] is not None:
                self.produced += 1
            return out

    return Counting


def _own_log() -> None:
    """UltraNest registers its handlers once per process (``ultranest.utils.create_logger``), so a worker's later
    runs would write into its first run's ``debug.log``: close and drop them before each run, so that each run's
    log goes to its own directory."""
    logger = logging.getLogger("ultranest")
    for h in list(logger.handlers):
        logger.removeHandler(h)
        h.close()


def _quiet() -> None:
    """UltraNest logs its progress to stdout; keep its debug file, send only warnings to the terminal."""
    logger = logging.getLogger("ultranest")
    for h in logger.handlers:
        if type(h) is logging.StreamHandler:
            h.setLevel(logging.WARNING)


def run_ultranest(problem, k, seed, options, path, resume, progress, target):
    """Run ``k`` of ``problem`` by UltraNest; ``target`` is :func:`~.nested.nested_target`'s ``(n_dim, prior
    transform, log-likelihood, complete)``. Returns the fields of a :class:`~.nested.NestedRun` as a dict."""
    import ultranest
    from ultranest import popstepsampler

    n_dim, prior, log_l, complete = target
    before = earlier_cost(path, resume)
    cost = cost_meter(before, problem)
    state = {"next": options.report_every, "produced": 0, "calls_at": before.calls}
    limit = stall_limit(options, n_dim)
    step = _counting(popstepsampler.PopulationSliceSampler)(
        popsize=options.population,
        nsteps=slice_steps(options, n_dim),
        generate_direction=getattr(popstepsampler, _DIRECTIONS[options.directions]),
    )

    def like(x):
        ll = np.asarray(log_l(x), dtype=float)
        so_far = cost()
        if step.produced != state["produced"]:
            state["produced"], state["calls_at"] = step.produced, so_far.calls
        elif so_far.calls - state["calls_at"] > limit:
            write_cost(path, so_far)
            raise SamplerStalled(
                f"nested run {k} (UltraNest) stalled: no new point in {so_far.calls - state['calls_at']} likelihood "
                f"calls (limit {STALL_FACTOR} x population {options.population} x {slice_steps(options, n_dim)} "
                f"slice steps) after {step.produced} points from its step sampler, {so_far.calls} calls in all: "
                "UltraNest's population slice sampler is stuck (its issues #166 and #177); use [nested] sampler = "
                '"nautilus" for this problem'
            )
        if so_far.calls >= state["next"]:  # the run's evaluations over all its sessions
            write_cost(path, so_far)
            if progress is not None:
                progress(k, so_far.calls, 0.0, False, float("nan"))
            state["next"] = (so_far.calls // options.report_every + 1) * options.report_every
        return np.where(np.isfinite(ll), ll, _FLOOR)

    def transform(u):
        return prior(np.asarray(u, dtype=float))

    log_dir = None if path is None else str(Path(path).with_suffix(""))
    saved = np.random.get_state()  # noqa: NPY002 (UltraNest draws from the global state)
    np.random.seed(int(seed) % 2**32)  # noqa: NPY002
    _own_log()
    try:
        sampler = ultranest.ReactiveNestedSampler(
            [f"x{j}" for j in range(n_dim)],
            like,
            transform,
            vectorized=True,
            log_dir=log_dir,
            resume="resume" if resume else "overwrite",
            ndraw_max=options.population,
            num_bootstraps=_N_BOOT,
        )
        _quiet()
        sampler.stepsampler = step
        result = sampler.run(
            min_num_live_points=options.n_live,
            frac_remain=options.f_live,
            min_ess=options.n_eff,
            max_ncalls=options.max_evaluations,
            show_status=False,
            viz_callback=False,
        )
    finally:
        np.random.set_state(saved)  # noqa: NPY002
    spent = cost()
    write_cost(path, spent)
    ws = result["weighted_samples"]
    keep = ws["weights"] > 0
    log_w = np.log(ws["weights"][keep])
    boot = np.asarray(ws["bootstrapped_weights"][keep], dtype=float)
    test = result["insertion_order_MWW_test"]
    alarm = bool(np.isfinite(test["independent_iterations"]) and int(result["niter"]) < _QUIET_ITERATIONS)
    cap = options.max_evaluations
    return dict(
        points=complete(np.asarray(ws["points"][keep], dtype=float), rng=np.random.default_rng([seed, 1])),
        log_w=log_w - logsumexp(log_w),
        log_l=np.asarray(ws["logl"][keep], dtype=float),
        log_z=float(result["logz"]),
        n_like=spent.calls,
        n_failed=spent.failed,
        seed=int(seed),
        time_s=spent.seconds,
        n_like_resumed=before.calls,
        finished=bool(cap is None or int(result["ncall"]) < cap),
        reported_log_z_err=float(result["logzerr"]),
        insertion_ok=bool(test["converged"]) and not alarm,
        insertion_run=float(test["independent_iterations"]),
        bootstrap_weights=boot / boot.sum(axis=0),
    )
