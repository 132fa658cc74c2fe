"""The nested engine: independent nautilus runs of one posterior, with the evidence.

nautilus (Lange 2023, MNRAS 525, 3181, "nautilus: boosting Bayesian importance nested sampling with deep
learning") estimates the evidence

.. math:: Z = \\int L(\\theta)\\, \\pi(\\theta)\\, d\\theta

and the posterior :math:`L\\pi/Z` by importance sampling from nested shells of the prior whose boundaries
neural-network emulators of the likelihood's rank learn: a run returns points :math:`\\theta_i` with importance
weights :math:`w_i \\propto V_i L(\\theta_i)` (:math:`V_i` the volume of its shell over the points drawn in it) and
:math:`\\hat Z = \\sum_i w_i`. Curved ridges and separate modes cost it no more than a round posterior does, which
is what the paper's 11-parameter posterior needs (two label-switched modes, a thin curved ridge in each).

The prior is the problem's box prior exactly: the unit cube maps to the box by each parameter's inverse CDF
(:meth:`~bayestissue.inference.parameters.ParameterSet.from_prior_quantiles`; uniform and log-uniform boxes as
on the emcee path). The likelihood is the batched :meth:`CalibrationProblem.log_likelihood` (nautilus's
vectorised interface passes ``n_batch`` points at once); a failed forward solve is :math:`L = 0`, counted.

With ``exchangeable`` parameter groups (the problem's prior keeps the first group's leading parameter the
larger, density doubled) the runs sample the whole box, where the likelihood has both label-switched copies of
every mode, and the draws are folded afterwards (:meth:`CalibrationProblem.canonical`). The evidence is the same:
with a symmetric likelihood, :math:`\\int_{\\text{half}} L\\, 2\\pi = \\int L \\pi`. A law's ordered label groups (Ogden
terms, Prony branches: :class:`~bayestissue.inference.ordering.OrderedGroup`) are different: the prior transform
maps the cube onto the ordered region itself (order statistics), so the runs see one labelling, not ``n!`` copies.

Unknown Gaussian noise sds are integrated out analytically by default (:mod:`bayestissue.inference.marginal_noise`):
the runs sample the material parameters under the marginal likelihood (same evidence), and each point's sd is
drawn from its conditional posterior afterwards. Measured on the T1 mirror model: with the sd sampled, one of two
runs' bounds cut the sd's posterior at 0.0200 mm (its lower side, where the likelihood is higher), R-hat 1.64.

``NestedOptions.sampler = "ultranest"`` runs UltraNest instead (classic nested sampling, a population slice
sampler over batches of the forward model, and the insertion-order test of each run:
:mod:`~bayestissue.inference.sampling.ultranest_run`); the runs, their merging and the verdict are the same.

Runs go to forked processes (:mod:`~bayestissue.inference.sampling.processes`), each checkpointed in its own
nautilus HDF5 file (or UltraNest directory) and resumable; diagnostics in :mod:`bayestissue.inference.evidence`.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.special import logsumexp

from bayestissue._validation import ValidationError
from bayestissue.inference.diagnostics import runs_mean_error
from bayestissue.inference.marginal_noise import MarginalNoise, can_marginalise
from bayestissue.inference.problem import CalibrationProblem
from bayestissue.inference.sampling.checkpoints import checkpoint_path, cost_meter, earlier_cost, write_cost
from bayestissue.inference.sampling.cluster import check_scheduler, run_runs

__all__ = [
    "SLICE_DIRECTIONS",
    "SAMPLERS",
    "NestedOptions",
    "NestedRun",
    "NestedSample",
    "RunPhases",
    "nested_target",
    "sample_nested",
]


#: the nested engine's samplers (:attr:`NestedOptions.sampler`)
SAMPLERS = ("nautilus", "ultranest")
#: UltraNest's slice directions (:mod:`~bayestissue.inference.sampling.ultranest_run`): along the principal axes of
#: the live points' region, or half of them along the difference of two random live points (differential evolution)
SLICE_DIRECTIONS = ("region", "mixture")


class RunPhases:
    """Where the runs are, from the arguments of :func:`sample_nested`'s ``progress`` callback: the evaluations of
    all runs and each run's phase, as the CLI's bar and the emcee cross-check both show them."""

    def __init__(self, n_eff: int):
        self.n_eff = n_eff
        self._runs: dict[int, tuple[int, float, bool]] = {}

    def update(self, k: int, n_like: int, n_eff: float, explored: bool) -> None:
        self._runs[k] = (int(n_like), float(n_eff), bool(explored))

    @property
    def evaluations(self) -> int:
        return sum(r[0] for r in self._runs.values())

    def text(self) -> str:
        """``run 0 exploring, run 1 n_eff 120/1000``"""
        runs = sorted(self._runs.items())
        return ", ".join(f"run {k} " + (f"n_eff {e:.0f}/{self.n_eff}" if x else "exploring") for k, (_, e, x) in runs)


def _count(name, v, low):
    if not (isinstance(v, int | np.integer) and not isinstance(v, bool) and v >= low):
        raise ValidationError(name, v, f"an integer >= {low}")


@dataclass(frozen=True)
class NestedOptions:
    """Options of the nested engine (validated on construction).

    Parameters
    ----------
    n_live : nautilus live points (the points a new shell's bound must enclose); more resolve smaller modes.
    n_eff : importance effective sample size each run samples up to after the exploration.
    n_runs : independent runs (different seeds; >= 2 for the between-run R-hat and evidence spread).
    n_processes : parallel processes (default ``min(n_runs, cores)``); with ``scheduler = "local"`` the
        LocalCluster's workers.
    scheduler : where the runs go: None (forked processes of this machine), ``"local"`` (dask tasks on a
        LocalCluster started for the call) or a dask scheduler's address (``"tcp://host:8786"``: a cluster's
        workers, docs/cluster.md); :mod:`~bayestissue.inference.sampling.cluster`. The runs are the same either way.
    n_networks : neural networks per bound (nautilus default 4; their training dominates the cost of a cheap
        likelihood).
    network_tol : a network's training stops when its loss has improved by less than this for 10 epochs in a row
        (scikit-learn's ``MLPRegressor`` ``tol``; 0, nautilus's default, trains until the loss stops improving at
        all). The networks only shape the bound a shell is sampled from, whose volume nautilus measures by sampling,
        so a looser tolerance costs efficiency, not correctness. On the tendon preset's two-branch relaxation (8 sampled
        parameters, 500 live points) two runs at 1e-4 gave log Z -537.64 and -537.54 (four at 0: -537.64 to
        -537.44); one run at each tolerance side by side made 130 000 (1e-4) and 85 000 (0) calls in the same
        630 s (examples/README.md).
    f_live : the exploration ends when the live set holds less than this share of the evidence.
    max_evaluations : likelihood evaluations per run at most (None: no cap); a capped run is reported as such.
    report_every : likelihood evaluations between progress reports (nautilus writes its checkpoint file itself,
        after every batch of evaluations and every new bound).
    marginalise_noise : integrate every sampled Gaussian noise sd out analytically and sample the material
        parameters alone (:mod:`bayestissue.inference.marginal_noise`; exact, same evidence); each point's sd is then
        drawn from its conditional posterior. Ignored for other noise models.
    sampler : ``"nautilus"`` (importance nested sampling, this module) or ``"ultranest"`` (classic nested sampling
        with a population slice sampler over batches and the insertion-order test,
        :mod:`~bayestissue.inference.sampling.ultranest_run`). ``n_networks``, ``network_tol`` and
        ``discard_exploration`` are nautilus's; ``slice_steps`` and ``population`` UltraNest's; ``f_live`` is
        UltraNest's ``frac_remain`` and ``n_eff`` its ``min_ess``.
    slice_steps : slice steps of each new point (UltraNest; None: two per sampled dimension).
    directions : UltraNest's slice directions (:data:`SLICE_DIRECTIONS`): ``"region"``, the principal axes of the live
        points' region, or ``"mixture"``, each step drawing with equal odds a region axis or the difference of two
        random live points (which carries new points between distant parts of a ridge; arXiv:2211.09426).
    population : chains advanced together, i.e. points per likelihood batch (UltraNest).
    discard_exploration : drop the points of the exploration phase from the posterior and the evidence
        (unbiased; costs more evaluations, but no network training). On the linear-Gaussian stand-in (3
        parameters, 200 live points, 4 runs) the evidence was 0.034 below the closed form with them (about 3
        standard errors) and 0.002 without them.
    """

    n_live: int = 1000
    n_eff: int = 1000
    n_runs: int = 4
    n_processes: int | None = None
    n_networks: int = 4
    network_tol: float = 0.0
    f_live: float = 0.01
    max_evaluations: int | None = None
    report_every: int = 5000
    marginalise_noise: bool = True
    discard_exploration: bool = True
    sampler: str = "nautilus"
    slice_steps: int | None = None
    directions: str = "region"
    population: int = 100
    scheduler: str | None = None

    def __post_init__(self):
        check_scheduler(self.scheduler)
        for name, low in (("n_live", 10), ("n_eff", 1), ("n_runs", 1), ("n_networks", 1), ("report_every", 1),
                          ("population", 1)):  # fmt: skip
            _count(name, getattr(self, name), low)
        if self.sampler not in SAMPLERS:
            raise ValidationError("sampler", self.sampler, " or ".join(f'"{s}"' for s in SAMPLERS))
        if self.directions not in SLICE_DIRECTIONS:
            raise ValidationError("directions", self.directions, " or ".join(f'"{s}"' for s in SLICE_DIRECTIONS))
        for name in ("n_processes", "slice_steps"):
            if getattr(self, name) is not None:
                _count(name, getattr(self, name), 1)
        if self.max_evaluations is not None:
            _count("max_evaluations", self.max_evaluations, 1)
        if isinstance(self.network_tol, bool) or not (
            isinstance(self.network_tol, float | int) and 0.0 <= self.network_tol <= 0.1
        ):
            raise ValidationError("network_tol", self.network_tol, "a number in [0, 0.1]")
        if isinstance(self.f_live, bool) or not (isinstance(self.f_live, float | int) and 0.0 < self.f_live < 1.0):
            raise ValidationError("f_live", self.f_live, "a number in (0, 1)")
        for name in ("discard_exploration", "marginalise_noise"):
            if not isinstance(getattr(self, name), bool):
                raise ValidationError(name, getattr(self, name), "true or false")


@dataclass
class NestedRun:
    """One nested run: weighted points in natural units (not folded), the evidence and the cost; UltraNest runs
    also carry their own log-evidence error and the insertion-order test (None for nautilus runs)."""

    points: np.ndarray  # (n, ndim)
    log_w: np.ndarray  # (n,) normalised: logsumexp(log_w) == 0
    log_l: np.ndarray  # (n,) the sampled likelihood: with the noise sds integrated out where the run did that
    log_z: float
    n_like: int  # likelihood evaluations of all the run's sessions (a resumed run's included)
    n_failed: int
    seed: int
    time_s: float  # seconds of all its sessions; NaN where a session's were not recorded
    finished: bool
    reported_log_z_err: float | None = None
    insertion_ok: bool | None = None
    insertion_run: float | None = None  # shortest stretch of iterations between insertion-test alarms
    #: (n, B) replicate weights of the run's own bootstrap (UltraNest), for the quantiles' errors
    bootstrap_weights: np.ndarray | None = field(default=None, repr=False)
    #: the evaluations stored in the checkpoint it resumed from (0: a fresh run; :func:`~.checkpoints.earlier_cost`)
    n_like_resumed: int = 0

    @property
    def weights(self) -> np.ndarray:
        return np.exp(self.log_w)

    @property
    def n_eff(self) -> float:
        """Kish's effective sample size of the importance weights, :math:`(\\sum w)^2 / \\sum w^2`."""
        return float(1.0 / np.sum(self.weights**2))

    @property
    def log_z_err(self) -> float:
        """Standard error of :math:`\\log\\hat Z` from the weights alone: for an importance-sampling mean
        :math:`\\hat Z`, :math:`\\operatorname{Var}(\\hat Z)/Z^2 \\approx 1/n_\\text{eff} - 1/n` (delta method, Kish's
        :math:`n_\\text{eff}`). It leaves out the shells' volume errors; the spread across runs checks it. An
        UltraNest run reports its own (the live points' shrinkage), which is used instead."""
        if self.reported_log_z_err is not None:
            return self.reported_log_z_err
        return float(np.sqrt(max(1.0 / self.n_eff - 1.0 / self.log_w.size, 0.0)))


