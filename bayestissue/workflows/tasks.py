"""Calibration tasks for the identifiability and T1-vs-T2 studies: picklable, deterministic in their arguments.

A :class:`CalibrationTask` (experiments, an optional specimen-level parameter, run settings) goes through the same
problem as ``bayestissue fit`` (:func:`bayestissue.workflows.problem.build_problem`, noise sd known from the data
files) to least squares (multi-start, the paper's method) and, with ``n_steps > 0``, a fixed-length emcee posterior;
:func:`run_task` returns :class:`CalibrationDraws`: arrays in the paper's 11 parameters (tied ones expanded), ready
for the array functions of :mod:`bayestissue.identifiability`. Tasks fan out with
:func:`bayestissue.parallel.fan_out` and are cached by content hash.

:func:`attach_posterior` reads the posterior of a calibration results file (``bayestissue fit`` or
``studies/calibrate.py``: per-variable R-hat and ties stored as attributes, see
:func:`bayestissue.inference.posterior.to_inference_data`) into the :class:`CalibrationDraws` of a least-squares task
on the same experiments.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from bayestissue._validation import ValidationError
from bayestissue.inference import (
    CalibrationProblem,
    ParameterSet,
    SamplerOptions,
    fit_least_squares,
    fit_multistart,
    sample_posterior,
)
from bayestissue.inference.coordinates import adapt_coordinates
from bayestissue.inference.diagnostics import rhat_ensembles
from bayestissue.inference.fit_check import fit_check, fit_check_text
from bayestissue.inference.likelihood import _tag
from bayestissue.inference.posterior import evenly, tied_sources
from bayestissue.io.results import read_inference_data
from bayestissue.workflows.config import CalibrationConfig
from bayestissue.workflows.problem import build_problem, paper_parameter_set

__all__ = ["CalibrationTask", "CalibrationDraws", "run_task", "attach_posterior", "drop_stuck_draws", "task_problem"]


@dataclass(frozen=True)
class CalibrationTask:
    """One calibration: experiments, an optional specimen-level parameter, and the run settings.

    Parameters
    ----------
    experiments : the experiments calibrated together (shared material parameters).
    specimen : None, or ``(kind, experiment name)``: a ``"scale"`` or ``"angle"`` parameter acting on that
        experiment only (see :class:`SpecimenForward`).
    n_starts : Latin-hypercube least-squares starts besides the paper's initial guess.
    extra_starts : further least-squares starts (natural units; 11 values, the specimen parameter's
        initial value is appended when the problem has one), e.g. the paper's Table 1 estimates.
    n_steps : emcee steps per ensemble (0: least squares only); n_ensembles, n_walkers : ensemble layout.
    keep : number of posterior draws kept (thinned evenly).
    max_nfev : function-evaluation cap of each least-squares fit.
    paper_start : also start from the paper's initial guess (the multi-start); False with
        ``n_starts=0`` fits only from ``extra_starts`` (warm starts, e.g. per stereology replicate).
    seed : seed of the multi-start and the sampler.
    tied : pairs ``(name, target)``: ``name`` takes ``target``'s value (e.g. :data:`bayestissue.paper.MIRROR_TIES`); the
        draws are still reported for all 11 parameters.
    coordinates, moves, adapt_rounds, adapt_steps : the sampler's coordinate system
        (:data:`bayestissue.workflows.coordinates.COORDINATES`; sheared ones are adapted to the best
        optimum as in the calibration stage) and moves (:class:`~bayestissue.inference.SamplerOptions`).
        Defaults: box coordinates with DE/snooker moves, a fixed-length chain of ``n_steps``.
    """

    experiments: tuple
    specimen: tuple | None = None
    n_starts: int = 3
    extra_starts: tuple = ()
    n_steps: int = 1500
    n_ensembles: int = 2
    n_walkers: int | None = None
    keep: int = 4000
    seed: int = 0
    label: str = ""
    paper_start: bool = True
    max_nfev: int = 400
    tied: tuple = ()
    coordinates: str = "box"
    moves: str = "de_snooker"
    adapt_rounds: int = 2
    adapt_steps: int = 500


@dataclass
class CalibrationDraws:
    """Result of :func:`run_calibration` (natural units unless stated).

    ``draws`` (n, p) posterior draws, ``u`` the same in the scaled box :math:`[0, 1]^p` (the space
    where every prior is uniform), ``loglik`` (n, n_experiments) per-experiment log-likelihood of
    each draw, ``ls_x``/``ls_chi2`` the least-squares optimum and its :math:`\\chi^2`,
    ``chi2_parts`` its split by experiment, ``ls_starts`` (x, chi2) of every start,
    ``rhat``/``acceptance`` sampler diagnostics.
    """

    label: str
    names: tuple
    lower: np.ndarray
    upper: np.ndarray
    ls_x: np.ndarray
    ls_chi2: float
    chi2_parts: np.ndarray
    ls_active: np.ndarray
    ls_starts: list = field(default_factory=list)
    draws: np.ndarray | None = None
    u: np.ndarray | None = None
    loglik: np.ndarray | None = None
    rhat: np.ndarray | None = None
    acceptance: float = float("nan")
    n_failed: int = 0
    time_ls_s: float = 0.0
    time_mcmc_s: float = 0.0
    experiment_names: tuple = ()
    results_file: str = ""
    convergence: str = "no verdict (not read from a results file)"
    converged: bool = False
    fit: dict = field(default_factory=dict)
    fit_check: str = ""
    n_dropped: int = 0
    tied: dict = field(default_factory=dict)

    @property
    def misfit(self) -> bool:
        """The posterior predictive check (:mod:`bayestissue.inference.fit_check`) says MISFIT for an experiment."""
        return any(v["misfit"] for v in self.fit.values())


def _chi2_parts(problem: CalibrationProblem, x) -> np.ndarray:
    preds = problem.predict_material(np.atleast_2d(x))
    return np.array(
        [
            float(np.sum(((p[0] - e.observed) / e.noise.sd) ** 2))
            for p, e in zip(preds, problem.experiments, strict=True)
        ]
    )


def task_problem(task: CalibrationTask) -> CalibrationProblem:
    """The calibration problem of a task: :func:`~bayestissue.workflows.problem.build_problem` with the noise sd
    known from each data file, the task's ties, specimen parameter and coordinates."""
    config = CalibrationConfig(
        noise_options={"sd": "data"}, tied=dict(task.tied), coordinates=task.coordinates, specimen=task.specimen
    )
    return build_problem(task.experiments, config)


