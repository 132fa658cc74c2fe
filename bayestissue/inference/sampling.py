"""Ensemble MCMC (emcee) of the calibration posterior: walkers, moves, checkpoints, automatic
length.

The sampler targets :meth:`CalibrationProblem.log_posterior_unconstrained` (the posterior in the
unconstrained space with the log-Jacobian) with ``vectorize=True``, so every half-ensemble update is
one batched forward call.

* Walkers start around the least-squares optimum with scatter from its Laplace (Gauss-Newton)
  covariance, mapped to :math:`z` by the Jacobian of the transform and clipped into the box
  (:func:`initial_walkers`).
* Default moves: differential evolution 0.8 / DE-snooker 0.2 (ter Braak & Vrugt 2008,
  doi:10.1007/s11222-008-9104-9; Nelson et al. 2014, doi:10.1088/0067-0049/210/1/11), which adapt to
  the strongly correlated stiffness parameters better than the stretch move; selectable by name in
  :data:`MOVES`.
* ``moves="mixture"``: half of the steps are independence proposals from a Student-t mixture fitted
  to the ensemble's own draws during ``adapt_rounds`` discarded rounds of ``adapt_steps`` and then
  frozen (:mod:`bayestissue.inference.proposals`), the rest DE 0.4 / DE-snooker 0.1. On the T1
  replica (mirror model, creep coordinates, 36 walkers, 12 000 steps) the largest tau fell from 165
  (DE/snooker) to 57 steps at the same overall acceptance (0.136 vs 0.137): half of the proposals
  are now jumps across the whole posterior.
* ``proposal="shared"`` (with ``moves="mixture"``): the ensembles first run their pruning and
  adaptation apart (:func:`prepare_ensemble`), then one mixture is fitted to the last adaptation
  round of all of them, frozen, and used by each ensemble's production run. Each production chain is
  still an ordinary Metropolis-Hastings chain with a fixed proposal, and the ensembles stay
  independent given it; what changes is that an ensemble can jump into a mode that only another
  ensemble found (ensembles started at distinct least-squares optima). Independence proposals move
  mass between modes in proportion to :math:`p/q`, so a mode the mixture over-weights (found by more
  ensembles) is not favoured at equilibrium.
* Seeded: ``sampler.random_state`` is set from the caller's Generator (emcee otherwise seeds from
  numpy's global state): same seed, same chain.
* Checkpoints: emcee ``HDFBackend`` (one group per ensemble); ``resume=True`` continues a killed run
  and gives the same chain as an unbroken run, because the backend stores the random state with
  every step and the convergence checks happen at fixed multiples of ``check_every``.
* Automatic length: run until :math:`N \\ge 50 \\max_i \\hat\\tau_i` and every :math:`\\hat\\tau_i`
  changed by less than 1 % since the previous check (Goodman & Weare 2010,
  doi:10.2140/camcos.2010.5.65; emcee's autocorrelation tutorial), within ``max_steps``. Burn-in
  :math:`2\\max\\hat\\tau`, thinning :math:`\\max(1, \\lfloor \\min\\hat\\tau / 2 \\rfloor)`.
* Walkers of one ensemble are not independent chains, so :func:`sample_posterior` runs
  ``n_ensembles`` (>= 4 for R-hat) independent ensembles, in parallel processes where cores allow.
"""

from __future__ import annotations

import math
import multiprocessing as mp
import os
import queue as _queue
import time
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

import emcee
import numpy as np
from emcee.autocorr import auto_window, function_1d

from bayestissue._validation import ValidationError, check_positive
from bayestissue.inference.problem import CalibrationProblem
from bayestissue.inference.proposals import MixtureMove, TMixture, fit_t_mixture

__all__ = [
    "MOVES",
    "SamplerOptions",
    "EnsembleResult",
    "PosteriorSample",
    "initial_walkers",
    "prepare_ensemble",
    "run_ensemble",
    "sample_posterior",
]

