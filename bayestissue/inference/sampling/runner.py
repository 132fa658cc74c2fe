"""Independent ensembles run in parallel processes or as dask tasks (:func:`~bayestissue.inference.sampling.cluster.
run_runs`), pooled into a :class:`PosteriorSample`."""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from bayestissue._validation import ValidationError
from bayestissue.inference.problem import CalibrationProblem
from bayestissue.inference.proposals import fit_t_mixture
from bayestissue.inference.sampling.checkpoints import checkpoint_path
from bayestissue.inference.sampling.cluster import run_runs
from bayestissue.inference.sampling.ensemble import EnsembleResult, _phase_report, _stored_run, run_ensemble
from bayestissue.inference.sampling.options import ADAPTIVE_MOVES, SamplerOptions
from bayestissue.inference.sampling.phases import prepare_ensemble
from bayestissue.inference.sampling.start import initial_walkers

__all__ = ["PosteriorSample", "sample_posterior"]


@dataclass
class PosteriorSample:
    """Independent ensembles of one posterior, with the parameter layout."""

    names: tuple[str, ...]
    ensembles: list[EnsembleResult]
    problem: CalibrationProblem = field(repr=False)
    time_s: float = 0.0
    seeds: list[int] | None = None

    @property
    def n_failed(self) -> int:
        return sum(e.n_failed for e in self.ensembles)

    @property
    def n_evaluations(self) -> int:
        return sum(e.n_evaluations for e in self.ensembles)

    def kept_z(self) -> np.ndarray:
        """Post-burn-in draws, ``(n_ensembles, n_draws, n_walkers, ndim)`` in z (common length, last
        rows)."""
        kept = [e.kept()[0] for e in self.ensembles]
        n = min(k.shape[0] for k in kept)
        return np.stack([k[k.shape[0] - n :] for k in kept])

    def kept_log_prob(self) -> np.ndarray:
        kept = [e.kept()[1] for e in self.ensembles]
        n = min(k.shape[0] for k in kept)
        return np.stack([k[k.shape[0] - n :] for k in kept])

    def draws(self) -> np.ndarray:
        """Post-burn-in draws in natural units, ``(n_ensembles, n_draws, n_walkers, ndim)``."""
        z = self.kept_z()
        return self.problem.coordinates.from_unconstrained(z.reshape(-1, z.shape[-1])).reshape(z.shape)

    def flat(self) -> np.ndarray:
        """All post-burn-in draws as ``(n, ndim)`` natural units."""
        d = self.draws()
        return d.reshape(-1, d.shape[-1])


def _task(problem, task, k, p0, seed, options, path, resume, proposal, progress):
    """One ensemble's ``task``: ``"prepare"`` (:func:`prepare_ensemble`; returns its start and draws)
    or ``"run"`` (:func:`run_ensemble`), with the problem's evaluations and failures during it."""
    n_eval0, n_fail0 = problem.n_evaluations, problem.n_failed
    if task == "prepare":
        start, _, draws = prepare_ensemble(problem, p0, options=options, seed=seed, report=_phase_report(progress, k))
        out = (start, draws)
    else:
        out = run_ensemble(
            problem,
            p0,
            options=options,
            seed=seed,
            backend_path=path,
            ensemble_id=k,
            resume=resume,
            progress=progress,
            proposal=proposal,
        )
    return out, problem.n_evaluations - n_eval0, problem.n_failed - n_fail0