def run_task(task: CalibrationTask) -> CalibrationDraws:
    """Least squares (paper's start + ``n_starts`` Latin-hypercube starts) then, if ``n_steps > 0``, an emcee
    posterior started around the best optimum. Runs in one process (safe inside a dask worker)."""
    if not task.experiments:
        raise ValidationError("task.experiments", (), "at least one Experiment")
    problem = task_problem(task)
    rng = np.random.default_rng(task.seed)
    t0 = time.perf_counter()
    fits = []
    if task.paper_start or task.n_starts > 0:
        kw = {"include_initial": task.paper_start}
        fits = list(fit_multistart(problem, n_starts=task.n_starts, rng=rng, max_nfev=task.max_nfev, **kw).results)
    mat = problem.material
    for start in task.extra_starts:
        fits.append(fit_least_squares(problem, _sampled_start(mat, start), max_nfev=task.max_nfev))
    if not fits:
        raise ValidationError("task", "no least-squares start", "paper_start, n_starts > 0 or extra_starts")
    best = min(fits, key=lambda r: r.cost)
    t_ls = time.perf_counter() - t0
    parts = _chi2_parts(problem, best.x)
    untied = _untied(mat)
    out = CalibrationDraws(
        label=task.label,
        names=mat.names,
        lower=untied.lower,
        upper=untied.upper,
        ls_x=mat.expand(best.x),
        ls_chi2=float(parts.sum()),
        chi2_parts=parts,
        ls_active=mat.expand(np.asarray(best.active, dtype=float)).astype(bool),
        ls_starts=[(mat.expand(r.x), 2 * r.cost) for r in fits],
        time_ls_s=t_ls,
        experiment_names=tuple(e.name for e in task.experiments),
        tied=mat.tied,
    )
    if task.n_steps <= 0:
        return out
    opts = SamplerOptions(
        n_walkers=task.n_walkers,
        n_ensembles=task.n_ensembles,
        n_processes=1,
        max_steps=task.n_steps,
        min_steps=task.n_steps,
        check_every=max(50, task.n_steps // 10),
        moves=task.moves,
        adapt_rounds=task.adapt_rounds,
        adapt_steps=task.adapt_steps,
    )
    t1 = time.perf_counter()
    problem.coordinates = adapt_coordinates(problem, best.x)
    post = sample_posterior(problem, best.x, cov=best.cov, options=opts, rng=rng)
    draws4 = post.draws()  # (n_ens, n_draws, n_walkers, ndim)
    out.acceptance = float(np.mean([e.acceptance.mean() for e in post.ensembles]))
    out.n_failed = int(post.n_failed)
    out.time_mcmc_s = time.perf_counter() - t1
    if draws4.shape[0] >= 2 and draws4.shape[1] >= 4:
        out.rhat = rhat_ensembles(draws4)
    flat = draws4.reshape(-1, draws4.shape[-1])
    idx = evenly(flat.shape[0], task.keep)
    out.loglik = np.column_stack([ll.sum(axis=1) for ll in problem.log_likelihood_pointwise(flat[idx])])
    out.draws = mat.expand(flat[idx])
    out.u = untied.to_unit(out.draws)
    return out


def _sampled_start(mat: ParameterSet, start) -> np.ndarray:
    """A least-squares start given for every parameter (the paper's 11, a specimen parameter's initial
    value appended when missing) -> the sampled ones, clipped into the box."""
    x0 = np.asarray(start, dtype=float).ravel()
    if x0.size == len(mat.names) - 1:
        x0 = np.append(x0, mat.specs[-1].value)
    if x0.size != len(mat.names):
        raise ValidationError("least-squares start", f"{x0.size} values", f"{len(mat.names)} ({', '.join(mat.names)})")
    x0 = x0[[mat.names.index(n) for n in mat.sampled_names]]
    return np.clip(x0, mat.lower, mat.upper)


def _untied(mat: ParameterSet) -> ParameterSet:
    """``mat`` with every tie released (same boxes and priors): the space of the reported draws."""
    return ParameterSet(tuple(replace(s, tied_to=None) for s in mat.specs), mat.fixed_inputs, mat.ordered)


def attach_posterior(outcome: CalibrationDraws, path, *, keep: int = 4000) -> CalibrationDraws:
    """A copy of the least-squares ``outcome`` with the posterior of a calibration results file.

    The file (:func:`bayestissue.io.results.write_inference_data`: ``bayestissue fit`` or
    ``studies/calibrate.py``) must calibrate the same experiments. Its material draws are expanded to
    the paper's 11 parameters (a tied parameter takes its target's draw; the target variable's ``tied``
    attribute lists the parameters tied to it), thinned evenly to at most ``keep``; ``u`` is their scaled box;
    ``loglik`` the file's pointwise log-likelihood summed per experiment (its own noise model, e.g.
    a sampled sd); ``rhat`` the file's between-ensemble R-hat (each variable's ``rhat_ensembles`` attribute);
    ``results_file``, ``convergence`` and ``converged`` name the file and its convergence verdict; ``fit`` (per
    experiment) and ``fit_check`` (one line) its posterior predictive check (:mod:`bayestissue.inference.fit_check`,
    recomputed from the file's predictive draws). Nuisance draws (noise sd) are dropped.
    """
    box = paper_parameter_set()
    if tuple(outcome.names) != box.names:
        raise ValidationError("outcome.names", outcome.names, f"the paper's 11 parameters {box.names}")
    path = Path(path)
    idata = read_inference_data(path)
    post, attrs = idata.posterior, idata.posterior.attrs
    tags = [_tag(n) for n in outcome.experiment_names]
    have = sorted(idata.log_likelihood.data_vars)
    if have != sorted(tags):
        raise ValidationError(f"results file {path.name} experiments", have, f"the experiments {sorted(tags)}")
    tied = tied_sources(post)
    missing = [n for n in outcome.names if tied.get(n, n) not in post.data_vars]
    if missing:
        raise ValidationError(f"results file {path.name}", f"no draws of {missing}", f"draws of {list(outcome.names)}")
    draws = np.column_stack([post[tied.get(n, n)].values.ravel() for n in outcome.names])
    n = draws.shape[0]
    ll = np.column_stack([idata.log_likelihood[t].values.reshape(n, -1).sum(axis=1) for t in tags])
    idx = evenly(n, keep)
    out = replace(outcome)
    out.draws, out.loglik = draws[idx], ll[idx]
    out.u = box.to_unit(out.draws)
    out.rhat = np.array([float(post[tied.get(n, n)].attrs.get("rhat_ensembles", np.nan)) for n in outcome.names])
    out.acceptance = float(attrs.get("acceptance_mean", float("nan")))
    out.n_failed = int(attrs.get("n_failed_forward", 0))
    out.time_mcmc_s = float(attrs.get("sampling_time_s", float("nan")))
    out.results_file = path.name
    out.convergence = str(attrs.get("convergence", "no verdict recorded"))
    out.converged = bool(attrs.get("converged", 0))
    out.fit = fit_check(idata)
    out.fit_check = fit_check_text(out.fit)
    out.tied = tied
    return out


def drop_stuck_draws(outcome: CalibrationDraws, *, p: float = 1e-6) -> CalibrationDraws:
    """Remove draws of stuck walkers: log-likelihood more than :math:`\\chi^2_{d, 1-p}/2` below the best draw.

    Near the mode :math:`2(\\ell_{max} - \\ell) \\sim \\chi^2_d` (d sampled parameters, tied ones not
    counted), so with ``p = 1e-6`` a legitimate draw is dropped with probability about 1e-6; an ensemble walker that
    started in (or jumped to) a region a million times less likely and never moved is not a
    posterior draw. Returns a copy with ``n_dropped`` set.
    """
    from scipy.stats import chi2

    if outcome.draws is None:
        return outcome
    ll = outcome.loglik.sum(axis=1)
    d = outcome.draws.shape[1] - len(outcome.tied)  # tied columns repeat their targets
    keep = 2 * (ll.max() - ll) <= chi2.ppf(1 - p, d)
    out = replace(outcome)
    out.draws, out.u, out.loglik = outcome.draws[keep], outcome.u[keep], outcome.loglik[keep]
    out.n_dropped = int((~keep).sum())
    return out