#: Move mixtures by name: each entry builds the ``moves`` argument of ``emcee.EnsembleSampler``
#: from the frozen proposal mixture (only ``mixture`` uses it).
MOVES: dict[str, Callable] = {
    "de_snooker": lambda mix=None: [(emcee.moves.DEMove(), 0.8), (emcee.moves.DESnookerMove(), 0.2)],
    "de": lambda mix=None: emcee.moves.DEMove(),
    "stretch": lambda mix=None: emcee.moves.StretchMove(),
    "walk": lambda mix=None: emcee.moves.WalkMove(),
    "kde": lambda mix=None: emcee.moves.KDEMove(),
    "mixture": lambda mix: [(MixtureMove(mix), 0.5), (emcee.moves.DEMove(), 0.4), (emcee.moves.DESnookerMove(), 0.1)],
}

#: Moves that need a fitted proposal (an adaptation phase before production).
ADAPTIVE_MOVES = ("mixture",)
#: Where the fitted proposal comes from: each ensemble's own adaptation draws, or all ensembles' draws.
PROPOSALS = ("own", "shared")


@dataclass(frozen=True)
class SamplerOptions:
    """Options of the ensemble sampler (validated on construction).

    Parameters
    ----------
    n_walkers : walkers per ensemble; default ``4 * ndim`` (at least ``2 * ndim + 2``), rounded up
    to even.
    moves : name in :data:`MOVES` (default DE 0.8 / DE-snooker 0.2).
    n_ensembles : independent ensembles (>= 4 for a between-ensemble R-hat).
    n_processes : parallel processes; default ``min(n_ensembles, os.cpu_count())``.
    max_steps : step cap per ensemble.
    min_steps : minimum steps per ensemble.
    check_every : steps between convergence checks.
    tau_factor : required length in units of the largest autocorrelation time (50).
    tau_rtol : required relative change of tau between checks (0.01).
    scatter : multiplier of the Laplace sd for the initial walkers.
    prune_rounds, prune_steps : discarded pre-run in which stuck walkers are moved onto good ones
        (``prune_rounds`` chunks of ``prune_steps``; 0 disables it).
    adapt_rounds, adapt_steps, mixture_components : adaptation of the ``mixture`` proposal
        (discarded): ``adapt_rounds`` rounds of ``adapt_steps`` steps, the mixture of up to
        ``mixture_components`` components refitted to the second half of every round.
    proposal : ``"own"`` (each ensemble's mixture is fitted to its own adaptation draws) or
        ``"shared"`` (one mixture fitted to the last adaptation round of *all* ensembles, then frozen
        and used by each: an ensemble can jump into a mode that only another ensemble found;
        :func:`sample_posterior`).
    """

    n_walkers: int | None = None
    moves: str = "de_snooker"
    n_ensembles: int = 4
    n_processes: int | None = None
    max_steps: int = 20000
    min_steps: int = 0
    check_every: int = 100
    tau_factor: float = 50.0
    tau_rtol: float = 0.01
    scatter: float = 1.0
    prune_rounds: int = 3
    prune_steps: int = 200
    adapt_rounds: int = 3
    adapt_steps: int = 1000
    mixture_components: int = 16
    proposal: str = "own"

    def __post_init__(self):
        if self.moves not in MOVES:
            raise ValidationError("moves", self.moves, f"one of {sorted(MOVES)}")
        for name in ("prune_rounds", "prune_steps"):
            v = getattr(self, name)
            if not (isinstance(v, int | np.integer) and v >= 0):
                raise ValidationError(name, v, "an integer >= 0")
        for name in ("n_ensembles", "max_steps", "check_every", "adapt_rounds", "adapt_steps", "mixture_components"):
            v = getattr(self, name)
            if not (isinstance(v, int | np.integer) and v >= 1):
                raise ValidationError(name, v, "an integer >= 1")
        if self.n_walkers is not None and not (isinstance(self.n_walkers, int | np.integer) and self.n_walkers >= 4):
            raise ValidationError("n_walkers", self.n_walkers, "an integer >= 4 or None")
        if self.n_processes is not None and not (
            isinstance(self.n_processes, int | np.integer) and self.n_processes >= 1
        ):
            raise ValidationError("n_processes", self.n_processes, "an integer >= 1 or None")
        if self.proposal not in PROPOSALS:
            raise ValidationError("proposal", self.proposal, f"one of {list(PROPOSALS)}")
        check_positive("tau_factor", self.tau_factor)
        check_positive("tau_rtol", self.tau_rtol)
        check_positive("scatter", self.scatter)

    def walkers(self, ndim: int) -> int:
        """Walkers for ``ndim`` parameters (even, >= 2 ndim + 2)."""
        n = self.n_walkers if self.n_walkers is not None else 4 * ndim
        n = max(int(n), 2 * ndim + 2)
        return n + (n % 2)


