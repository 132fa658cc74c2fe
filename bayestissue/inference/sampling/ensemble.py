"""One emcee ensemble: seeded, checkpointed (HDF5), resumable, with the automatic length."""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import emcee
import numpy as np

from bayestissue._validation import ValidationError
from bayestissue.inference.problem import CalibrationProblem
from bayestissue.inference.proposals import TMixture
from bayestissue.inference.sampling.options import ADAPTIVE_MOVES, SamplerOptions
from bayestissue.inference.sampling.phases import _length_ok, _moves, _tau, prepare_ensemble

__all__ = ["EnsembleResult", "run_ensemble"]


@dataclass
class EnsembleResult:
    """One ensemble's run. Chains are stored thinned by ``store_thin`` (from tau) to keep results
    small.

    Attributes
    ----------
    chain_z : (n_stored, n_walkers, ndim) positions in the unconstrained space (incl. burn-in).
    log_prob : (n_stored, n_walkers) log-posterior in z (incl. log-Jacobian).
    n_steps : steps run; store_thin : steps per stored row; burn_in : burn-in steps (2 max tau).
    tau : (ndim,) integrated autocorrelation times (steps); tau_history : (n_checks, ndim).
    acceptance : (n_walkers,) acceptance fraction per walker.
    converged_length : ``n_steps >= tau_factor * max(tau)`` and tau stable to ``tau_rtol`` (or the ensemble twice
        that long: :func:`~bayestissue.inference.sampling.phases._length_ok`).
    """

    ensemble_id: int
    seed: int
    chain_z: np.ndarray
    log_prob: np.ndarray
    n_steps: int
    store_thin: int
    burn_in: int
    tau: np.ndarray
    tau_history: np.ndarray
    check_steps: np.ndarray
    acceptance: np.ndarray
    converged_length: bool
    time_s: float
    n_evaluations: int
    n_failed: int
    resumed_at: int = 0

    def kept(self) -> tuple[np.ndarray, np.ndarray]:
        """Post-burn-in stored rows: ``(chain_z, log_prob)`` with shapes ``(n, n_walkers, ndim)``,
        ``(n, nw)``."""
        start = math.ceil(self.burn_in / self.store_thin)
        return self.chain_z[start:], self.log_prob[start:]


