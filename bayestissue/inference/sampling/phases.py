"""The phases before and around production: burn-in pruning, mixture adaptation, the length criterion."""

from __future__ import annotations

import emcee
import numpy as np
from emcee.autocorr import auto_window, function_1d

from bayestissue._validation import ValidationError
from bayestissue.inference.proposals import TMixture, fit_t_mixture
from bayestissue.inference.sampling.options import ADAPTIVE_MOVES, MOVES, SamplerOptions

__all__ = ["prepare_ensemble"]


#: Steps between progress reports of the discarded phases.
REPORT_CHUNK = 100


def _run(sampler, state, n_steps: int, report, phase: str, done: int, total: int):
    """``sampler.run_mcmc`` for ``n_steps`` in chunks of :data:`REPORT_CHUNK`, calling ``report(phase, steps done,
    total)`` after each (the chain and the random stream are those of one call)."""
    left = n_steps
    while left > 0:
        m = min(REPORT_CHUNK, left)
        # the jittered or adapted walkers may make emcee's heuristic condition-number check fire
        state = sampler.run_mcmc(state, m, progress=False, skip_initial_state_check=True)
        left -= m
        if report is not None:
            report(phase, done + n_steps - left, total)
    return state


def _prune_burn_in(problem, p0, options, seed, report=None) -> np.ndarray:
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
    total = options.prune_rounds * options.prune_steps
    state = _run(sampler, p0, options.prune_steps, report, "pruning", 0, total)
    delta = ndim / 2 + 5 * np.sqrt(ndim / 2) + 5
    for r in range(1, options.prune_rounds):
        coords, lp = state.coords.copy(), state.log_prob.copy()
        good = lp >= lp.max() - delta
        bad = np.flatnonzero(~good)
        if bad.size:
            src = rs.choice(np.flatnonzero(good), bad.size)
            spread = coords[good].std(axis=0) + 1e-8
            coords[bad] = coords[src] + 1e-2 * spread * rs.standard_normal((bad.size, ndim))
            lp[bad] = problem.log_posterior_unconstrained(coords[bad])
        state = emcee.State(coords, log_prob=lp, random_state=sampler.random_state)
        state = _run(sampler, state, options.prune_steps, report, "pruning", r * options.prune_steps, total)
    return state.coords


def _moves(name: str, mixture: TMixture | None = None):
    """emcee moves ``name`` (pre-runs of an adaptive mixture use DE 0.8 / DE-snooker 0.2)."""
    if name in ADAPTIVE_MOVES and mixture is None:
        name = "de_snooker"
    return MOVES[name](mixture)


def _adapt_mixture(problem, p0, options, seed, report=None) -> tuple[TMixture, np.ndarray, np.ndarray]:
    """Adaptation phase of the ``mixture`` proposal: ``options.adapt_rounds`` rounds of
    ``options.adapt_steps`` steps (the first with DE/snooker, the next with the mixture fitted so
    far), refitting to the second half of every round. Discarded; deterministic given ``seed``.
    Returns the frozen mixture, the walkers' positions and the draws it was fitted to."""
    nw, ndim = p0.shape
    rs = np.random.RandomState((seed + 2) % (2**32 - 1))
    mixture, coords = None, p0
    total = options.adapt_rounds * options.adapt_steps
    for r in range(options.adapt_rounds):
        sampler = emcee.EnsembleSampler(
            nw, ndim, problem.log_posterior_unconstrained, vectorize=True, moves=_moves(options.moves, mixture)
        )
        sampler.random_state = rs.get_state()
        state = _run(sampler, coords, options.adapt_steps, report, "adaptation", r * options.adapt_steps, total)
        rs.set_state(sampler.random_state)
        coords = state.coords
        draws = sampler.get_chain(discard=options.adapt_steps // 2, flat=True)
        mixture = fit_t_mixture(draws, n_components=options.mixture_components, seed=int(rs.randint(2**31 - 1)))
    return mixture, coords, draws


def prepare_ensemble(problem, p0, *, options: SamplerOptions, seed: int, report=None):
    """The discarded phases of :func:`run_ensemble` (pruning, then the mixture's adaptation for
    adaptive moves): returns ``(start, mixture, draws)``, the production start, the fitted mixture
    and the last adaptation round's draws it was fitted to (both None without adaptation).
    Deterministic given ``seed``; :func:`sample_posterior` fits a shared proposal to all ensembles'
    draws. ``report(phase, steps done, steps of the phase)`` every :data:`REPORT_CHUNK` steps, phase ``"pruning"``
    or ``"adaptation"``."""
    p0 = np.asarray(p0, dtype=float)
    if not emcee.ensemble.walkers_independent(p0):
        raise ValidationError("initial walkers", "linearly dependent positions", "independent walkers")
    p0 = _prune_burn_in(problem, p0, options, seed, report)
    if options.moves not in ADAPTIVE_MOVES:
        return p0, None, None
    mixture, start, draws = _adapt_mixture(problem, p0, options, seed, report)
    return start, mixture, draws


def _length_ok(chain: np.ndarray, options: SamplerOptions) -> tuple[bool, np.ndarray]:
    """The automatic-length criterion at the end of ``chain``; returns (ok, tau).

    ``n >= tau_factor * max(tau)``, and tau trusted: every tau changed by less than ``tau_rtol`` since ``check_every``
    steps earlier, or the chain is at least twice as long as the rule asks (``n >= 2 tau_factor max(tau)`` at both
    checks' tau). The stability test guards against a tau estimated too short early on, while the chain has not yet
    seen its slowest direction (the estimate then grows from check to check; emcee's documentation, after Sokal
    1997). Once the chain is 100 tau long, the estimator's own scatter (a few per cent: its relative sd is about
    :math:`\\sqrt{2 c\\,\\tau / n}` per walker, window ``c = 5``) exceeds the 1 % test, which then holds back runs
    that have long met the rule (issue 34: R-hat 1.000, bulk ESS 19 000, tau 14-18 steps, refused), while a tau
    that is still growing would need to double before the 50-tau rule failed."""
    n = chain.shape[0]
    tau = _tau(chain)
    every = options.check_every
    if n < 2 * every or n < options.min_steps:
        return False, tau
    prev = _tau(chain[: n - every])
    stable = bool(np.all(np.abs(prev - tau) / tau < options.tau_rtol))
    long_enough = n >= 2.0 * options.tau_factor * max(np.max(tau), np.max(prev))
    return bool(n >= options.tau_factor * np.max(tau) and (stable or long_enough)), tau


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