def initial_walkers(
    problem: CalibrationProblem,
    center,
    n_walkers: int,
    *,
    cov=None,
    scatter: float = 1.0,
    nuisance_sd_z: float = 0.1,
    max_sd_z: float = 0.3,
    min_sd_z: float = 1e-4,
    rng=None,
) -> np.ndarray:
    """Initial walker positions in the unconstrained space, ``(n_walkers, ndim)``.

    The centre :math:`\\hat\\theta` (natural units, clipped to :math:`u \\in [10^{-4}, 1 - 10^{-4}]`
    so a parameter on its bound maps to a finite :math:`z`) is mapped to :math:`\\hat z` by the
    problem's sampler coordinates; the material block of ``cov`` (natural units, e.g. the
    Gauss-Newton covariance) is mapped by their Jacobian :math:`D = dz/d\\theta` (central
    differences), :math:`\\Sigma_z = D \\Sigma D^T`,
    its eigenvalues clipped to ``[min_sd_z**2, max_sd_z**2]``; nuisance parameters get
    ``nuisance_sd_z``. Walkers with a non-finite log-posterior are redrawn; the set passes emcee's
    linear-independence check.

    Raises
    ------
    ValidationError
        If ``center`` has the wrong shape or no valid walkers can be drawn.
    """
    rng = np.random.default_rng(rng)
    pars = problem.parameters
    center = np.asarray(center, dtype=float).ravel()
    if center.shape != (problem.ndim,):
        raise ValidationError("center", f"shape {center.shape}", f"shape ({problem.ndim},)")
    u = np.clip(pars.to_unit(center), 1e-4, 1 - 1e-4)
    theta_c = pars.from_unit(u)
    coords = problem.coordinates
    z_c = coords.to_unconstrained(theta_c)
    if not np.all(np.isfinite(z_c)):
        raise ValidationError("center", theta_c, "a point the sampler coordinates can represent")
    cov_z = np.diag(np.full(problem.ndim, nuisance_sd_z**2))
    m = problem.n_material
    if cov is not None:
        cov = np.asarray(cov, dtype=float)
        if cov.shape != (m, m):
            raise ValidationError("cov", f"shape {cov.shape}", f"shape ({m}, {m}) (material block)")
        # dz/dtheta by central differences (relative step 1e-6; the maps are smooth inside the box)
        h = 1e-6 * np.maximum(np.abs(theta_c), 1e-3 * (pars.upper - pars.lower))
        steps = np.diag(h)
        dzdx = (coords.to_unconstrained(theta_c + steps) - coords.to_unconstrained(theta_c - steps)).T / (2 * h)
        full = np.zeros((problem.ndim, problem.ndim))
        full[:m, :m] = cov
        block = (dzdx @ full @ dzdx.T)[:m, :m]
        block = np.where(np.isfinite(block), block, 0.0)
        block = 0.5 * (block + block.T)
        w, v = np.linalg.eigh(block)
        w = np.clip(w, min_sd_z**2, max_sd_z**2)
        cov_z[:m, :m] = (v * w) @ v.T
    else:
        cov_z[:m, :m] = np.diag(np.full(m, (0.1 * max_sd_z) ** 2))
    chol = np.linalg.cholesky(cov_z * scatter**2)
    walkers = z_c + rng.standard_normal((n_walkers, problem.ndim)) @ chol.T
    for attempt in range(20):
        lp = problem.log_posterior_unconstrained(walkers)
        bad = ~np.isfinite(lp)
        if not np.any(bad) and emcee.ensemble.walkers_independent(walkers):
            return walkers
        # redraw around the centre; after 10 rounds (a centre next to a region where solves fail) around
        # walkers already valid, at a tenth of the scatter
        base = z_c
        if attempt >= 10 and np.any(~bad):
            base = walkers[rng.choice(np.flatnonzero(~bad), int(bad.sum()))]
        scale = 1.0 if attempt < 10 else 0.1
        walkers[bad] = base + scale * rng.standard_normal((int(bad.sum()), problem.ndim)) @ chol.T
        if not np.any(bad):  # degenerate: add jitter
            walkers += 1e-3 * rng.standard_normal(walkers.shape)
    raise ValidationError(
        "initial walkers",
        f"{int(bad.sum())} of {n_walkers} with -inf log-posterior",
        "finite log-posterior at the start",
        "check the centre (least-squares estimate) and the forward model",
    )


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
    converged_length : ``n_steps >= tau_factor * max(tau)`` and tau stable to ``tau_rtol``.
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


