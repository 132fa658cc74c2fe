"""The calibration problem: experiments + parameter specification + noise models -> log-posterior.

The problem object is the one thing the stages share (warm start, sampler, identifiability): it
knows nothing about mechanics. Each experiment brings a *forward* callable

    ``forward(params) -> predictions``,  ``params`` ``(n_sets, n_material)`` -> ``(n_sets, n_obs)``,

with a NaN row for a parameter set whose solve failed (:class:`bayestissue.mechanics.ForwardModel`
of an experiment is one). ``n_material`` counts all material parameters, fixed ones included, in the
order of the material :class:`~bayestissue.inference.parameters.ParameterSet`.

The sampled vector ``theta`` is the sampled material parameters followed by each experiment's
sampled nuisance parameters (``sigma_<name>``, ``rho_<name>``). The posterior is

.. math::

    \\log p(\\theta \\mid y) = \\sum_{e} \\sum_t \\log p(y_{e,t} \\mid u_{e,t}(\\theta_m),
    \\theta_{n,e})
    + \\sum_i \\log p_i(\\theta_i) + \\text{const},

with box priors (:mod:`bayestissue.inference.priors`); the sampler targets it in the unconstrained
space :math:`z` with the log-Jacobian added
(:meth:`CalibrationProblem.log_posterior_unconstrained`). A failed forward solve gives
:math:`-\\infty` and is counted in :attr:`CalibrationProblem.n_failed`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from bayestissue._validation import ValidationError
from bayestissue.inference.coordinates import make_coordinates
from bayestissue.inference.likelihood import GaussianNoise, NoiseModel, _tag
from bayestissue.inference.ordering import folded
from bayestissue.inference.parameters import ParameterSet

__all__ = ["ExperimentTerm", "CalibrationProblem"]


@dataclass(frozen=True)
class ExperimentTerm:
    """One experiment in the likelihood.

    Parameters
    ----------
    name : str
        Label (``T1``); names the nuisance parameters and the output variables.
    time_s : (n_obs,) ndarray
        Data times.
    observed : (n_obs,) ndarray
        Observed data (the experiment's observable: a displacement in mm, a force in mN ...); must be finite.
    forward : callable
        ``(n_sets, n_material) -> (n_sets, n_obs)`` predictions, NaN rows for failed solves.
    noise : NoiseModel
        Residual model (default: Gaussian with unknown sd).
    meta : dict
        Free-form provenance (data file, hash ...).
    unit : str
        Unit of the observed data and of the noise sd (default mm, a displacement).
    sensitivities : callable, optional
        ``(n_sets, n_material) -> (predictions (n_sets, n_obs), derivatives (n_sets, n_obs, n_material))``: exact
        derivatives of the predictions with respect to the forward model's inputs (NaN rows for failed solves);
        enables :meth:`CalibrationProblem.residual_jacobian`.
    """

    name: str
    time_s: np.ndarray
    observed: np.ndarray
    forward: Callable[[np.ndarray], np.ndarray]
    noise: NoiseModel = field(default_factory=GaussianNoise)
    meta: dict = field(default_factory=dict)
    unit: str = "mm"
    sensitivities: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]] | None = None

    def __post_init__(self):
        t = np.asarray(self.time_s, dtype=float)
        y = np.asarray(self.observed, dtype=float)
        if y.ndim != 1 or y.shape != t.shape or y.size < 2:
            raise ValidationError(
                f"experiment {self.name} data",
                f"time shape {t.shape}, observed shape {y.shape}",
                "two 1-D arrays of equal length >= 2",
            )
        bad = np.flatnonzero(~np.isfinite(y))
        if bad.size:
            raise ValidationError(
                f"experiment {self.name} observed data",
                f"{y[bad[0]]} at row {bad[0]}",
                "finite values",
                f"{bad.size} non-finite value(s); remove or interpolate them",
            )
        if not np.all(np.isfinite(t)):
            raise ValidationError(f"experiment {self.name} time_s", "non-finite", "finite values")
        if not callable(self.forward):
            raise ValidationError(f"experiment {self.name} forward", self.forward, "a callable")
        if not isinstance(self.noise, NoiseModel):
            raise ValidationError(f"experiment {self.name} noise", self.noise, "a NoiseModel")
        object.__setattr__(self, "time_s", t)
        object.__setattr__(self, "observed", y)


class CalibrationProblem:
    """Experiments sharing material parameters, each with its own noise model.

    Parameters
    ----------
    experiments : sequence of ExperimentTerm
        One or several experiments (unique names).
    material : ParameterSet
        Material parameters (the forward models' inputs), sampled and fixed.
    exchangeable : two parameter groups whose exchange leaves the likelihood unchanged (see
        :meth:`log_prior`).
    coordinates : the sampler's coordinate system: ``"box"`` or a factory ``f(problem) -> coordinates``
        (:mod:`bayestissue.inference.coordinates`; the physics-aware ones: :mod:`bayestissue.workflows.coordinates`).

    Attributes
    ----------
    parameters : ParameterSet
        Material parameters followed by the experiments' nuisance parameters.
    n_evaluations, n_failed : int
        Parameter sets evaluated by the forward models and how many of them failed (NaN
        predictions).
    """

    def __init__(
        self,
        experiments: Sequence[ExperimentTerm],
        material: ParameterSet,
        *,
        exchangeable: Sequence[Sequence[str]] | None = None,
        coordinates="box",
    ):
        experiments = tuple(experiments)
        if not experiments or not all(isinstance(e, ExperimentTerm) for e in experiments):
            raise ValidationError("experiments", experiments, "a non-empty sequence of ExperimentTerm")
        names = [_tag(e.name) for e in experiments]
        if len(set(names)) != len(names):
            raise ValidationError("experiment names", names, "unique names")
        if not isinstance(material, ParameterSet):
            raise ValidationError("material", material, "a ParameterSet")
        self.experiments = experiments
        self.material = material
        nuisance = []
        self._nuis_slices = []
        start = material.n_sampled
        for e in experiments:
            specs = e.noise.nuisance_specs(e.name, e.observed, e.unit)
            self._nuis_slices.append(slice(start, start + len(specs)))
            start += len(specs)
            nuisance.extend(specs)
        self.parameters = ParameterSet(material.specs + tuple(nuisance), material.fixed_inputs, material.ordered)
        self.exchangeable = None
        if exchangeable:
            groups = [list(g) for g in exchangeable]
            names = self.parameters.sampled_names
            if len(groups) != 2 or len(groups[0]) != len(groups[1]) or not groups[0]:
                raise ValidationError("exchangeable", exchangeable, "two parameter groups of equal length")
            unknown = sorted({n for g in groups for n in g} - set(names))
            if unknown:
                raise ValidationError(
                    "exchangeable parameter names", unknown, f"sampled parameters among {list(names)}"
                )
            self.exchangeable = tuple(np.array([names.index(n) for n in g]) for g in groups)
        self.n_evaluations = 0
        self.n_failed = 0
        #: the sampler's coordinate system (:mod:`bayestissue.inference.coordinates`)
        self.coordinates = make_coordinates(coordinates, self)

    # ---- layout
    # ------------------------------------------------------------------------------------
    @property
    def ndim(self) -> int:
        """Number of sampled parameters (material + nuisance)."""
        return self.parameters.n_sampled

    @property
    def names(self) -> tuple[str, ...]:
        """Names of the sampled parameters, in the order of ``theta``."""
        return self.parameters.sampled_names

    @property
    def n_material(self) -> int:
        """Number of sampled material parameters (the first entries of ``theta``)."""
        return self.material.n_sampled

    @property
    def n_obs(self) -> int:
        return sum(e.observed.size for e in self.experiments)

    def _batch(self, theta) -> tuple[np.ndarray, bool]:
        theta = np.asarray(theta, dtype=float)
        single = theta.ndim == 1
        theta = np.atleast_2d(theta)
        if theta.ndim != 2 or theta.shape[1] != self.ndim:
            raise ValidationError("theta", f"array of shape {np.shape(theta)}", f"shape (n_sets, {self.ndim})")
        return theta, single

    def material_full(self, theta) -> np.ndarray:
        """Forward-model input ``(n_sets, n_material_total)`` with the fixed values inserted."""
        theta, _ = self._batch(theta)
        return self.material.expand(theta[:, : self.n_material])

    # ---- forward and likelihood
    # --------------------------------------------------------------------
    def _checked(self, preds: list, n_sets: int) -> list[np.ndarray]:
        """Forward outputs as ``(n_sets, n_obs_e)`` arrays, shape-checked; counts evaluations and failures."""
        out = []
        for e, raw in zip(self.experiments, preds, strict=True):
            pred = np.asarray(raw, dtype=float).reshape(n_sets, -1)
            if pred.shape[1] != e.observed.size:
                raise ValidationError(
                    f"experiment {e.name} forward output",
                    f"shape {pred.shape}",
                    f"(n_sets, {e.observed.size})",
                )
            out.append(pred)
        ok = np.all([np.all(np.isfinite(p), axis=1) for p in out], axis=0)
        self.n_evaluations += int(n_sets)
        self.n_failed += int(np.count_nonzero(~ok))
        return out

    def predict_material(self, theta_material) -> list[np.ndarray]:
        """Predictions per experiment from the sampled *material* parameters ``(n_sets,
        n_material)``."""
        tm = np.atleast_2d(np.asarray(theta_material, dtype=float))
        full = self.material.expand(tm)
        preds = []
        for e in self.experiments:
            preds.append(e.forward(full))
        return self._checked(preds, full.shape[0])

    def predict(self, theta) -> list[np.ndarray]:
        """Predictions per experiment, each ``(n_sets, n_obs_e)`` (NaN rows for failed solves)."""
        theta, _ = self._batch(theta)
        return self.predict_material(theta[:, : self.n_material])

    def nuisance_slice(self, k: int) -> slice:
        """Columns of experiment ``k``'s nuisance parameters in ``theta``."""
        return self._nuis_slices[k]

    def nuisance(self, theta, k: int) -> np.ndarray:
        """Nuisance block ``(n_sets, n_nuisance_k)`` of experiment ``k``."""
        theta, _ = self._batch(theta)
        return theta[:, self._nuis_slices[k]]

    def _pointwise(self, theta, preds) -> list[np.ndarray]:
        out = []
        for k, (e, pred) in enumerate(zip(self.experiments, preds, strict=False)):
            resid = pred - e.observed
            with np.errstate(invalid="ignore", over="ignore"):
                ll = e.noise.loglik_pointwise(resid, theta[:, self._nuis_slices[k]])
            ll[~np.isfinite(ll)] = -np.inf
            out.append(ll)
        return out

    def log_likelihood_pointwise(self, theta, predictions=None) -> list[np.ndarray]:
        """Pointwise log-likelihood per experiment, each ``(n_sets, n_obs_e)``; ``-inf`` for failed
        rows."""
        theta, _ = self._batch(theta)
        preds = self.predict(theta) if predictions is None else predictions
        return self._pointwise(theta, preds)

    def log_likelihood(self, theta) -> np.ndarray:
        """Total log-likelihood ``(n_sets,)`` (a float for a 1-D ``theta``).

        The sampler's hot path: the forward models are called from here directly (no intermediate frames), so
        the stack from emcee to the kernel is log_posterior_unconstrained -> log_posterior -> log_likelihood ->
        forward.
        """
        theta, single = self._batch(theta)
        full = self.material.expand(theta[:, : self.n_material])
        preds = []
        for e in self.experiments:
            preds.append(e.forward(full))
        preds = self._checked(preds, full.shape[0])
        total = sum(ll.sum(axis=1) for ll in self._pointwise(theta, preds))
        return float(total[0]) if single else total

    def canonical(self, theta) -> np.ndarray:
        """Swap the exchangeable groups where needed so that the first group's leading parameter is
        not smaller than the second's (:func:`~bayestissue.inference.ordering.folded`; identity without
        ``exchangeable``), and relabel the terms of the parameters'
        exchangeable ordered groups (:meth:`ParameterSet.canonical`)."""
        theta = np.array(theta, dtype=float, copy=True)
        if self.parameters.ordered:
            theta = self.parameters.canonical(theta)
        if self.exchangeable is None:
            return theta
        return folded(np.atleast_2d(theta), self.exchangeable).reshape(theta.shape)

    def _prior(self, theta) -> np.ndarray:
        lp = self.parameters.log_prior(theta)
        if self.exchangeable is not None:
            a, b = self.exchangeable
            lp = np.where(theta[:, a[0]] >= theta[:, b[0]], lp + np.log(2.0), -np.inf)
        return lp

    def log_prior(self, theta) -> np.ndarray:
        """Box-prior log-density of ``theta`` (natural units); ``-inf`` outside the box.

        With ``exchangeable`` groups (e.g. the parameters of two mirror-symmetric fibre families, whose
        exchange leaves the likelihood unchanged) the prior is restricted to the half-space in which
        the first group's leading parameter is the larger (density doubled): this removes the
        label-switching mode without changing the posterior of symmetric functions of the groups.
        """
        theta, single = self._batch(theta)
        lp = self._prior(theta)
        return float(lp[0]) if single else lp

    def log_posterior(self, theta) -> np.ndarray:
        """Unnormalised log-posterior in natural units; the forward model is only run inside the
        box."""
        theta, single = self._batch(theta)
        lp = self._prior(theta)
        inside = np.isfinite(lp)
        out = np.full(theta.shape[0], -np.inf)
        if np.any(inside):
            out[inside] = lp[inside] + self.log_likelihood(theta[inside])
        out[~np.isfinite(out)] = -np.inf
        return float(out[0]) if single else out

    def log_posterior_unconstrained(self, z) -> np.ndarray:
        """The sampler's target: :math:`\\log p(\\theta(z) \\mid y) + \\log|d\\theta/dz|`,
        ``(n_sets,)``."""
        z, single = self._batch(z)
        theta = self.coordinates.from_unconstrained(z)
        out = self.log_posterior(theta) + self.coordinates.log_abs_det_jacobian(z)
        out[~np.isfinite(out)] = -np.inf
        return float(out[0]) if single else out

    # ---- least-squares view
    # ------------------------------------------------------------------------
    def residual_scales(self) -> np.ndarray:
        """Per-observation divisor for the least-squares residuals: the known sd, else 1 (the
        paper)."""
        return np.concatenate([np.full(e.observed.size, e.noise.sd or 1.0) for e in self.experiments])

    def residuals(self, theta_material, *, fail_value: float = 1e6) -> np.ndarray:
        """Stacked scaled residuals ``(n_sets, n_obs)`` of the material parameters (paper eq. 11).

        Failed solves give ``fail_value`` (the least-squares solver cannot take NaN); they are
        counted.
        """
        return self._scaled_residuals(self.predict_material(theta_material), fail_value)

    def _scaled_residuals(self, preds: list, fail_value: float) -> np.ndarray:
        """``(prediction - observed) / scale`` stacked over the experiments, non-finite -> ``fail_value``."""
        r = np.concatenate([p - e.observed for p, e in zip(preds, self.experiments, strict=True)], axis=1)
        r = r / self.residual_scales()
        r[~np.isfinite(r)] = fail_value
        return r

    @property
    def has_sensitivities(self) -> bool:
        """True if every experiment provides exact sensitivities (:meth:`residual_jacobian` works)."""
        return all(e.sensitivities is not None for e in self.experiments)

    def residual_jacobian(self, theta_material, *, fail_value: float = 1e6) -> tuple[np.ndarray, np.ndarray]:
        r""":meth:`residuals` ``(n_sets, n_obs)`` and their exact Jacobian ``(n_sets, n_obs, n_material)``.

        The experiments' sensitivities with respect to the forward inputs :math:`x = E\theta + x_{fixed}`
        (:meth:`ParameterSet.expand`: fixed values inserted, tied parameters copied from their targets) are chained
        through the constant matrix :math:`E`, :math:`\partial r/\partial\theta = (\partial y/\partial x)\, E /
        s`. A failed solve gives the residual ``fail_value`` (a constant), hence a zero Jacobian row.
        """
        if not self.has_sensitivities:
            missing = [e.name for e in self.experiments if e.sensitivities is None]
            raise ValidationError("experiments without sensitivities", missing, "every experiment's sensitivities")
        tm = np.atleast_2d(np.asarray(theta_material, dtype=float))
        full = self.material.expand(tm)
        E = self.material.expand_matrix
        preds, jacs = zip(*(e.sensitivities(full) for e in self.experiments), strict=True)
        preds = self._checked(list(preds), full.shape[0])
        r = self._scaled_residuals(preds, fail_value)
        failed = ~np.all([np.all(np.isfinite(p), axis=1) for p in preds], axis=0)
        jac = np.concatenate([np.asarray(d, dtype=float) @ E for d in jacs], axis=1)
        jac /= self.residual_scales()[None, :, None]
        jac[failed | ~np.all(np.isfinite(jac), axis=(1, 2))] = 0.0
        return r, jac

    def nuisance_estimate(self, theta_material) -> np.ndarray:
        """Plug-in nuisance values from the residuals at ``theta_material`` (``(n_material,)``).

        :math:`\\hat\\sigma^2 = \\mathrm{RSS}/n` per experiment and :math:`\\hat\\rho` the lag-one
        autocorrelation of the residuals, clipped into their boxes. Returns the full ``theta``.
        """
        tm = np.asarray(theta_material, dtype=float).reshape(1, -1)
        preds = self.predict_material(tm)
        theta = np.empty(self.ndim)
        theta[: self.n_material] = tm[0]
        lo, hi = self.parameters.lower, self.parameters.upper
        for k, (e, p) in enumerate(zip(self.experiments, preds, strict=False)):
            sl = self._nuis_slices[k]
            names = self.names[sl]
            r = p[0] - e.observed
            for j, name in zip(range(sl.start, sl.stop), names, strict=False):
                if name.startswith("sigma_"):
                    val = float(np.sqrt(np.mean(r**2)))
                else:
                    rc = r - r.mean()
                    val = float(np.sum(rc[1:] * rc[:-1]) / max(np.sum(rc**2), 1e-300))
                theta[j] = val
        span = hi - lo
        return np.clip(theta, lo + 1e-9 * span, hi - 1e-9 * span)
