"""The batched forward model of an experiment: :class:`ForwardModel` (what the sampler calls) and ``simulate``."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bayestissue.mechanics.experiment import Experiment
from bayestissue.mechanics.fibres import fibre_structure
from bayestissue.mechanics.solver import solve_batch
from bayestissue.mechanics.tissue import check_parameters

__all__ = ["ChannelForward", "ForwardModel", "simulate", "SimulationResult"]

#: The kernel's sensitivity output when none is asked for (never written).


@dataclass(frozen=True)
class SimulationResult:
    """Full output of :func:`simulate` with ``full=True``.

    Attributes
    ----------
    observed : (n_sets, n_obs) ndarray, or (n_sets, n_obs, n_channels) for several channels
        The experiment's observed channels (:attr:`Experiment.channels`) at the data times; NaN rows where the solve
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

    The load case's conditions on the simulation grid (:meth:`Experiment.prescribed` through the experiment's
    :class:`~bayestissue.mechanics.loadcases.LoadCase`), the laws' layout (:attr:`TissueConfig.layout`), the fibre
    structure tensors :math:`M_k = v_k \otimes v_k`, the contiguous volume fractions and slack strains, and the
    interpolation from the step grid to the data times (:meth:`Experiment.interpolation`) depend on the experiment
    only; a sampler calls the model millions of times with new parameters, so they are built here once and a call
    does the parameter check, the kernel (:func:`~bayestissue.mechanics.solver.solve_batch`) and the interpolation.
    The output is the experiment's observed channels (:attr:`Experiment.channels`): the displacement (mm) under force
    control, the force (mN) or nominal stress (kPa) under stretch control, a shear stress for simple shear; one
    channel gives ``(n_sets, n_obs)``, several ``(n_sets, n_obs, n_channels)`` (:meth:`channel` gives one of them).
    Picklable (a dask or multiprocessing worker rebuilds nothing but the object).

    Parameters
    ----------
    experiment : Experiment
    """

    def __init__(self, experiment: Experiment):
        tissue = experiment.tissue
        self.experiment = experiment
        self.specs = tissue.parameters
        self.names = tuple(p.name for p in self.specs)
        self.channels = experiment.channels
        self.stretch_control = experiment.controls == "stretch"
        self.load = experiment.prescribed()
        kinds, values = experiment.load_case.prescribe(self.load, experiment.controls)
        #: kernel output -> observable, per channel: 1 (mm, kPa) or a face's area (mN per kPa)
        self.scales = np.array([c.scale for c in self.channels])
        self.structure = np.ascontiguousarray(fibre_structure(tissue.directions).reshape(-1, 6))
        self.phi_fibres = np.ascontiguousarray(tissue.phi_fibres)
        self.eps0 = np.ascontiguousarray(tissue.eps0)
        self.index, self.weight = experiment.interpolation()
        #: the kernel's fixed inputs after the parameters, in its order (laws' layout, structure tensors, fibre
        #: fractions, matrix fraction, bulk modulus, slack strains, load case, step, specimen, channels)
        self.kernel_inputs = (
            tissue.layout,
            self.structure,
            self.phi_fibres,
            tissue.phi_matrix,
            tissue.bulk_kpa,
            self.eps0,
            kinds,
            np.ascontiguousarray(values),
            experiment.dt_s,
            np.asarray(experiment.specimen_mm, dtype=float),
            np.array([[c.kind, c.axis] for c in self.channels], dtype=np.int64),
        )
        self._memo = None

    def at_data_times(self, steps: np.ndarray) -> np.ndarray:
        """Interpolate ``(n_sets, n_steps + 1, ...)`` step values to the data times: ``(n_sets, n_obs, ...)``
        (:meth:`Experiment.interpolation`)."""
        i = self.index
        w = self.weight.reshape((-1,) + (1,) * (steps.ndim - 2))
        return steps[:, i] * (1.0 - w) + steps[:, i + 1] * w

    def _run(self, p2, full: bool, want_sens: bool):
        """One kernel run: ``(out, ok, strain, tension, iterations, dout)`` on the step grid."""
        n_sets, n_t, nf, n_ch = p2.shape[0], self.load.shape[0], self.experiment.tissue.n_fibres, len(self.channels)
        out = np.empty((n_sets, n_t, n_ch))
        ok = np.empty(n_sets, dtype=np.bool_)
        strain = np.empty((n_sets, n_t, 6) if full else (1, 1, 6))
        tension = np.empty((n_sets, n_t, nf) if full else (1, 1, nf))
        iterations = np.zeros(n_sets, dtype=np.int64)
        dout = np.empty((n_sets, n_t, n_ch, p2.shape[1])) if want_sens else None
        solve_batch(p2, *self.kernel_inputs, out, ok, strain, tension, full, iterations, dout)
        return out, ok, strain, tension, iterations, dout

    def _observed(self, steps: np.ndarray) -> np.ndarray:
        """Channel values at the steps -> observables at the data times, ``(n_sets, n_obs[, n_ch])``."""
        obs = self.at_data_times(steps)
        if np.any(self.scales != 1.0):
            obs = obs * self.scales.reshape((1, 1, -1) + (1,) * (obs.ndim - 3))
        return obs[:, :, 0] if len(self.channels) == 1 else obs

    def __call__(self, params, *, full: bool = False):
        """The observed channels at the data times for ``params`` ``(n_sets, n_params)``: ``(n_sets, n_obs)`` for
        one channel (``(n_obs,)`` for one set), ``(n_sets, n_obs, n_channels)`` for several; a
        :class:`SimulationResult` if ``full`` (see :func:`simulate`)."""
        p = check_parameters(params, self.specs)
        single = p.ndim == 1
        p2 = np.ascontiguousarray(np.atleast_2d(p))
        n_sets, n_t, nf, n_ch = p2.shape[0], self.load.shape[0], self.experiment.tissue.n_fibres, len(self.channels)
        out = np.empty((n_sets, n_t, n_ch))
        ok = np.empty(n_sets, dtype=np.bool_)
        strain = np.empty((n_sets, n_t, 6) if full else (1, 1, 6))
        tension = np.empty((n_sets, n_t, nf) if full else (1, 1, nf))
        iterations = np.zeros(n_sets, dtype=np.int64)
        solve_batch(p2, *self.kernel_inputs, out, ok, strain, tension, full, iterations, None)
        obs = self._observed(out)
        if full:
            return self._result(obs, out, ok, strain, tension, iterations)
        return obs[0] if single else obs

    def channel(self, c: int) -> ChannelForward:
        """A forward of channel ``c`` alone (its own noise model in a calibration); channels evaluated at the same
        parameters share one kernel run."""
        return ChannelForward(self, c)

    def _memoised(self, params):
        """All channels at ``params`` (2-D), re-using the last run for the same parameters."""
        p2 = np.ascontiguousarray(np.atleast_2d(np.asarray(params, dtype=float)))
        if self._memo is not None and self._memo[0].shape == p2.shape and np.array_equal(self._memo[0], p2):
            return self._memo[1]
        obs = self(p2)
        obs = obs[:, :, None] if obs.ndim == 2 else obs
        self._memo = (p2.copy(), obs)
        return obs

    def _result(self, obs, out, ok, strain, tension, iterations) -> SimulationResult:
        """Both the displacement and the stress of face 1 at the steps, whichever the kernel computed."""
        e = self.experiment
        first = self.channels[0]
        load = self.load if self.load.ndim == 1 else self.load[:, 0]  # face 1 of a two-history biaxial test
        if first.kind == 0:
            disp = out[:, :, 0]
            stress = np.where(ok[:, None], load[None, :], np.nan)
        else:
            stress = out[:, :, 0]
            lam = load if self.stretch_control else np.sqrt(1.0 + 2.0 * strain[:, :, 0])
            disp = np.where(ok[:, None], (lam - 1.0) * e.specimen_mm[0], np.nan)
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
        r"""The observed channels and their exact parameter derivatives at the data times.

        Returns ``y`` as :meth:`__call__` and ``dy`` ``(n_sets, n_obs[, n_ch], n_params)`` with
        ``dy[s, i, ..., j] = \partial y_i / \partial p_j`` in the parameters' own units (per kPa, per 1, per 1/s),
        from one forward run that differentiates every converged step (:mod:`~bayestissue.mechanics.sensitivity`);
        interpolated to the data times like ``y``. ``(n_obs,)`` and ``(n_obs, n_params)`` for one set; NaN rows for
        failed sets.
        """
        p = check_parameters(params, self.specs)
        single = p.ndim == 1
        p2 = np.ascontiguousarray(np.atleast_2d(p))
        out, ok, strain, tension, iterations, dout = self._run(p2, False, True)
        y = self._observed(out)
        dobs = self.at_data_times(dout)  # (n_sets, n_obs, n_ch, n_p)
        if np.any(self.scales != 1.0):
            dobs = dobs * self.scales[None, None, :, None]
        if len(self.channels) == 1:
            dobs = dobs[:, :, 0]
        return (y[0], dobs[0]) if single else (y, dobs)


class ChannelForward:
    """One channel of a :class:`ForwardModel` as a forward of its own: ``(n_sets, n_obs)`` at ``params``."""

    def __init__(self, model: ForwardModel, c: int):
        self.model, self.c = model, int(c)
        self.names = model.names
        self.channel = model.channels[self.c]

    def __call__(self, params):
        single = np.asarray(params).ndim == 1
        obs = self.model._memoised(params)[:, :, self.c]
        return obs[0] if single else obs

    def sensitivities(self, params):
        y, dy = self.model.sensitivities(params)
        if len(self.model.channels) == 1:
            return y, dy
        return y[..., self.c], dy[..., self.c, :]


def simulate(experiment: Experiment, params, *, full: bool = False):
    """Simulate ``experiment`` for one or many parameter sets (one call of a new :class:`ForwardModel`).

    Parameters
    ----------
    experiment : Experiment
    params : (n_params,) or (n_sets, n_params) array_like
        Material parameters in the tissue's order (``experiment.tissue.param_names``). Every row is checked against
        its specification (moduli >= 0, gamma in [0, 1), beta > 0, ...); a bad value raises.
    full : bool
        Return a :class:`SimulationResult` with strains and fibre tensions on the simulation grid.

    Returns
    -------
    (n_obs,) or (n_sets, n_obs) ndarray of the observable at ``experiment.time_s`` (displacements in mm under force
    control, forces in mN or nominal stresses in kPa under stretch control; a last axis per channel where the load
    case observes several), NaN rows for sets whose solve failed; or a SimulationResult if ``full``.
    """
    return ForwardModel(experiment)(params, full=full)