@dataclass
class NestedSample:
    """Independent nested runs of one posterior, with the parameter layout."""

    names: tuple[str, ...]
    runs: list[NestedRun]
    problem: CalibrationProblem = field(repr=False)
    time_s: float = 0.0
    seeds: list[int] | None = None
    #: seed of the equal-weight resampling (same seed, same draws)
    draw_seed: int = 0
    sampler: str = "nautilus"

    @property
    def n_failed(self) -> int:
        return sum(r.n_failed for r in self.runs)

    @property
    def n_evaluations(self) -> int:
        return sum(r.n_like for r in self.runs)

    @property
    def log_z(self) -> float:
        """Mean of the runs' :math:`\\log\\hat Z`."""
        return float(np.mean([r.log_z for r in self.runs]))

    @property
    def log_z_err(self) -> float:
        """Error of :attr:`log_z`: the larger of the runs' scatter over :math:`\\sqrt{n}` and their own errors
        combined, :math:`\\sqrt{\\sum_k \\sigma_k^2}/n`."""
        return float(runs_mean_error([r.log_z for r in self.runs], [r.log_z_err for r in self.runs]))

    def insertion_tests(self) -> tuple[np.ndarray, np.ndarray] | None:
        """Each run's insertion-order test ``(passed, shortest alarm-free stretch in iterations)``; None unless every
        run has one (UltraNest runs)."""
        if any(r.insertion_ok is None for r in self.runs):
            return None
        return np.array([r.insertion_ok for r in self.runs]), np.array([r.insertion_run for r in self.runs], float)

    def n_draws_per_run(self) -> int:
        """Equal-weight draws per run: the smallest run's :math:`n_\\text{eff}` (at least 100, at most 4000)."""
        return int(np.clip(min(r.n_eff for r in self.runs), 100, 4000))

    def draws(self) -> np.ndarray:
        """Equal-weight draws ``(n_runs, n_draws, ndim)`` (natural units, folded, in random order): systematic
        resampling of each run's weighted points, seeded by :attr:`draw_seed`."""
        if getattr(self, "_draws", None) is None:
            rng = np.random.default_rng(self.draw_seed)
            n = self.n_draws_per_run()
            out = []
            for r in self.runs:
                u = (rng.random() + np.arange(n)) / n
                idx = np.minimum(np.searchsorted(np.cumsum(r.weights), u), r.log_w.size - 1)
                out.append(r.points[rng.permutation(idx)])
            stacked = np.stack(out)
            self._draws = self.problem.canonical(stacked.reshape(-1, stacked.shape[-1])).reshape(stacked.shape)
        return self._draws

    def flat(self) -> np.ndarray:
        """All equal-weight draws as ``(n, ndim)`` natural units."""
        d = self.draws()
        return d.reshape(-1, d.shape[-1])

    def weighted(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Every run's weighted points pooled (folded): points ``(n, ndim)``, weights summing to one (each run
        weighing ``1/n_runs``), and the run of each point."""
        pts = self.problem.canonical(np.concatenate([r.points for r in self.runs]))
        w = np.concatenate([r.weights / len(self.runs) for r in self.runs])
        run = np.concatenate([np.full(r.log_w.size, k) for k, r in enumerate(self.runs)])
        return pts, w, run


def nested_target(problem: CalibrationProblem, options: NestedOptions):
    """What a run samples: ``(n_dim, prior transform, log-likelihood, complete)``. With the noise sds integrated
    out (``options.marginalise_noise`` and only Gaussian sds among the nuisance parameters) the runs see the
    ``n_material`` sampled material parameters and the marginal likelihood, and ``complete(points, rng)`` draws the
    sds; otherwise all of ``theta`` and ``complete`` is the identity. nautilus needs two dimensions at least: a
    problem with one material parameter keeps its sds sampled."""
    if options.marginalise_noise and can_marginalise(problem) and problem.n_material >= 2:
        marginal = MarginalNoise(problem)
        return problem.n_material, problem.material.from_prior_quantiles, marginal.log_likelihood, marginal.complete

    def log_l(x):
        ll = np.asarray(problem.log_likelihood(np.atleast_2d(x)), dtype=float)
        return np.where(np.isfinite(ll), ll, -np.inf)

    def identity(x, rng=None):
        return np.asarray(x, dtype=float)

    return problem.ndim, problem.parameters.from_prior_quantiles, log_l, identity


def _run(problem, k, seed, options: NestedOptions, path, resume, progress) -> NestedRun:
    """Run ``k``: a nautilus sampler driven in chunks of ``report_every`` evaluations (progress after each), or
    an UltraNest run (:func:`~bayestissue.inference.sampling.ultranest_run.run_ultranest`)."""
    if options.sampler == "ultranest":
        from bayestissue.inference.sampling.ultranest_run import run_ultranest

        target = nested_target(problem, options)
        return NestedRun(**run_ultranest(problem, k, seed, options, path, resume, progress, target))
    from nautilus import Sampler

    before = earlier_cost(path, resume)
    cost = cost_meter(before, problem)
    if path is not None and not resume and Path(path).exists():
        Path(path).unlink()
    n_dim, prior, log_l, complete = nested_target(problem, options)
    sampler = Sampler(
        prior,
        log_l,
        n_dim=n_dim,
        n_live=options.n_live,
        n_networks=options.n_networks,
        neural_network_kwargs={"tol": float(options.network_tol)} if options.network_tol else {},
        vectorized=True,
        seed=int(seed),
        filepath=None if path is None else str(path),
        resume=bool(resume),
    )
    cap = np.inf if options.max_evaluations is None else options.max_evaluations
    finished = False
    while not finished and sampler.n_like < cap:
        finished = sampler.run(
            f_live=options.f_live,
            n_eff=options.n_eff,
            n_like_max=min(sampler.n_like + options.report_every, cap),
            discard_exploration=options.discard_exploration,
        )
        write_cost(path, cost())
        if progress is not None:  # nautilus has no log Z right after it discards the exploration phase: NaN then
            log_z = float("nan") if sampler.log_z is None else float(sampler.log_z)
            progress(k, int(sampler.n_like), float(sampler.n_eff), bool(sampler.explored), log_z)
    # the run's cost over all its sessions, before completing the points (that is not the run's work)
    spent = cost()
    write_cost(path, spent)
    points, log_w, log_l = sampler.posterior()
    log_w = np.asarray(log_w, dtype=float)
    return NestedRun(
        points=complete(points, rng=np.random.default_rng([seed, 1])),
        log_w=log_w - logsumexp(log_w),
        log_l=np.asarray(log_l, dtype=float),
        log_z=float(sampler.log_z),
        n_like=spent.calls,
        n_failed=spent.failed,
        seed=int(seed),
        time_s=spent.seconds,
        finished=bool(finished),
        n_like_resumed=before.calls,
    )


def sample_nested(
    problem: CalibrationProblem,
    *,
    options: NestedOptions = NestedOptions(),
    checkpoint: str | Path | None = None,
    resume: bool = False,
    progress: Callable | None = None,
    rng=None,
) -> NestedSample:
    """Run ``options.n_runs`` independent nested runs (nautilus or UltraNest: ``options.sampler``), in parallel
    processes where cores allow, or as dask tasks (``options.scheduler``).

    Parameters
    ----------
    problem : CalibrationProblem (its box prior and batched log-likelihood; no starting point needed).
    options : NestedOptions
    checkpoint : directory for the runs' nautilus files (``nested_<k>.h5``) or UltraNest directories
        (``nested_<k>/``); none without it.
    resume : continue the runs stored in ``checkpoint`` (each sampler reads its own files); otherwise they are
        replaced.
    progress : ``progress(run, n_evaluations, n_eff, explored, log_z)``, called in this process after every
        ``options.report_every`` evaluations of a run.
    rng : seed or Generator (the runs' seeds and the equal-weight resampling).
    """
    rng = np.random.default_rng(rng)
    seeds = [int(s) for s in rng.integers(2**31 - 1, size=options.n_runs)]
    draw_seed = int(rng.integers(2**31 - 1))
    paths = [None] * options.n_runs
    if checkpoint is not None:
        Path(checkpoint).mkdir(parents=True, exist_ok=True)
        paths = [checkpoint_path(checkpoint, "nested", k) for k in range(options.n_runs)]
    n_proc = min(options.n_processes or os.cpu_count() or 1, options.n_runs)
    t0 = time.perf_counter()
    args = [(k, seeds[k], options, paths[k], resume) for k in range(options.n_runs)]
    runs = run_runs(options.scheduler, problem, _run, args, n_proc, progress)
    return NestedSample(problem.names, runs, problem, time.perf_counter() - t0, seeds, draw_seed, options.sampler)