def run_ensemble(
    problem: CalibrationProblem,
    p0,
    *,
    options: SamplerOptions = SamplerOptions(),
    seed: int = 0,
    backend_path: str | Path | None = None,
    ensemble_id: int = 0,
    resume: bool = False,
    progress: Callable[[int, int, int, str], None] | None = None,
    proposal: TMixture | None = None,
) -> EnsembleResult:
    """Run one ensemble with automatic length, optionally checkpointed to HDF5.

    Parameters
    ----------
    problem : CalibrationProblem
    p0 : (n_walkers, ndim) initial positions in the unconstrained space (ignored when resuming a
    run).
    options : SamplerOptions
    seed : integer seed of the sampler's RandomState.
    backend_path : HDF5 file for emcee's ``HDFBackend`` (group ``ensemble_<id>``); None keeps it in
    memory.
    resume : continue the run stored in ``backend_path`` instead of starting afresh.
    progress : ``progress(ensemble_id, steps_done, steps_total, phase)`` after every chunk: phase
        ``"pruning"`` and ``"adaptation"`` (discarded; :func:`prepare_ensemble`), then ``"sampling"`` (of
        ``max_steps``).
    proposal : a fitted mixture for adaptive moves, fitted elsewhere (a shared proposal): ``p0`` is
        then taken as the production start (pruning and adaptation were done by
        :func:`prepare_ensemble`).
    """
    p0 = np.asarray(p0, dtype=float)
    n_walkers, ndim = p0.shape
    if ndim != problem.ndim:
        raise ValidationError("p0", f"shape {p0.shape}", f"(n_walkers, {problem.ndim})")
    backend = None
    resumed_at = 0
    mixture = None
    group = f"ensemble_{ensemble_id}"
    if backend_path is not None:
        backend = emcee.backends.HDFBackend(str(backend_path), name=group)
        if resume:
            resumed_at, mixture = _stored_run(backend_path, ensemble_id, options.moves in ADAPTIVE_MOVES)
        if resumed_at == 0:
            backend.reset(n_walkers, ndim)
    t0 = time.perf_counter()
    if resumed_at == 0:
        if proposal is not None:  # p0 comes from prepare_ensemble (checked there, then moved by the sampler)
            mixture = proposal
        else:
            p0, mixture, _ = prepare_ensemble(
                problem, p0, options=options, seed=seed, report=_phase_report(progress, ensemble_id)
            )
        if mixture is not None and backend_path is not None:
            mixture.to_hdf5(backend_path, f"{group}_proposal")
        state = p0
    else:
        state = None
    sampler = emcee.EnsembleSampler(
        n_walkers,
        ndim,
        problem.log_posterior_unconstrained,
        vectorize=True,
        moves=_moves(options.moves, mixture),
        backend=backend,
    )
    if resumed_at == 0:
        sampler.random_state = np.random.RandomState(seed).get_state()
    n = sampler.iteration
    taus, checks = [], []
    every = options.check_every
    converged = False
    if resumed_at > 0 and n % every == 0:  # a finished run stays finished
        converged, tau = _length_ok(sampler.get_chain(), options)
    while n < options.max_steps and not converged:
        n_next = min((n // every + 1) * every, options.max_steps)
        # emcee re-checks the walkers' condition number at every call; a thin (sloppy) posterior can
        # legitimately exceed its 1e8 heuristic, so the start is checked once above instead
        sampler.run_mcmc(state, n_next - n, progress=False, skip_initial_state_check=True)
        state = None
        n = sampler.iteration
        converged, tau = _length_ok(sampler.get_chain(), options)
        taus.append(tau)
        checks.append(n)
        if progress is not None:
            progress(ensemble_id, n, options.max_steps, "sampling")
    chain = sampler.get_chain()
    lp = sampler.get_log_prob()
    tau = _tau(chain)
    store_thin = max(1, int(np.min(tau) / 2))
    burn = min(int(math.ceil(2 * np.max(tau))), n - store_thin)
    return EnsembleResult(
        ensemble_id=ensemble_id,
        seed=int(seed),
        chain_z=chain[::store_thin].copy(),
        log_prob=lp[::store_thin].copy(),
        n_steps=int(n),
        store_thin=store_thin,
        burn_in=max(burn, 0),
        tau=tau,
        tau_history=np.array(taus),
        check_steps=np.array(checks),
        acceptance=np.asarray(sampler.acceptance_fraction, dtype=float),
        converged_length=converged,
        time_s=time.perf_counter() - t0,
        n_evaluations=problem.n_evaluations,
        n_failed=problem.n_failed,
        resumed_at=int(resumed_at),
    )


def _phase_report(progress, ensemble_id: int):
    """``prepare_ensemble``'s ``report(phase, done, total)`` as ``progress(ensemble_id, done, total, phase)``."""
    if progress is None:
        return None
    return lambda phase, done, total: progress(ensemble_id, done, total, phase)


def _stored_run(path, k, adaptive: bool) -> tuple[int, TMixture | None]:
    """Steps of ensemble ``k``'s run stored in ``path`` and, for ``adaptive`` moves, its proposal:
    ``(0, None)`` when there is nothing to resume (no file, no run, or killed between the adaptation
    and the first checkpoint, before the proposal was stored with the chain)."""
    if path is None or not Path(path).exists():
        return 0, None
    try:
        n = emcee.backends.HDFBackend(str(path), name=f"ensemble_{k}", read_only=True).iteration
    except (KeyError, OSError):
        return 0, None
    if n == 0 or not adaptive:
        return n, None
    mixture = TMixture.from_hdf5(path, f"ensemble_{k}_proposal")
    return (n, mixture) if mixture is not None else (0, None)
