"""The batched forward model of an experiment: :class:`ForwardModel` (what the sampler calls) and ``simulate``."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bayestissue.mechanics.experiment import Experiment
from bayestissue.mechanics.fibres import fibre_structure
from bayestissue.mechanics.sensitivity import sensitivities_uniaxial_batch
from bayestissue.mechanics.tissue import check_parameters
from bayestissue.mechanics.uniaxial import solve_uniaxial_batch

__all__ = ["ForwardModel", "simulate", "SimulationResult"]


@dataclass(frozen=True)
class SimulationResult:
    """Full output of :func:`simulate` with ``full=True``.

    Attributes
    ----------
    observed : (n_sets, n_obs) ndarray
        The experiment's observable (:attr:`Experiment.observable`) at the data times; NaN rows where the solve
        failed.
    displacement_mm, force_mN : (n_sets, n_obs) ndarray
        x-displacement of the loaded face and the force on it at the data times (one of them prescribed, the other
        computed).
    ok : (n_sets,) bool ndarray
    step_time_s : (n_steps + 1,) ndarray
        Simulation grid.
    step_displacement_mm, step_stress_kpa : (n_sets, n_steps + 1) ndarray
        Displacement and nominal stress P11 at the simulation steps.
    strain : (n_sets, n_steps + 1, 6) ndarray
        Green strain, Voigt order E11, E22, E33, E12, E13, E23.
    tension_kpa : (n_sets, n_steps + 1, n_f) ndarray
        Fibre tensions tau_k.
    iterations : (n_sets,) ndarray of int
        Newton iterations plus line-search halvings over the whole run (cost diagnostic).
    """

    observed: np.ndarray
    displacement_mm: np.ndarray
    force_mN: np.ndarray
    ok: np.ndarray
    step_time_s: np.ndarray
    step_displacement_mm: np.ndarray
    step_stress_kpa: np.ndarray
    strain: np.ndarray
    tension_kpa: np.ndarray
    iterations: np.ndarray


class ForwardModel:
    r"""The batched forward model of one experiment, with its fixed inputs computed once.

    The load history on the simulation grid (:meth:`Experiment.prescribed`: :math:`P_{11}(t_n)` under force
    control, the stretch :math:`\lambda(t_n)` under stretch control), the fibre structure tensors
    :math:`M_k = v_k \otimes v_k`, the contiguous volume fractions and slack strains, and the interpolation
    from the step grid to the data times (:meth:`Experiment.interpolation`) depend on the experiment only;
    a sampler calls the model millions of times with new parameters, so they are built here once and a call
    does the parameter check, the kernel (:func:`~bayestissue.mechanics.uniaxial.solve_uniaxial_batch`) and
    the interpolation. The output is the experiment's observable (:attr:`Experiment.observable`): the
    displacement (mm) under force control, the force (mN, :math:`P_{11} L_y L_z`) or nominal stress (kPa) under
    stretch control. Picklable (a dask or multiprocessing worker rebuilds nothing but the object).

    Parameters
    ----------
    experiment : Experiment
    """

    def __init__(self, experiment: Experiment):
        tissue = experiment.tissue
        self.experiment = experiment
        self.names = tissue.param_names
        self.stretch_control = experiment.controls == "stretch"
        self.load = experiment.prescribed()
        #: kernel output -> observable: 1 (displacement, nominal stress) or the cross-section (force, mN per kPa)
        self.scale = experiment.area_mm2 if experiment.observable[0] == "force" else 1.0
        self.structure = np.ascontiguousarray(fibre_structure(tissue.directions))
        self.phi_fibres = np.ascontiguousarray(tissue.phi_fibres)
        self.eps0 = np.ascontiguousarray(tissue.eps0)
        self.index, self.weight = experiment.interpolation()
        #: the kernels' fixed inputs after the parameters, in their order (structure tensors, fibre fractions,
        #: matrix fraction, bulk modulus, slack strains, load, step, specimen length)
        self.kernel_inputs = (
            self.structure,
            self.phi_fibres,
            tissue.phi_matrix,
            tissue.bulk_kpa,
            self.eps0,
            self.load,
            experiment.dt_s,
            experiment.specimen_mm[0],
        )

    def at_data_times(self, steps: np.ndarray) -> np.ndarray:
        """Interpolate ``(n_sets, n_steps + 1, ...)`` step values to the data times: ``(n_sets, n_obs, ...)``
        (:meth:`Experiment.interpolation`)."""
        i = self.index
        w = self.weight.reshape((-1,) + (1,) * (steps.ndim - 2))
        return steps[:, i] * (1.0 - w) + steps[:, i + 1] * w

    def __call__(self, params, *, full: bool = False):
        """The observable ``(n_sets, n_obs)`` at the data times for ``params`` ``(n_sets, n_params)``;
        ``(n_obs,)`` for one set; a :class:`SimulationResult` if ``full`` (see :func:`simulate`)."""
        tissue = self.experiment.tissue
        p = check_parameters(params, self.names)
        single = p.ndim == 1
        p2 = np.ascontiguousarray(np.atleast_2d(p))
        n_sets, n_t, nf = p2.shape[0], self.load.size, tissue.n_fibres
        u = np.empty((n_sets, n_t))
        ok = np.empty(n_sets, dtype=np.bool_)
        strain = np.empty((n_sets, n_t, 6) if full else (1, 1, 6))
        tension = np.empty((n_sets, n_t, nf) if full else (1, 1, nf))
        iterations = np.zeros(n_sets, dtype=np.int64)
        solve_uniaxial_batch(p2, *self.kernel_inputs, u, ok, strain, tension, full, iterations, self.stretch_control)
        obs = self.at_data_times(u)
        if self.scale != 1.0:
            obs *= self.scale
        if full:
            return self._result(obs, u, ok, strain, tension, iterations)
        return obs[0] if single else obs

    def _result(self, obs, u, ok, strain, tension, iterations) -> SimulationResult:
        """Both the displacement and the stress at the steps, whichever the kernel computed."""
        e = self.experiment
        if self.stretch_control:
            stress = u
            disp = np.where(ok[:, None], (self.load[None, :] - 1.0) * e.specimen_mm[0], np.nan)
        else:
            disp = u
            stress = np.where(ok[:, None], self.load[None, :], np.nan)
        return SimulationResult(
            observed=obs,
            displacement_mm=self.at_data_times(disp),
            force_mN=self.at_data_times(stress) * e.area_mm2,
            ok=ok,
            step_time_s=e.step_time_s,
            step_displacement_mm=disp,
            step_stress_kpa=stress,
            strain=strain,
            tension_kpa=tension,
            iterations=iterations,
        )

    def sensitivities(self, params) -> tuple[np.ndarray, np.ndarray]:
        r"""The observable and its exact parameter derivatives at the data times.

        Returns ``y`` ``(n_sets, n_obs)`` (:meth:`__call__`: mm, or mN / kPa under stretch control) and ``dy``
        ``(n_sets, n_obs, n_params)`` with ``dy[s, i, j] = \partial y_i / \partial p_j`` in the parameters' own
        units (per kPa, per 1, per 1/s), from a forward run and one differentiation pass over its converged states
        (:func:`~bayestissue.mechanics.sensitivity.sensitivities_uniaxial_batch`); interpolated to the data times
        like ``y``. ``(n_obs,)`` and ``(n_obs, n_params)`` for one set; NaN rows for failed sets.
        """
        p = check_parameters(params, self.names)
        single = p.ndim == 1
        p2 = np.ascontiguousarray(np.atleast_2d(p))
        run = self(p2, full=True)
        du = np.empty((p2.shape[0], self.load.size, p2.shape[1]))
        sensitivities_uniaxial_batch(
            p2, *self.kernel_inputs, run.strain, run.tension_kpa, run.ok, du, self.stretch_control
        )
        dobs = self.at_data_times(du)
        if self.scale != 1.0:
            dobs *= self.scale
        y = run.observed
        return (y[0], dobs[0]) if single else (y, dobs)


def simulate(experiment: Experiment, params, *, full: bool = False):
    """Simulate ``experiment`` for one or many parameter sets (one call of a new :class:`ForwardModel`).

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
    (n_obs,) or (n_sets, n_obs) ndarray of the observable at ``experiment.time_s`` (displacements in mm under force
    control, forces in mN or nominal stresses in kPa under stretch control), NaN rows for sets whose solve failed;
    or a SimulationResult if ``full``.
    """
    return ForwardModel(experiment)(params, full=full)
