"""Sampler options and the registry of emcee move mixtures (see :mod:`bayestissue.inference.sampling`)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import emcee
import numpy as np

from bayestissue._validation import ValidationError, check_positive
from bayestissue.inference.proposals import MixtureMove
from bayestissue.inference.sampling.cluster import check_scheduler

__all__ = ["MOVES", "ADAPTIVE_MOVES", "PROPOSALS", "SamplerOptions"]

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
    n_processes : parallel processes; default ``min(n_ensembles, os.cpu_count())``; with ``scheduler = "local"`` the
        LocalCluster's workers.
    scheduler : where the ensembles go: None (forked processes of this machine), ``"local"`` (dask tasks on a
        LocalCluster started for the call) or a dask scheduler's address (docs/cluster.md).
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
    scheduler: str | None = None

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
        check_scheduler(self.scheduler)
        check_positive("tau_factor", self.tau_factor)
        check_positive("tau_rtol", self.tau_rtol)
        check_positive("scatter", self.scatter)

    def walkers(self, ndim: int) -> int:
        """Walkers for ``ndim`` parameters (even, >= 2 ndim + 2)."""
        n = self.n_walkers if self.n_walkers is not None else 4 * ndim
        n = max(int(n), 2 * ndim + 2)
        return n + (n % 2)
