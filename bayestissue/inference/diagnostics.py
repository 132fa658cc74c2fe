"""Convergence diagnostics for independent emcee ensembles.

* Integrated autocorrelation time :math:`\\hat\\tau` per parameter and ensemble (emcee's estimator,
  Goodman & Weare 2010) and the length criterion :math:`N \\ge 50\\,\\hat\\tau`.
* Acceptance fraction per walker; a walker is *stuck* when its acceptance is below ``max(floor, rel
  * median)``.
* Rank-normalised split :math:`\\hat R` (Vehtari et al. 2021, doi:10.1214/20-BA1221) with one chain
  per *ensemble*: walkers of one ensemble interact, so treating them as independent chains
  understates :math:`\\hat R`; each ensemble's post-burn-in draws are flattened (step-major) into
  one chain.
* Bulk and tail ESS (Vehtari et al. 2021) with every walker as a chain: the autocorrelation is
  estimated along each walker's own trajectory.

* Ensembles apart (:func:`ensembles_apart`): when :math:`\\hat R` fails, which ensembles sit away from
  the others and whether they found a mode as high as the others' (a multimodal posterior) or a
  lower one (a stuck ensemble). Each parameter's pooled draws are rank-normalised,
  :math:`s = \\Phi^{-1}((r - 3/8) / (N + 1/4))` (the normal scores of rank-normalised
  :math:`\\hat R`); ensemble *e* is apart in a parameter when its median score differs from the
  median of the other ensembles' median scores by more than ``threshold`` (default 1, i.e. one sd of
  the pooled posterior). Its best log-posterior within 2 of the others' best: a region as high as
  theirs (a second mode, or a flat ridge the ensembles have not crossed yet); lower: a lower mode.

Verdict (:func:`assess_convergence`): :math:`\\hat R < 1.01`, bulk and tail ESS :math:`\\ge 400` for
every sampled parameter, and every ensemble at least :math:`50\\hat\\tau` long with a stable
:math:`\\hat\\tau` (changed by < 1 % over the last check, or the ensemble 100 tau long:
:func:`bayestissue.inference.sampling.phases._length_ok`).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
from scipy.special import ndtri
from scipy.stats import rankdata

from bayestissue._validation import ValidationError

__all__ = [
    "runs_mean_error",
    "import_arviz",
    "rhat_ensembles",
    "ess_walkers",
    "stuck_walkers",
    "ensembles_apart",
    "ParameterChecks",
    "ConvergenceReport",
    "assess_convergence",
    "quantile_mcse",
]


def import_arviz():
    """Import arviz with its once-a-day refactor FutureWarning silenced (see docs/dependencies.md)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FutureWarning)
        import arviz as az
    return az


def _check_draws(draws) -> np.ndarray:
    d = np.asarray(draws, dtype=float)
    if d.ndim != 4 or d.shape[0] < 2 or d.shape[1] < 4:
        raise ValidationError(
            "draws",
            f"array of shape {d.shape}",
            "shape (n_ensembles >= 2, n_draws >= 4, n_walkers, ndim)",
        )
    return d


def rhat_ensembles(draws) -> np.ndarray:
    """Rank-normalised split R-hat with one chain per ensemble.

    Parameters
    ----------
    draws : (n_ensembles, n_draws, n_walkers, ndim) post-burn-in draws.

    Returns
    -------
    (ndim,) ndarray
    """
    az = import_arviz()
    d = _check_draws(draws)
    n_ens, n, nw, ndim = d.shape
    chains = d.reshape(n_ens, n * nw, ndim)
    return np.array([float(az.rhat(chains[:, :, j], method="rank")) for j in range(ndim)])


def ess_walkers(draws, *, method: str = "bulk") -> np.ndarray:
    """Bulk or tail ESS with every walker of every ensemble as a chain, ``(ndim,)``."""
    az = import_arviz()
    d = _check_draws(draws)
    n_ens, n, nw, ndim = d.shape
    chains = d.transpose(0, 2, 1, 3).reshape(n_ens * nw, n, ndim)
    return np.array([float(az.ess(chains[:, :, j], method=method)) for j in range(ndim)])