def sample_posterior(
    problem: CalibrationProblem,
    center,
    *,
    cov=None,
    options: SamplerOptions = SamplerOptions(),
    checkpoint: str | Path | None = None,
    resume: bool = False,
    progress: Callable[[int, int, int, str], None] | None = None,
    rng=None,
) -> PosteriorSample:
    """Run ``options.n_ensembles`` independent ensembles, in parallel processes where cores allow, or as dask tasks
    (``options.scheduler``; with the shared proposal the preparation and the production are two rounds of tasks).

    Parameters
    ----------
    problem : CalibrationProblem
    center : (ndim,) starting point in natural units (least-squares estimate + nuisance estimates),
        or (n_ensembles, ndim): one centre per ensemble (e.g. distinct least-squares optima, so that
        the between-ensemble R-hat can see separate modes).
    cov : (n_material, n_material) Laplace covariance for the initial scatter (None: small fixed
        scatter), or a list with one per ensemble.
    options : SamplerOptions
    checkpoint : directory for the HDF5 checkpoints, one file per ensemble (``ensemble_<k>.h5``;
    HDF5
        files must not be written by two processes at once).
    resume : continue the runs stored in ``checkpoint``.
    progress : ``progress(ensemble_id, steps_done, steps_total, phase)``, called in this process (phases: see
        :func:`run_ensemble`).
    rng : seed or Generator (seeds of the ensembles and their initial walkers).

    Notes
    -----
    Worker processes are forked (POSIX), so the problem and its forward callables need not be
    picklable; without ``fork`` the ensembles run one after another. As dask tasks the problem is pickled
    (:mod:`~bayestissue.inference.sampling.cluster`); the ensembles are the same bit for bit. With
    ``options.proposal == "shared"`` (and adaptive moves) every ensemble is first pruned and adapted
    (:func:`prepare_ensemble`), one mixture is fitted to all their last-round draws, and the
    production runs start from the prepared walkers with that mixture. When resuming, this
    preparation is repeated (it is deterministic, so it gives the stored mixture again) unless every
    ensemble's checkpoint already holds its run and proposal.
    """
    rng = np.random.default_rng(rng)
    ndim = problem.ndim
    nw = options.walkers(ndim)
    n_ens = options.n_ensembles
    seeds = [int(s) for s in rng.integers(2**32 - 1, size=n_ens)]
    centers = np.asarray(center, dtype=float)
    centers = np.broadcast_to(centers, (n_ens, ndim)) if centers.ndim == 1 else centers
    if centers.shape != (n_ens, ndim):
        raise ValidationError("center", f"shape {np.shape(center)}", f"({ndim},) or ({n_ens}, {ndim})")
    covs = list(cov) if isinstance(cov, list | tuple) else [cov] * n_ens
    if len(covs) != n_ens:
        raise ValidationError("cov", f"{len(covs)} matrices", f"one matrix or {n_ens} (one per ensemble)")
    p0s = [
        initial_walkers(problem, centers[k], nw, cov=covs[k], scatter=options.scatter, rng=rng) for k in range(n_ens)
    ]
    paths = [None] * n_ens
    if checkpoint is not None:
        Path(checkpoint).mkdir(parents=True, exist_ok=True)
        paths = [checkpoint_path(checkpoint, "emcee", k) for k in range(n_ens)]
    n_proc = options.n_processes or min(n_ens, os.cpu_count() or 1)
    n_proc = min(n_proc, n_ens)
    t0 = time.perf_counter()
    args = [(k, p0s[k], seeds[k], options, paths[k], resume, None) for k in range(n_ens)]
    extra = [(0, 0)] * n_ens
    shared = options.proposal == "shared" and options.moves in ADAPTIVE_MOVES
    if shared and not (resume and all(_stored_run(paths[k], k, True)[0] > 0 for k in range(n_ens))):
        prepared = run_runs(options.scheduler, problem, _task, [("prepare", *a) for a in args], n_proc, None)
        draws = np.concatenate([out[1] for out, _, _ in prepared])
        mixture = fit_t_mixture(draws, n_components=options.mixture_components, seed=seeds[0] % (2**31 - 1))
        args = [(k, prepared[k][0][0], seeds[k], options, paths[k], resume, mixture) for k in range(n_ens)]
        extra = [(n_eval, n_fail) for _, n_eval, n_fail in prepared]
    results = []
    for (r, n_eval, n_fail), (n_eval0, n_fail0) in zip(
        run_runs(options.scheduler, problem, _task, [("run", *a) for a in args], n_proc, progress),
        extra,
        strict=True,
    ):
        r.n_evaluations, r.n_failed = n_eval + n_eval0, n_fail + n_fail0
        results.append(r)
    return PosteriorSample(problem.names, results, problem, time.perf_counter() - t0, seeds)
