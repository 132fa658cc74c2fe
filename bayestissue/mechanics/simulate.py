"""``simulate``: the batched forward model of an experiment (what the sampler calls)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bayestissue.mechanics.experiment import Experiment
from bayestissue.mechanics.fibres import fibre_structure
from bayestissue.mechanics.tissue import check_parameters
from bayestissue.mechanics.uniaxial import solve_uniaxial_batch

__all__ = ["simulate", "SimulationResult"]


@dataclass(frozen=True)
class SimulationResult:
    """Full output of :func:`simulate` with ``full=True``.

    Attributes
    ----------
    displacement_mm : (n_sets, n_obs) ndarray
        x-displacement of the loaded face at the data times; NaN rows where the solve failed.
    ok : (n_sets,) bool ndarray
    step_time_s : (n_steps + 1,) ndarray
        Simulation grid.
    step_displacement_mm : (n_sets, n_steps + 1) ndarray
    strain : (n_sets, n_steps + 1, 6) ndarray
        Green strain, Voigt order E11, E22, E33, E12, E13, E23.
    tension_kpa : (n_sets, n_steps + 1, n_f) ndarray
        Fibre tensions tau_k.
    nominal_stress_kpa : (n_steps + 1,) ndarray
        Applied P11.
    iterations : (n_sets,) ndarray of int
        Newton iterations plus line-search halvings over the whole run (cost diagnostic).
    """

    displacement_mm: np.ndarray
    ok: np.ndarray
    step_time_s: np.ndarray
    step_displacement_mm: np.ndarray
    strain: np.ndarray
    tension_kpa: np.ndarray
    nominal_stress_kpa: np.ndarray
    iterations: np.ndarray


def simulate(experiment: Experiment, params, *, full: bool = False):
    """Simulate ``experiment`` for one or many parameter sets.

    Parameters
    ----------
    experiment : Experiment
    params : (n_params,) or (n_sets, n_params) array_like
        Material parameters in the paper's order (``experiment.tissue.param_names``). Every row is checked
        (moduli >= 0, gamma in [0, 1), beta > 0); a bad value raises.
    full : bool
        Return a :class:`SimulationResult` with strains and fibre tensions on the simulation grid.

    Returns
    -------
    (n_obs,) or (n_sets, n_obs) ndarray of displacements (mm) at ``experiment.time_s``, NaN rows for sets whose
    solve failed; or a SimulationResult if ``full``.
    """
    tissue = experiment.tissue
    p = check_parameters(params, tissue.param_names)
    single = p.ndim == 1
    p2 = np.ascontiguousarray(np.atleast_2d(p))
    n_sets = p2.shape[0]
    load = experiment.nominal_stress_kpa()
    n_t = load.size
    nf = tissue.n_fibres
    u = np.empty((n_sets, n_t))
    ok = np.empty(n_sets, dtype=np.bool_)
    shape_s = (n_sets, n_t, 6) if full else (1, 1, 6)
    shape_t = (n_sets, n_t, nf) if full else (1, 1, nf)
    strain = np.empty(shape_s)
    tension = np.empty(shape_t)
    iterations = np.zeros(n_sets, dtype=np.int64)
    solve_uniaxial_batch(
        p2,
        np.ascontiguousarray(fibre_structure(tissue.directions)),
        np.ascontiguousarray(tissue.phi_fibres),
        tissue.phi_matrix,
        tissue.bulk_kpa,
        np.ascontiguousarray(tissue.eps0),
        load,
        experiment.dt_s,
        experiment.specimen_mm[0],
        u,
        ok,
        strain,
        tension,
        full,
        iterations,
    )
    i, w = experiment.interpolation()
    obs = u[:, i] * (1.0 - w) + u[:, i + 1] * w
    if full:
        return SimulationResult(
            displacement_mm=obs,
            ok=ok,
            step_time_s=experiment.step_time_s,
            step_displacement_mm=u,
            strain=strain,
            tension_kpa=tension,
            nominal_stress_kpa=load,
            iterations=iterations,
        )
    return obs[0] if single else obs