def _prune_burn_in(problem, p0, options, seed) -> np.ndarray:
    """Pre-run with walker pruning; returns the production start.

    ``options.prune_rounds`` chunks of ``options.prune_steps`` steps; after each, walkers whose
    log-posterior is more than :math:`d/2 + 5\\sqrt{d/2} + 5` below the best walker (far outside the
    :math:`\\chi^2_d` range of a converged ensemble) are moved onto randomly chosen good walkers
    with a small jitter. Stuck walkers otherwise stay stuck for a very long time under ensemble
    moves. This phase is discarded; it is deterministic given ``seed``.
    """
    if options.prune_rounds == 0 or options.prune_steps == 0:
        return p0
    nw, ndim = p0.shape
    rs = np.random.RandomState((seed + 1) % (2**32 - 1))
    sampler = emcee.EnsembleSampler(
        nw, ndim, problem.log_posterior_unconstrained, vectorize=True, moves=_moves(options.moves)
    )
    sampler.random_state = rs.get_state()
    state = sampler.run_mcmc(p0, options.prune_steps, progress=False, skip_initial_state_check=True)
    delta = ndim / 2 + 5 * np.sqrt(ndim / 2) + 5
    for _ in range(options.prune_rounds - 1):
        coords, lp = state.coords.copy(), state.log_prob.copy()
        good = lp >= lp.max() - delta
        bad = np.flatnonzero(~good)
        if bad.size:
            src = rs.choice(np.flatnonzero(good), bad.size)
            spread = coords[good].std(axis=0) + 1e-8
            coords[bad] = coords[src] + 1e-2 * spread * rs.standard_normal((bad.size, ndim))
            lp[bad] = problem.log_posterior_unconstrained(coords[bad])
        state = emcee.State(coords, log_prob=lp, random_state=sampler.random_state)
        # the jittered copies are independent but may make emcee's heuristic condition-number check fire
        state = sampler.run_mcmc(state, options.prune_steps, progress=False, skip_initial_state_check=True)
    return state.coords


def _moves(name: str, mixture: TMixture | None = None):
    """emcee moves ``name`` (pre-runs of an adaptive mixture use DE 0.8 / DE-snooker 0.2)."""
    if name in ADAPTIVE_MOVES and mixture is None:
        name = "de_snooker"
    return MOVES[name](mixture)


