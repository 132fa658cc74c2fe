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

The second engine, :func:`sample_nested` (:mod:`~bayestissue.inference.sampling.nested`), runs independent
nautilus importance nested sampling runs from the prior: no start, any number of modes, and the evidence.
"""

from bayestissue.inference.sampling.ensemble import EnsembleResult, run_ensemble
from bayestissue.inference.sampling.nested import NestedOptions, NestedRun, NestedSample, sample_nested
from bayestissue.inference.sampling.options import ADAPTIVE_MOVES, MOVES, PROPOSALS, SamplerOptions
from bayestissue.inference.sampling.phases import prepare_ensemble
from bayestissue.inference.sampling.runner import PosteriorSample, sample_posterior
from bayestissue.inference.sampling.start import initial_walkers

__all__ = [
    "ADAPTIVE_MOVES",
    "MOVES",
    "PROPOSALS",
    "EnsembleResult",
    "NestedOptions",
    "NestedRun",
    "NestedSample",
    "PosteriorSample",
    "SamplerOptions",
    "initial_walkers",
    "prepare_ensemble",
    "run_ensemble",
    "sample_nested",
    "sample_posterior",
]