def stuck_walkers(acceptance, *, rel: float = 0.3, floor: float = 0.0) -> np.ndarray:
    """Boolean flags for walkers whose acceptance is below ``max(floor, rel * median
    acceptance)``."""
    acc = np.asarray(acceptance, dtype=float)
    return (acc < max(floor, rel * float(np.median(acc)))) | (acc == 0)


def ensembles_apart(draws, log_prob, *, threshold: float = 1.0) -> list[tuple[int, list[int], float]]:
    """Ensembles whose draws sit away from the other ensembles' (see the module docstring).

    Parameters
    ----------
    draws : (n_ensembles, n_draws, n_walkers, ndim) post-burn-in draws.
    log_prob : (n_ensembles, n_draws, n_walkers) their log-posterior.
    threshold : shift of the median normal score (pooled sd units) that counts as apart.

    Returns
    -------
    list of ``(ensemble, parameter indices, best log-posterior of the ensemble minus the best of the
    others)``, one per ensemble apart; empty when all ensembles agree.
    """
    d = _check_draws(draws)
    lp = np.asarray(log_prob, dtype=float)
    if lp.shape != d.shape[:3]:
        raise ValidationError("log_prob", f"array of shape {lp.shape}", f"shape {d.shape[:3]} (as draws)")
    n_ens, ndim = d.shape[0], d.shape[-1]
    flat = d.reshape(-1, ndim)
    scores = ndtri((rankdata(flat, axis=0) - 0.375) / (flat.shape[0] + 0.25)).reshape(n_ens, -1, ndim)
    med = np.median(scores, axis=1)  # (n_ens, ndim)
    best = np.max(np.where(np.isfinite(lp), lp, -np.inf).reshape(n_ens, -1), axis=1)
    out = []
    for e in range(n_ens):
        others = np.delete(np.arange(n_ens), e)
        apart = np.flatnonzero(np.abs(med[e] - np.median(med[others], axis=0)) > threshold)
        if apart.size:
            out.append((e, apart.tolist(), float(best[e] - best[others].max())))
    return out


class ParameterChecks:
    """The per-parameter criteria of both engines' verdicts: R-hat below ``rhat_max``, bulk and tail ESS at least
    ``ess_min``. Base of :class:`ConvergenceReport` and :class:`~bayestissue.inference.evidence.NestedReport`, which
    carry ``rhat``, ``ess_bulk``, ``ess_tail``, ``rhat_max``, ``ess_min`` and ``time_s``."""

    @property
    def parameters_ok(self) -> np.ndarray:
        """``(ndim,)`` bool: every per-parameter criterion met (a NaN R-hat or ESS fails)."""
        return (self.rhat < self.rhat_max) & (self.ess_bulk >= self.ess_min) & (self.ess_tail >= self.ess_min)

    def ess_per_second(self) -> float:
        """Smallest bulk ESS divided by the wall time of the sampling."""
        return float(np.min(self.ess_bulk) / self.time_s) if self.time_s > 0 else np.nan

    def quantiles(self, draws) -> np.ndarray:
        """``(ndim, 3)`` the 5/50/95 % quantiles the summary reports, those whose errors :meth:`quantile_errors`
        gives: here of ``draws``; the nested engine's report pools its runs' weighted quantiles (its override)."""
        return np.quantile(draws, [0.05, 0.5, 0.95], axis=0).T

    def quantile_errors(self, draws) -> np.ndarray:
        """``(ndim, 3)`` Monte Carlo errors of the 5/50/95 % quantiles of ``draws``: from the bulk and tail ESS
        (:func:`quantile_mcse`); the nested engine's report has its runs' own (its override)."""
        return quantile_mcse(draws, self.ess_bulk, self.ess_tail)

    def advice(self) -> list[str]:
        """What a user can do about a NOT CONVERGED verdict, one line each (none here; the ensembles' report has
        its own)."""
        return []


