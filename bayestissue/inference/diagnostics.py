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

Verdict (:func:`assess_convergence`): :math:`\\hat R < 1.01`, bulk and tail ESS :math:`\\ge 400` for
every sampled parameter, and every ensemble at least :math:`50\\hat\\tau` long with a stable
:math:`\\hat\\tau`.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from bayestissue._validation import ValidationError

__all__ = [
    "import_arviz",
    "rhat_ensembles",
    "ess_walkers",
    "stuck_walkers",
    "ConvergenceReport",
    "assess_convergence",
]


def import_arviz():
    """Import arviz with its once-a-day refactor FutureWarning silenced (see DEPENDENCIES.md)."""
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


@dataclass(frozen=True)
class ConvergenceReport:
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

    @property
    def converged(self) -> bool:
        return bool(
            np.all(self.rhat < self.rhat_max)
            and np.all(self.ess_bulk >= self.ess_min)
            and np.all(self.ess_tail >= self.ess_min)
            and np.all(self.length_ok)
        )

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
        if not np.all(self.length_ok):
            lines.append(
                f"ensembles {np.flatnonzero(~self.length_ok).tolist()} shorter than "
                f"{self.tau_factor:g} tau or tau not yet stable"
            )
        n_stuck = int(self.stuck.sum())
        head = (
            f"CONVERGED: R-hat < {self.rhat_max} (max {np.max(self.rhat):.4f}), bulk ESS >= "
            f"{self.ess_min:g} (min {np.min(self.ess_bulk):.0f}), tail ESS >= {self.ess_min:g} "
            f"(min {np.min(self.ess_tail):.0f}), every ensemble >= {self.tau_factor:g} tau "
            f"(max tau {np.max(self.tau):.1f} steps)"
            if self.converged
            else "NOT CONVERGED: " + "; ".join(lines)
        )
        if n_stuck:
            head += f". {n_stuck} stuck walker(s) flagged (acceptance well below the median)"
        return head

    def ess_per_second(self) -> float:
        """Smallest bulk ESS divided by the wall time of the sampling."""
        return float(np.min(self.ess_bulk) / self.time_s) if self.time_s > 0 else np.nan


def assess_convergence(
    sample, *, rhat_max: float = 1.01, ess_min: float = 400.0, tau_factor: float = 50.0
) -> ConvergenceReport:
    """Diagnostics and verdict of a :class:`~bayestissue.inference.sampling.PosteriorSample`."""
    draws = sample.draws()
    ens = sample.ensembles
    return ConvergenceReport(
        names=tuple(sample.names),
        rhat=rhat_ensembles(draws),
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
    )
