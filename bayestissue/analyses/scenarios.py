"""Simulated experiments from the model itself: T2-like ramps at other loading rates, synthetic replicas.

Cause 1 of the paper (the faster loading of T2 hid the fibre viscosity) is tested by designing
T2-like experiments at rate factors :math:`f` (ramp rate :math:`f \\cdot r_{T2}`, :math:`r_{T2}` =
3.24 kPa/min) that reach the same peak stress: the same pre-stress hold, then a ramp lasting
:math:`t_r / f` with the same number of data points (so every design has the same amount of data and
differs only in its time scale). Data are simulated from a chosen parameter set plus Gaussian noise
and analysed like the real tests.

A fibre family with relaxation rate :math:`\\beta` shows its viscosity when the loading time is
comparable with :math:`1/\\beta`: much faster, the fibres respond with their instantaneous modulus
:math:`g_\\infty/(1-\\gamma)`; much slower, with the equilibrium modulus :math:`g_\\infty`; in both
limits :math:`\\beta` drops out (docs/model.md, Kelvin model).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from bayestissue._validation import ValidationError, check_positive
from bayestissue.mechanics import Experiment, RampProtocol, simulate

__all__ = ["ramp_scenario", "synthetic_replica"]


def ramp_scenario(template: Experiment, rate_factor: float, *, max_dt_s: float = 30.0) -> Experiment:
    """A T2-like experiment at ``rate_factor`` times the template's ramp rate, same hold and peak stress.

    Parameters
    ----------
    template : an experiment with a :class:`~bayestissue.mechanics.RampProtocol` (e.g. T2).
    rate_factor : > 0; 1 reproduces the template's protocol and time grid.
    max_dt_s : largest simulation step; the step is also at most the ramp's data spacing and never
        below the template's step for slow ramps (f <= 1 keeps at least the template's resolution).
        The Kelvin update is an exponential integrator, so a coarse step stays stable; synthetic
        data and fits use the same grid, so the design comparison is self-consistent.

    Returns
    -------
    Experiment without data (``displacement_mm=None``), named ``"<template>_x<factor>"``.
    """
    f = check_positive("rate_factor", rate_factor)
    prot = template.protocol
    if not isinstance(prot, RampProtocol):
        raise ValidationError("template.protocol", type(prot).__name__, "a RampProtocol (a T2-like test)")
    t = template.time_s
    hold = t[t <= prot.hold_s]
    n_ramp = int(np.count_nonzero(t > prot.hold_s))
    if n_ramp < 2:
        raise ValidationError("template.time_s", f"{n_ramp} ramp points", "at least 2 data points on the ramp")
    ramp_len = (t[-1] - prot.hold_s) / f
    step = ramp_len / n_ramp
    times = np.concatenate([hold, prot.hold_s + step * np.arange(1, n_ramp + 1)])
    dt = min(max(max_dt_s, template.dt_s), step) if f < 1 else min(step, template.dt_s)
    return replace(
        template,
        name=f"{template.name}_x{f:g}",
        protocol=RampProtocol(prot.hold_stress_kpa, prot.hold_s, prot.rate_kpa_per_s * f),
        time_s=times,
        dt_s=dt,
        displacement_mm=None,
        force_mN=None,
        description=f"simulated design: {template.name} ramp at {f:g} x its rate",
        source=None,
        meta={},
    )


def synthetic_replica(experiment: Experiment, params, *, sd: float, rng=None) -> Experiment:
    """``experiment`` with synthetic data: the model at ``params`` plus Gaussian noise of sd ``sd`` (mm).

    The result records ``synthetic=True``, the noise sd and the generating parameters in ``meta``.
    """
    rng = np.random.default_rng(rng)
    sd = check_positive("sd", sd)
    u = simulate(experiment, np.asarray(params, dtype=float))
    if not np.all(np.isfinite(u)):
        raise ValidationError("params", list(np.ravel(params)), "a parameter set the model can solve")
    y = u + sd * rng.normal(size=u.shape)
    return replace(
        experiment,
        displacement_mm=y,
        noise_sd_mm=sd,
        synthetic=True,
        meta={"synthetic": "yes", "generating_parameters": list(map(float, np.ravel(params)))},
    )