@dataclass(frozen=True)
class ConvergenceReport(ParameterChecks):
    """Diagnostics of a :class:`~bayestissue.inference.sampling.PosteriorSample`."""

    names: tuple[str, ...]
    rhat: np.ndarray
    ess_bulk: np.ndarray
    ess_tail: np.ndarray
    tau: np.ndarray  # (n_ensembles, ndim), steps
    n_steps: np.ndarray  # (n_ensembles,)
    length_ok: np.ndarray  # (n_ensembles,)
    acceptance: np.ndarray  # (n_ensembles, n_walkers)
    stuck: np.ndarray  # (n_ensembles, n_walkers) bool
    n_draws: int
    rhat_max: float
    ess_min: float
    tau_factor: float
    time_s: float
    apart: tuple = ()  # ensembles_apart(...) entries, computed when R-hat fails
    engine_check: object = None  # an EngineCheck (bayestissue.inference.engine_check) when another engine ran

    @property
    def converged(self) -> bool:
        """Every criterion met, and no other engine's sample of the same posterior contradicts this one."""
        agree = self.engine_check is None or self.engine_check.agree
        return bool(np.all(self.parameters_ok) and np.all(self.length_ok) and agree)

    def verdict(self) -> str:
        """Plain-language verdict, one line per failed criterion."""
        lines = []
        bad_r = [n for n, r in zip(self.names, self.rhat, strict=False) if not r < self.rhat_max]
        bad_b = [n for n, e in zip(self.names, self.ess_bulk, strict=False) if not e >= self.ess_min]
        bad_t = [n for n, e in zip(self.names, self.ess_tail, strict=False) if not e >= self.ess_min]
        if bad_r:
            lines.append(f"R-hat >= {self.rhat_max} for {bad_r} (max {np.max(self.rhat):.3f})")
        if bad_b:
            lines.append(f"bulk ESS < {self.ess_min:g} for {bad_b}")
        if bad_t:
            lines.append(f"tail ESS < {self.ess_min:g} for {bad_t}")
        for e, idx, dlp in self.apart:
            if dlp > 2.0:
                kind = f"{dlp:+.1f} above theirs: a higher region the others have not reached"
            elif dlp > -2.0:
                kind = (
                    f"within 2 of theirs ({dlp:+.1f}): a region as high as theirs (a second mode, or a flat ridge "
                    "not crossed yet; a proposal shared by the ensembles, moves 'mixture' with proposal 'shared', "
                    "can jump between them)"
                )
            else:
                kind = f"{dlp:+.1f} from theirs: a lower mode it is stuck in"
            names = [self.names[j] for j in idx]
            lines.append(f"ensemble {e} apart from the others in {names}: best log-posterior {kind}")
        if not np.all(self.length_ok):
            short = np.flatnonzero(~self.length_ok)
            need = ", ".join(
                f"{k}: {self.n_steps[k]} of {self.tau_factor:g} x {np.max(self.tau[k]):.1f} = "
                f"{self.tau_factor * np.max(self.tau[k]):.0f} steps"
                for k in short
            )
            lines.append(
                f"ensembles {short.tolist()} shorter than {self.tau_factor:g} tau or tau not yet stable ({need}; "
                "production steps, pruning and adaptation not counted)"
            )
        if self.engine_check is not None and not self.engine_check.agree:
            lines.append(self.engine_check.text())
        n_stuck = int(self.stuck.sum())
        head = (
            f"CONVERGED: R-hat < {self.rhat_max} (max {np.max(self.rhat):.4f}), bulk ESS >= "
            f"{self.ess_min:g} (min {np.min(self.ess_bulk):.0f}), tail ESS >= {self.ess_min:g} "
            f"(min {np.min(self.ess_tail):.0f}), every ensemble >= {self.tau_factor:g} tau "
            f"(max tau {np.max(self.tau):.1f} steps)"
            if self.converged
            else "NOT CONVERGED: " + "; ".join(lines)
        )
        if self.converged and self.engine_check is not None:
            head += f"; {self.engine_check.text()}"
        if n_stuck:
            head += f". {n_stuck} stuck walker(s) flagged (acceptance well below the median)"
        return head

    def advice(self) -> list[str]:
        """What a user can do about a NOT CONVERGED verdict: one line per kind of failure (none when converged)."""
        if self.converged:
            return []
        out = []
        if not np.all(self.length_ok):
            need = self.tau_factor * np.max(self.tau[~self.length_ok])
            steps = int(np.ceil(1.5 * need / 1000.0) * 1000)  # tau still grows while a run is short: half again
            out.append(
                f"run longer: the same command with --resume and [sampler] max_steps = {steps} (a resume may raise "
                f"it; the ensembles go on from their checkpoints; 50 tau is {need:.0f} steps at today's tau)"
            )
        if self.apart:
            out.append(
                'ensembles in different regions: moves = "mixture" with proposal = "shared" lets each jump into a '
                'region another found; engine = "nested" needs no start at all'
            )
        elif not np.all(self.parameters_ok) and np.all(self.length_ok):
            out.append("R-hat or ESS short although every ensemble is long enough: raise [sampler] max_steps")
        if self.engine_check is not None and not self.engine_check.agree:
            out.append(
                "the two engines disagree (cross_check.md lists every quantile of both): where the nested ranges are "
                'the wider, run engine = "nested" for this posterior, or more ensembles from more starts ([sampler] '
                "n_ensembles, [warmstart] n_starts); where they are the narrower, more live points ([nested] n_live) "
                "for the check"
            )
        return out


