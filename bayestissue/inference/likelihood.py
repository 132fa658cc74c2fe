"""Noise models for the displacement residuals :math:`r_t = u_t^{\\text{model}}(\\theta) -
u_t^{\\text{obs}}`.

One noise model per experiment; the calibration problem (:mod:`bayestissue.inference.problem`) sums
the experiments' log-likelihoods, so several experiments share the material parameters and each
keeps its own nuisance parameters (noise sd, AR(1) coefficient), named ``sigma_<experiment>`` and
``rho_<experiment>``.

Models (registered in :data:`NOISE_MODELS`):

* ``gaussian``: independent :math:`r_t \\sim N(0, \\sigma^2)`; :math:`\\sigma` known (``sd=...``) or
  sampled.
* ``ar1``: stationary AR(1) residuals, :math:`r_t = \\rho r_{t-1} + e_t`, :math:`e_t \\sim N(0,
  \\sigma^2 (1 - \\rho^2))`, marginal sd :math:`\\sigma`. Dense creep curves have correlated
  residuals (model error varies slowly); treating them as independent makes posteriors too narrow by
  roughly :math:`\\sqrt{(1 + \\rho)/(1 - \\rho)}`.
* ``student_t``: independent :math:`r_t / s \\sim t_\\nu` (robust to outliers; :math:`\\nu` fixed,
  default 4).

Priors of the nuisance parameters (weakly informative, stated here once): :math:`\\sigma` (or
:math:`s`) log-uniform on ``sd_bounds``, by default :math:`[10^{-5} R, R]` with :math:`R` the
peak-to-peak range of the observed displacement (a Jeffreys-type scale prior in a box spanning five
decades below the data's own scale); :math:`\\rho` uniform on ``rho_bounds`` = (-0.99, 0.99).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np
from scipy.special import gammaln

from bayestissue._validation import ValidationError, check_interval, check_positive
from bayestissue.inference.parameters import ParameterSpec

__all__ = ["NoiseModel", "GaussianNoise", "AR1Noise", "StudentTNoise", "NOISE_MODELS", "make_noise"]

_LOG_2PI = math.log(2.0 * math.pi)


def _tag(experiment: str) -> str:
    return re.sub(r"\W", "_", str(experiment))


@dataclass(frozen=True)
class NoiseModel:
    """Base class. ``sd`` known (float, mm) or ``None`` to sample it with a log-uniform prior on
    ``sd_bounds``."""

    sd: float | None = None
    sd_bounds: tuple[float, float] | None = None

    def __post_init__(self):
        if self.sd is not None:
            object.__setattr__(self, "sd", check_positive("noise sd", self.sd))
        if self.sd_bounds is not None:
            lo, hi = (float(b) for b in self.sd_bounds)
            check_positive("noise sd lower bound", lo)
            if not lo < hi:
                raise ValidationError("noise sd_bounds", (lo, hi), "0 < lower < upper")

    #: names of the nuisance parameters besides the sd
    def _extra_specs(self, tag: str) -> tuple[ParameterSpec, ...]:
        return ()

    def nuisance_specs(self, experiment: str, observed, unit: str = "mm") -> tuple[ParameterSpec, ...]:
        """The sampled nuisance parameters of this experiment (empty for a known sd and no
        extras); ``unit`` is the observable's (the sd's)."""
        tag = _tag(experiment)
        specs = []
        if self.sd is None:
            if self.sd_bounds is not None:
                lo, hi = self.sd_bounds
            else:
                obs = np.asarray(observed, dtype=float)
                hi = float(np.ptp(obs)) if obs.size > 1 and np.ptp(obs) > 0 else 1.0
                lo = 1e-5 * hi
            specs.append(ParameterSpec(f"sigma_{tag}", unit, lo, hi, prior="loguniform"))
        return tuple(specs) + self._extra_specs(tag)

    def _sd(self, nuisance: np.ndarray) -> np.ndarray:
        """``(n_sets, 1)`` sd from the nuisance block (or the known sd)."""
        if self.sd is not None:
            return np.full((nuisance.shape[0], 1), self.sd)
        return nuisance[:, :1]

    def loglik_pointwise(self, resid: np.ndarray, nuisance: np.ndarray) -> np.ndarray:
        """Log-likelihood of each observation, ``(n_sets, n_obs)``; ``resid`` is ``(n_sets,
        n_obs)``."""
        raise NotImplementedError  # pragma: no cover

    def simulate(self, n_obs: int, nuisance: np.ndarray, *, rng=None) -> np.ndarray:
        """Noise realisations ``(n_sets, n_obs)`` for the posterior predictive."""
        raise NotImplementedError  # pragma: no cover


@dataclass(frozen=True)
class GaussianNoise(NoiseModel):
    """Independent Gaussian residuals.

    .. math:: \\log p(r_t) = -\\tfrac12 \\log(2\\pi\\sigma^2) - \\frac{r_t^2}{2\\sigma^2}
    """

    def loglik_pointwise(self, resid, nuisance):
        sd = self._sd(nuisance)
        return -0.5 * _LOG_2PI - np.log(sd) - 0.5 * (resid / sd) ** 2

    def simulate(self, n_obs, nuisance, *, rng=None):
        rng = np.random.default_rng(rng)
        return self._sd(nuisance) * rng.standard_normal((nuisance.shape[0], n_obs))


@dataclass(frozen=True)
class AR1Noise(NoiseModel):
    """Stationary AR(1) residuals with marginal sd :math:`\\sigma` and lag-one correlation
    :math:`\\rho`.

    The exact likelihood factorises into conditionals (used as the pointwise terms):

    .. math::

        r_1 \\sim N(0, \\sigma^2), \\qquad
        r_t \\mid r_{t-1} \\sim N(\\rho r_{t-1}, \\sigma^2 (1 - \\rho^2)), \\; t \\ge 2 .

    Assumes equally spaced data (true for both experiments). ``rho`` known (float) or sampled.
    """

    rho: float | None = None
    rho_bounds: tuple[float, float] = (-0.99, 0.99)

    def __post_init__(self):
        super().__post_init__()
        lo, hi = (float(b) for b in self.rho_bounds)
        if not -1 < lo < hi < 1:
            raise ValidationError("rho_bounds", self.rho_bounds, "-1 < lower < upper < 1")
        if self.rho is not None:
            check_interval("rho", self.rho, -1, 1, closed=(False, False))

    def _extra_specs(self, tag):
        if self.rho is not None:
            return ()
        lo, hi = self.rho_bounds
        return (ParameterSpec(f"rho_{tag}", "1", lo, hi, prior="uniform"),)

    def _rho(self, nuisance):
        if self.rho is not None:
            return np.full((nuisance.shape[0], 1), self.rho)
        return nuisance[:, -1:]

    def loglik_pointwise(self, resid, nuisance):
        sd, rho = self._sd(nuisance), self._rho(nuisance)
        out = np.empty_like(resid)
        out[:, :1] = -0.5 * _LOG_2PI - np.log(sd) - 0.5 * (resid[:, :1] / sd) ** 2
        s_innov = sd * np.sqrt(1.0 - rho**2)
        e = resid[:, 1:] - rho * resid[:, :-1]
        out[:, 1:] = -0.5 * _LOG_2PI - np.log(s_innov) - 0.5 * (e / s_innov) ** 2
        return out

    def simulate(self, n_obs, nuisance, *, rng=None):
        rng = np.random.default_rng(rng)
        sd, rho = self._sd(nuisance), self._rho(nuisance)
        n = nuisance.shape[0]
        eps = rng.standard_normal((n, n_obs))
        out = np.empty((n, n_obs))
        out[:, 0] = sd[:, 0] * eps[:, 0]
        s_innov = (sd * np.sqrt(1.0 - rho**2))[:, 0]
        for t in range(1, n_obs):
            out[:, t] = rho[:, 0] * out[:, t - 1] + s_innov * eps[:, t]
        return out


@dataclass(frozen=True)
class StudentTNoise(NoiseModel):
    """Independent Student-t residuals with scale :math:`s` (the ``sd`` slot) and fixed
    :math:`\\nu`.

    .. math::

        \\log p(r_t) = \\log\\Gamma(\\tfrac{\\nu+1}{2}) - \\log\\Gamma(\\tfrac{\\nu}{2})
        - \\tfrac12\\log(\\nu\\pi s^2) - \\tfrac{\\nu+1}{2}\\log\\left(1 + \\frac{r_t^2}{\\nu
          s^2}\\right)
    """

    nu: float = 4.0

    def __post_init__(self):
        super().__post_init__()
        check_positive("Student-t nu", self.nu)

    def loglik_pointwise(self, resid, nuisance):
        s = self._sd(nuisance)
        nu = self.nu
        c = gammaln(0.5 * (nu + 1)) - gammaln(0.5 * nu) - 0.5 * math.log(nu * math.pi)
        return c - np.log(s) - 0.5 * (nu + 1) * np.log1p((resid / s) ** 2 / nu)

    def simulate(self, n_obs, nuisance, *, rng=None):
        rng = np.random.default_rng(rng)
        return self._sd(nuisance) * rng.standard_t(self.nu, (nuisance.shape[0], n_obs))


#: Registered noise models by name (config key ``likelihood.noise``).
NOISE_MODELS: dict[str, type[NoiseModel]] = {
    "gaussian": GaussianNoise,
    "ar1": AR1Noise,
    "student_t": StudentTNoise,
}


def make_noise(name: str = "gaussian", **options) -> NoiseModel:
    """Build a registered noise model, e.g. ``make_noise("ar1", sd=None)``.

    Raises
    ------
    ValidationError
        For an unknown model name or an option the model does not take.
    """
    if name not in NOISE_MODELS:
        raise ValidationError("noise model", name, f"one of {sorted(NOISE_MODELS)}")
    cls = NOISE_MODELS[name]
    allowed = set(cls.__dataclass_fields__)
    bad = sorted(set(options) - allowed)
    if bad:
        raise ValidationError(f"{name} noise options", bad, f"options among {sorted(allowed)}")
    return cls(**options)
