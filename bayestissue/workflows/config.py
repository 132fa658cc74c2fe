"""The calibration configuration: one typed schema for the TOML file, the CLI and the studies.

:func:`load_config` reads a file (:func:`bayestissue.io.results.read_config` returns its plain mapping) and
:func:`config_from_mapping` validates it once, section by section, into a frozen :class:`CalibrationConfig`;
unknown sections and keys, wrong types and values out of range are refused by name (:mod:`~.schema`, rendered as
``docs/config.md``).

Configuration file (all sections and keys optional)::

    [parameters]
    prior = "default"                 # or "uniform" (uniform on the box for every parameter)
    fixed = { ginf1 = 125.0 }         # name -> value, or a list of names held at their initial value
    sampled = ["mu", "kappa"]         # sample only these (the rest are fixed at their initial value)
    bounds = { mu = [0.001, 1000] }
    priors = { mu = "uniform" }
    initial = { mu = 10.0 }
    tied = { ginf3 = "ginf2" }        # takes the other parameter's value (one law for two families)

    [likelihood]
    noise = "gaussian"                # "gaussian", "ar1", "student_t"
    sd = 0.02                         # known sd (mm), or "data" (the data file's); omit to sample it
    nu = 4.0                          # Student-t degrees of freedom

    [warmstart]
    n_starts = 8
    max_nfev = 1000

    [sampler]
    seed = 20261121
    n_ensembles = 4
    moves = "de_snooker"              # or "mixture": fitted Student-t independence proposals + DE
    coordinates = "box"               # or "creep" (creep tests, tied families 2/3) or "ramp" (force ramps)
    max_steps = 20000

    [nested]                          # with [sampler] engine = "nested"
    n_live = 1000
    n_runs = 4

    [output]
    max_draws = 4000
    n_predictive = 400

``[likelihood] sd = "data"`` takes each experiment's known noise sd from its data file header
(``# noise_sd_mm: ...``, written for the synthetic replicas).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from bayestissue._validation import ValidationError
from bayestissue.inference.likelihood import NOISE_MODELS, make_noise
from bayestissue.inference.sampling import NestedOptions, SamplerOptions
from bayestissue.io.results import read_config
from bayestissue.workflows.coordinates import COORDINATES
from bayestissue.workflows.schema import CROSS_CHECKS, ENGINES, check_mapping

__all__ = ["CalibrationConfig", "config_from_mapping", "load_config"]


@dataclass(frozen=True)
class CalibrationConfig:
    """Settings of :func:`run_calibration` (see :mod:`bayestissue.io.results` for the TOML layout).

    Parameters
    ----------
    prior : "default" (log-uniform scale parameters, uniform gamma) or "uniform" (uniform on the
    box).
    fixed : names held at their initial value, or mapping name -> value.
    sampled : if given, sample only these names (the rest held at their initial values).
    bounds, priors, initial : per-parameter overrides.
    noise : noise model name (``gaussian``, ``ar1``, ``student_t``); noise_options : its options
        (``sd`` for a known sd, ``nu``, ``rho`` ...).
    n_starts : random starts of the multi-start least squares (the paper's start is always added).
    ls_max_nfev : evaluation cap of each least-squares run.
    ls_jacobian : ``"differences"`` or ``"exact"`` (:func:`bayestissue.inference.fit_least_squares`).
    sample : run the sampling stage.
    engine : ``"emcee"`` (ensembles started at the least-squares optima, :attr:`sampler`) or ``"nested"``
        (nautilus runs from the prior with the evidence, :attr:`nested`).
    sampler : :class:`~bayestissue.inference.sampling.SamplerOptions`.
    nested : :class:`~bayestissue.inference.sampling.NestedOptions`.
    seed : master seed (least-squares starts, walkers, sampler streams, predictive noise).
    max_draws, n_predictive : size of the stored posterior and of the posterior predictive.
    exchangeable : two groups of parameters whose exchange leaves the likelihood unchanged (fibre
        families 2 and 3 are mirror images about the loading axis), e.g.
        ``[["ginf2", "gamma2", "beta2"], ["ginf3", "gamma3", "beta3"]]``: the prior is restricted to
        ``ginf2 >= ginf3`` (see :meth:`CalibrationProblem.log_prior`). Off by default (the paper's
        problem as stated).
    tied : mapping name -> name: parameters that take another parameter's value instead of being
        sampled, e.g. ``{"ginf3": "ginf2", "gamma3": "gamma2", "beta3": "beta2"}`` for two fibre
        families with one law (the mirror-symmetric model). Off by default.
    cross_check : ``"none"`` or ``"nested"``: after the emcee engine, a nested run of the same posterior (the
        :attr:`nested` settings) compared quantile by quantile (:mod:`bayestissue.inference.engine_check`); a
        disagreement makes the verdict NOT CONVERGED.
    coordinates : the sampler's coordinate system (``[sampler] coordinates``): ``box`` (logit of the
        scaled box per parameter), ``creep`` or ``ramp`` (:mod:`bayestissue.inference.coordinates`; need mu,
        kappa, ginf2, gamma2, beta2 sampled).
    specimen : None, or ``(kind, experiment name)``: a specimen-level parameter (``"scale"`` or ``"angle"``,
        :class:`~bayestissue.workflows.forward.SpecimenForward`) acting on that experiment only.
    """

    prior: str = "default"
    fixed: Mapping | Sequence = ()
    sampled: Sequence[str] | None = None
    bounds: Mapping = field(default_factory=dict)
    priors: Mapping = field(default_factory=dict)
    initial: Mapping = field(default_factory=dict)
    noise: str = "gaussian"
    noise_options: Mapping = field(default_factory=dict)
    n_starts: int = 8
    ls_max_nfev: int = 1000
    ls_jacobian: str = "differences"
    sample: bool = True
    engine: str = "emcee"
    sampler: SamplerOptions = field(default_factory=SamplerOptions)
    nested: NestedOptions = field(default_factory=NestedOptions)
    seed: int = 20261121
    max_draws: int = 4000
    n_predictive: int = 400
    exchangeable: Sequence[Sequence[str]] | None = None
    tied: Mapping = field(default_factory=dict)
    coordinates: str = "box"
    cross_check: str = "none"
    specimen: tuple | None = None

    def __post_init__(self):
        if self.noise not in NOISE_MODELS:
            raise ValidationError("likelihood.noise", self.noise, f"one of {sorted(NOISE_MODELS)}")
        opts = dict(self.noise_options)
        if opts.get("sd") == "data":  # known per experiment, from its data file (checked by build_problem)
            opts["sd"] = 1.0
        make_noise(self.noise, **opts)  # validates the options
        if self.coordinates not in COORDINATES:
            raise ValidationError("sampler.coordinates", self.coordinates, f"one of {list(COORDINATES)}")
        if not (isinstance(self.n_starts, int) and self.n_starts >= 0):
            raise ValidationError("warmstart.n_starts", self.n_starts, "an integer >= 0")
        if self.engine not in ENGINES:
            raise ValidationError("sampler.engine", self.engine, f"one of {list(ENGINES)}")
        if self.cross_check not in CROSS_CHECKS:
            raise ValidationError("sampler.cross_check", self.cross_check, f"one of {list(CROSS_CHECKS)}")
        if self.ls_jacobian not in ("differences", "exact"):
            raise ValidationError("warmstart.jacobian", self.ls_jacobian, "'differences' or 'exact'")


def config_from_mapping(cfg: Mapping | None = None, *, where: str = "configuration", **overrides) -> CalibrationConfig:
    """Build a :class:`CalibrationConfig` from a parsed TOML mapping plus keyword overrides.

    ``where`` names the source in error messages (e.g. ``"configuration fit.toml"``).

    Raises
    ------
    ValidationError
        For unknown sections or keys, or invalid values.
    """
    cfg = dict(cfg or {})
    check_mapping(cfg, where=where)
    par = cfg.get("parameters", {})
    lik = dict(cfg.get("likelihood", {}))
    ws = cfg.get("warmstart", {})
    smp = dict(cfg.get("sampler", {}))
    out = cfg.get("output", {})
    keys = ("prior", "fixed", "sampled", "bounds", "priors", "initial", "exchangeable", "tied")
    kw = {k: par[k] for k in keys if k in par}
    if "noise" in lik:
        kw["noise"] = lik.pop("noise")
    kw["noise_options"] = {k: (tuple(v) if isinstance(v, list) else v) for k, v in lik.items()}
    if "n_starts" in ws:
        kw["n_starts"] = ws["n_starts"]
    if "max_nfev" in ws:
        kw["ls_max_nfev"] = ws["max_nfev"]
    if "jacobian" in ws:
        kw["ls_jacobian"] = ws["jacobian"]
    for k in ("seed", "sample", "coordinates", "engine", "cross_check"):
        if k in smp:
            kw[k] = smp.pop(k)
    kw.update({k: out[k] for k in ("max_draws", "n_predictive") if k in out})
    sampler_over = overrides.pop("sampler", {})
    kw["sampler"] = SamplerOptions(**{**smp, **dict(sampler_over)})
    kw["nested"] = NestedOptions(**{**cfg.get("nested", {}), **dict(overrides.pop("nested", {}))})
    kw.update(overrides)
    return CalibrationConfig(**kw)


def load_config(path: str | Path | None, **overrides) -> CalibrationConfig:
    """Read and validate a configuration file (``None``: the defaults) plus keyword overrides."""
    where = "configuration" if path is None else f"configuration {Path(path).name}"
    return config_from_mapping(read_config(path), where=where, **overrides)