def assess_convergence(
    sample, *, rhat_max: float = 1.01, ess_min: float = 400.0, tau_factor: float = 50.0
) -> ConvergenceReport:
    """Diagnostics and verdict of a :class:`~bayestissue.inference.sampling.PosteriorSample`."""
    draws = sample.draws()
    ens = sample.ensembles
    rhat = rhat_ensembles(draws)
    apart = ensembles_apart(draws, sample.kept_log_prob()) if np.any(~(rhat < rhat_max)) else []
    return ConvergenceReport(
        names=tuple(sample.names),
        rhat=rhat,
        ess_bulk=ess_walkers(draws, method="bulk"),
        ess_tail=ess_walkers(draws, method="tail"),
        tau=np.array([e.tau for e in ens]),
        n_steps=np.array([e.n_steps for e in ens]),
        length_ok=np.array([e.converged_length for e in ens]),
        acceptance=np.array([e.acceptance for e in ens]),
        stuck=np.array([stuck_walkers(e.acceptance) for e in ens]),
        n_draws=int(np.prod(draws.shape[:3])),
        rhat_max=rhat_max,
        ess_min=ess_min,
        tau_factor=tau_factor,
        time_s=float(sample.time_s),
        apart=tuple(apart),
    )


def quantile_mcse(draws, ess_bulk, ess_tail, levels=(0.05, 0.5, 0.95)) -> np.ndarray:
    """Monte Carlo error ``(ndim, len(levels))`` of the quantiles of ``draws`` ``(n, ndim)`` given each parameter's
    effective sample size: the bulk ESS for the median, the tail ESS for the others. The error of the probability
    level, :math:`\\sqrt{p(1-p)/n_\\text{eff}}`, is carried to the parameter's scale through the draws' own inverse
    CDF, :math:`(F^{-1}(p + \\sigma_p) - F^{-1}(p - \\sigma_p))/2` (Vehtari et al. 2021, doi:10.1214/20-BA1221,
    section 4.3); for independent normal draws it tends to :math:`\\sqrt{p(1-p)/n}/\\phi(z_p)` sd."""
    x = np.asarray(draws, dtype=float)
    out = np.empty((x.shape[1], len(levels)))
    for k, p in enumerate(levels):
        ess = np.asarray(ess_bulk if p == 0.5 else ess_tail, dtype=float)
        for j in range(x.shape[1]):
            s = np.sqrt(p * (1.0 - p) / max(ess[j], 1.0))
            lo, hi = np.quantile(x[:, j], [max(p - s, 0.0), min(p + s, 1.0)])
            out[j, k] = 0.5 * (hi - lo)
    return out


def runs_mean_error(values, errors) -> np.ndarray:
    """Monte Carlo error of the mean of :math:`n` independent runs' estimates ``values`` (runs along axis 0) with
    their own errors ``errors`` (same shape): the larger of the own errors combined,
    :math:`\\sqrt{\\sum_k \\sigma_k^2}/n`, and the runs' scatter over :math:`\\sqrt n`, :math:`s/\\sqrt n` (one
    run: its own error). Runs that agree are judged by their own errors; runs that scatter more, by the scatter."""
    v, e = np.asarray(values, dtype=float), np.asarray(errors, dtype=float)
    n = v.shape[0]
    own = np.sqrt(np.sum(e**2, axis=0)) / n
    scatter = v.std(axis=0, ddof=1) / np.sqrt(n) if n > 1 else 0.0
    return np.maximum(own, scatter)
