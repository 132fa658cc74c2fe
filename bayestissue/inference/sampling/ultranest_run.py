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

**A likelihood plateau above the contour ends the run with an error.** Where many live points share one
log-likelihood exactly (a region where the model does not depend on the sampled parameters, e.g. a fibre whose
recruitment stretch lies beyond the test's largest stretch), UltraNest removes them without replacement (Fowlie,
Handley & Su 2021, MNRAS 503, 1199, arXiv:2010.13884) and carries on with the few points left, and its population
slice sampler stalls: a walker parked on the plateau when the contour rises to it is not stepped back (UltraNest
reverts only points strictly below the contour) and shrinks its slice towards a start that is not inside the
contour, for ever (UltraNest issues #166 and #177; seen on the tendon relaxation preset, population 10: no new point
after 60 iterations and 1.5 M calls). Measured on a 3-parameter Gaussian peak (log Z = 0.316 by quadrature) with 75
% of the unit cube a plateau at log L = -100, above most of the peak's tails: UltraNest (population 10, 6 steps)
stalled on one seed of two with 200 live points; with the stepping back mended it finished, 3 runs of 400 live
points giving log Z 0.80 to 1.71 (own errors 0.44 to 0.52), 0.5-1.4 nats high; with the plateau at the lowest value
(UltraNest's own plateau handling) 0.21 +- 0.12 and 0.58 +- 0.17; nautilus 0.306 and 0.309. So a run whose live
points tie above the contour raises :class:`LikelihoodPlateau` at the first step that sees them (usually the first),
naming the value and the count: use nautilus there, or a prior box that excludes the plateau. Ties at the contour
itself (the initial plateau of failed solves, which UltraNest handles by widening its first live points) are
allowed.

**A stalled run ends with an error.** Should the step sampler stop producing points for another reason, a run
that makes about ``population * slice_steps`` calls per new point when it works raises :class:`SamplerStalled`
after :data:`STALL_FACTOR` times that many calls without a new point, naming the run, the calls and the points
produced so far; what it checkpointed is kept.
"""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np
from scipy.special import logsumexp

from bayestissue.inference.sampling.checkpoints import cost_meter, earlier_cost, write_cost

__all__ = ["LikelihoodPlateau", "SamplerStalled", "STALL_FACTOR", "run_ultranest", "slice_steps", "stall_limit"]

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


class LikelihoodPlateau(RuntimeError):
    """Raised by a run of the UltraNest engine whose live points share one log-likelihood above the contour
    (module docstring)."""


def plateau_above(log_l: np.ndarray, contour: float) -> tuple[float, int] | None:
    """The lowest log-likelihood that at least two of the live points ``log_l`` share exactly above ``contour``,
    and how many share it; None when no two tie there."""
    values, counts = np.unique(log_l[log_l > contour], return_counts=True)
    tied = np.flatnonzero(counts > 1)
    return None if tied.size == 0 else (float(values[tied[0]]), int(counts[tied[0]]))


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


def _watched(step_class):
    """``step_class`` (a population step sampler) that refuses a plateau above the contour (:func:`plateau_above`,
    as ``plateau``: value, count, live points, contour) and counts the points it hands to the integrator
    (``produced``: a step returns ``logl`` None while no walker has finished)."""

    class Watched(step_class):
        produced = 0
        plateau = None

        def __next__(self, region, Lmin, us, Ls, *args, **kwargs):
            tie = plateau_above(np.asarray(Ls), Lmin)
            if tie is not None:
                self.plateau = (*tie, len(Ls), float(Lmin))
                raise LikelihoodPlateau(self.plateau)
            out = super().__next__(region, Lmin, us, Ls, *args, **kwargs)
            if out[2] is not None:
                self.produced += 1
            return out

    return Watched


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
    step = _watched(popstepsampler.PopulationSliceSampler)(
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
    except LikelihoodPlateau:
        write_cost(path, cost())
        value, count, n_live, contour = step.plateau
        raise LikelihoodPlateau(
            f"nested run {k} (UltraNest): {count} of its {n_live} live points share log L = {value:.6g} exactly, "
            f"above the contour {contour:.6g}: the likelihood has a plateau (parameters on which the model does not "
            "depend there), where UltraNest's evidence is biased and its slice sampler stalls; use [nested] "
            'sampler = "nautilus" for this problem, or a prior box that leaves the plateau out'
        ) from None
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