def _adapt_mixture(problem, p0, options, seed) -> tuple[TMixture, np.ndarray, np.ndarray]:
    """Adaptation phase of the ``mixture`` proposal: ``options.adapt_rounds`` rounds of
    ``options.adapt_steps`` steps (the first with DE/snooker, the next with the mixture fitted so
    far), refitting to the second half of every round. Discarded; deterministic given ``seed``.
    Returns the frozen mixture, the walkers' positions and the draws it was fitted to."""
    nw, ndim = p0.shape
    rs = np.random.RandomState((seed + 2) % (2**32 - 1))
    mixture, coords = None, p0
    for _ in range(options.adapt_rounds):
        sampler = emcee.EnsembleSampler(
            nw, ndim, problem.log_posterior_unconstrained, vectorize=True, moves=_moves(options.moves, mixture)
        )
        sampler.random_state = rs.get_state()
        state = sampler.run_mcmc(coords, options.adapt_steps, progress=False, skip_initial_state_check=True)
        rs.set_state(sampler.random_state)
        coords = state.coords
        draws = sampler.get_chain(discard=options.adapt_steps // 2, flat=True)
        mixture = fit_t_mixture(draws, n_components=options.mixture_components, seed=int(rs.randint(2**31 - 1)))
    return mixture, coords, draws


def prepare_ensemble(problem, p0, *, options: SamplerOptions, seed: int):
    """The discarded phases of :func:`run_ensemble` (pruning, then the mixture's adaptation for
    adaptive moves): returns ``(start, mixture, draws)``, the production start, the fitted mixture
    and the last adaptation round's draws it was fitted to (both None without adaptation).
    Deterministic given ``seed``; :func:`sample_posterior` fits a shared proposal to all ensembles'
    draws."""
    p0 = np.asarray(p0, dtype=float)
    if not emcee.ensemble.walkers_independent(p0):
        raise ValidationError("initial walkers", "linearly dependent positions", "independent walkers")
    p0 = _prune_burn_in(problem, p0, options, seed)
    if options.moves not in ADAPTIVE_MOVES:
        return p0, None, None
    mixture, start, draws = _adapt_mixture(problem, p0, options, seed)
    return start, mixture, draws


def _length_ok(chain: np.ndarray, options: SamplerOptions) -> tuple[bool, np.ndarray]:
    """The automatic-length criterion at the end of ``chain``: ``n >= tau_factor * max(tau)`` and every
    tau changed by less than ``tau_rtol`` since ``check_every`` steps earlier; returns (ok, tau)."""
    n = chain.shape[0]
    tau = _tau(chain)
    every = options.check_every
    if n < 2 * every or n < options.min_steps:
        return False, tau
    prev = _tau(chain[: n - every])
    stable = bool(np.all(np.abs(prev - tau) / tau < options.tau_rtol))
    return bool(n >= options.tau_factor * np.max(tau) and stable), tau


def _tau(chain: np.ndarray) -> np.ndarray:
    """emcee's integrated autocorrelation time (walker-averaged autocorrelation function, window
    ``c = 5``), skipping walkers that have not moved (their autocorrelation is undefined); a
    parameter
    no walker has moved in gets ``tau = n_steps``."""
    n, nw, nd = chain.shape
    tau = np.empty(nd)
    for d in range(nd):
        f = np.zeros(n)
        k = 0
        for w in range(nw):
            x = chain[:, w, d]
            if np.ptp(x) > 0:
                f += function_1d(x)
                k += 1
        if k == 0:
            tau[d] = float(n)
            continue
        taus = 2.0 * np.cumsum(f / k) - 1.0
        tau[d] = max(taus[auto_window(taus, 5)], 1.0)
    return tau


def run_ensemble(
    problem: CalibrationProblem,
    p0,
    *,
    options: SamplerOptions = SamplerOptions(),
    seed: int = 0,
    backend_path: str | Path | None = None,
    ensemble_id: int = 0,
    resume: bool = False,
    progress: Callable[[int, int, int], None] | None = None,
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
    progress : ``progress(ensemble_id, steps_done, max_steps)`` after every chunk.
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
            p0, mixture, _ = prepare_ensemble(problem, p0, options=options, seed=seed)
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
            progress(ensemble_id, n, options.max_steps)
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


# ---- parallel ensembles
# ------------------------------------------------------------------------------
_WORKER: dict = {}


def _init_worker(problem, progress_queue):
    _WORKER["problem"] = problem
    _WORKER["queue"] = progress_queue


def _task(problem, task, k, p0, seed, options, path, resume, proposal, progress):
    """One ensemble's ``task``: ``"prepare"`` (:func:`prepare_ensemble`; returns its start and draws)
    or ``"run"`` (:func:`run_ensemble`), with the problem's evaluations and failures during it."""
    n_eval0, n_fail0 = problem.n_evaluations, problem.n_failed
    if task == "prepare":
        start, _, draws = prepare_ensemble(problem, p0, options=options, seed=seed)
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


def _worker(task, *args):
    q = _WORKER["queue"]

    def report(eid, n, nmax):
        q.put((eid, n, nmax))

    return _task(_WORKER["problem"], task, *args, report)


def _run_tasks(problem, task, args, n_proc, progress):
    """``_task`` for every ensemble's arguments in ``args``: in forked processes when ``n_proc > 1``,
    else one after another in this process. Returns ``(output, n_evaluations, n_failed)`` each."""
    if n_proc > 1 and "fork" in mp.get_all_start_methods():
        ctx = mp.get_context("fork")
        q = ctx.Queue()
        with ProcessPoolExecutor(n_proc, mp_context=ctx, initializer=_init_worker, initargs=(problem, q)) as ex:
            futs = [ex.submit(_worker, task, *a) for a in args]
            while not all(f.done() for f in futs):
                try:
                    msg = q.get(timeout=0.2)
                except _queue.Empty:
                    continue
                if progress is not None:
                    progress(*msg)
            results = [f.result() for f in futs]
            while progress is not None and not q.empty():
                progress(*q.get())
        return results
    return [_task(problem, task, *a, progress) for a in args]


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


def sample_posterior(
    problem: CalibrationProblem,
    center,
    *,
    cov=None,
    options: SamplerOptions = SamplerOptions(),
    checkpoint: str | Path | None = None,
    resume: bool = False,
    progress: Callable[[int, int, int], None] | None = None,
    rng=None,
) -> PosteriorSample:
    """Run ``options.n_ensembles`` independent ensembles, in parallel processes where cores allow.

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
    progress : ``progress(ensemble_id, steps_done, max_steps)``, called in this process.
    rng : seed or Generator (seeds of the ensembles and their initial walkers).

    Notes
    -----
    Worker processes are forked (POSIX), so the problem and its forward callables need not be
    picklable; without ``fork`` the ensembles run one after another. With
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
        paths = [Path(checkpoint) / f"ensemble_{k}.h5" for k in range(n_ens)]
    n_proc = options.n_processes or min(n_ens, os.cpu_count() or 1)
    n_proc = min(n_proc, n_ens)
    t0 = time.perf_counter()
    args = [(k, p0s[k], seeds[k], options, paths[k], resume, None) for k in range(n_ens)]
    extra = [(0, 0)] * n_ens
    shared = options.proposal == "shared" and options.moves in ADAPTIVE_MOVES
    if shared and not (resume and all(_stored_run(paths[k], k, True)[0] > 0 for k in range(n_ens))):
        prepared = _run_tasks(problem, "prepare", args, n_proc, None)
        draws = np.concatenate([out[1] for out, _, _ in prepared])
        mixture = fit_t_mixture(draws, n_components=options.mixture_components, seed=seeds[0] % (2**31 - 1))
        args = [(k, prepared[k][0][0], seeds[k], options, paths[k], resume, mixture) for k in range(n_ens)]
        extra = [(n_eval, n_fail) for _, n_eval, n_fail in prepared]
    results = []
    for (r, n_eval, n_fail), (n_eval0, n_fail0) in zip(
        _run_tasks(problem, "run", args, n_proc, progress), extra, strict=True
    ):
        r.n_evaluations, r.n_failed = n_eval + n_eval0, n_fail + n_fail0
        results.append(r)
    return PosteriorSample(problem.names, results, problem, time.perf_counter() - t0, seeds)
