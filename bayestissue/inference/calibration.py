"""The calibration pipeline on the mechanics model: experiments + configuration -> warm start -> posterior.

This is the only module of :mod:`bayestissue.inference` that knows the forward model
(:func:`bayestissue.mechanics.simulate`); everything else works on the generic
:class:`~bayestissue.inference.problem.CalibrationProblem`.

Steps of :func:`run_calibration`:

1. build the problem: the paper's 11 parameters with Table 1 boxes and the configured priors, fixed
   and sampled subsets; one :class:`~bayestissue.inference.problem.ExperimentTerm` per experiment
   (shared material parameters, one noise model each);
2. the paper's least squares from its initial guess (trust-region reflective, ``x_scale`` = initial
   guess);
3. multi-start least squares (Latin hypercube in the scaled box) and clustering of the optima;
4. emcee ensembles started around the best optimum (Laplace scatter), automatic length, diagnostics;
5. ``InferenceData`` with provenance and the summary table (written when ``out_dir`` is given).
"""

from __future__ import annotations

import logging
import re
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, fields
from pathlib import Path

import numpy as np

from bayestissue._validation import ValidationError
from bayestissue.inference.coordinates import COORDINATES, adapt_coordinates
from bayestissue.inference.diagnostics import ConvergenceReport, assess_convergence
from bayestissue.inference.likelihood import NOISE_MODELS, make_noise
from bayestissue.inference.parameters import ParameterSet, paper_parameter_set
from bayestissue.inference.posterior import to_inference_data
from bayestissue.inference.problem import CalibrationProblem, ExperimentTerm
from bayestissue.inference.sampling import PosteriorSample, SamplerOptions, sample_posterior
from bayestissue.inference.summary import summary_table, table_markdown
from bayestissue.inference.warmstart import (
    LeastSquaresResult,
    MultistartResult,
    fit_least_squares,
    fit_multistart,
)

__all__ = [
    "CalibrationConfig",
    "CalibrationOutcome",
    "SimulateForward",
    "config_from_mapping",
    "build_problem",
    "reference_values",
    "run_calibration",
]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class SimulateForward:
    """Picklable forward callable ``params (n_sets, 11) -> displacement (n_sets, n_obs)`` of an experiment."""

    experiment: object

    def __call__(self, params):
        from bayestissue.mechanics import simulate

        return simulate(self.experiment, np.atleast_2d(params))


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
    sample : run the MCMC stage.
    sampler : :class:`~bayestissue.inference.sampling.SamplerOptions`.
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
    coordinates : the sampler's coordinate system (``[sampler] coordinates``): ``box`` (logit of the
        scaled box per parameter) or ``creep`` (:mod:`bayestissue.inference.coordinates`; needs mu,
        kappa, ginf2, gamma2, beta2 sampled).
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
    sample: bool = True
    sampler: SamplerOptions = field(default_factory=SamplerOptions)
    seed: int = 20261121
    max_draws: int = 4000
    n_predictive: int = 400
    exchangeable: Sequence[Sequence[str]] | None = None
    tied: Mapping = field(default_factory=dict)
    coordinates: str = "box"

    def __post_init__(self):
        if self.noise not in NOISE_MODELS:
            raise ValidationError("likelihood.noise", self.noise, f"one of {sorted(NOISE_MODELS)}")
        make_noise(self.noise, **dict(self.noise_options))  # validates the options
        if self.coordinates not in COORDINATES:
            raise ValidationError("sampler.coordinates", self.coordinates, f"one of {list(COORDINATES)}")
        if not (isinstance(self.n_starts, int) and self.n_starts >= 0):
            raise ValidationError("warmstart.n_starts", self.n_starts, "an integer >= 0")


_SECTION_KEYS = {
    "parameters": {"prior", "fixed", "sampled", "bounds", "priors", "initial", "exchangeable", "tied"},
    "likelihood": {"noise", "sd", "nu", "rho", "sd_bounds", "rho_bounds"},
    "warmstart": {"n_starts", "max_nfev"},
    "sampler": {f.name for f in fields(SamplerOptions)} | {"seed", "sample", "coordinates"},
    "output": {"max_draws", "n_predictive"},
}


def config_from_mapping(cfg: Mapping | None = None, **overrides) -> CalibrationConfig:
    """Build a :class:`CalibrationConfig` from a parsed TOML mapping plus keyword overrides.

    Raises
    ------
    ValidationError
        For unknown sections or keys, or invalid values.
    """
    cfg = dict(cfg or {})
    for section, table in cfg.items():
        if section not in _SECTION_KEYS:
            raise ValidationError("configuration section", section, f"one of {sorted(_SECTION_KEYS)}")
        if not isinstance(table, Mapping):
            raise ValidationError(f"[{section}]", table, "a table of key = value entries")
        bad = sorted(set(table) - _SECTION_KEYS[section])
        if bad:
            raise ValidationError(f"[{section}] keys", bad, f"keys among {sorted(_SECTION_KEYS[section])}")
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
    for k in ("seed", "sample", "coordinates"):
        if k in smp:
            kw[k] = smp.pop(k)
    kw.update({k: out[k] for k in ("max_draws", "n_predictive") if k in out})
    sampler_over = overrides.pop("sampler", {})
    kw["sampler"] = SamplerOptions(**{**smp, **dict(sampler_over)})
    kw.update(overrides)
    return CalibrationConfig(**kw)


def reference_values(experiment) -> dict[str, np.ndarray]:
    """Known parameter values for an experiment: the paper's Table 1 result (``paper``) for T1/T2 and the
    generating values of a synthetic replica (``generating``, from the data file header)."""
    from bayestissue.mechanics import PAPER_PARAMETERS, param_names, parse_parameters

    out = {}
    if experiment.name in PAPER_PARAMETERS:
        out["paper"] = np.asarray(PAPER_PARAMETERS[experiment.name], dtype=float)
    gen = (experiment.meta or {}).get("generating_parameters")
    if gen:
        names = param_names(experiment.tissue.n_fibres)
        out["generating"] = parse_parameters(re.sub(r"\s+", "", str(gen)), names)
        if experiment.noise_sd_mm is not None:
            out["noise_sd"] = float(experiment.noise_sd_mm)
    return out


def build_problem(experiments: Sequence, config: CalibrationConfig) -> CalibrationProblem:
    """The calibration problem of mechanics ``experiments`` (shared material parameters).

    Raises
    ------
    ValidationError
        If an experiment has no displacement data, the experiments have different fibre counts, or
        the parameter configuration is invalid (unknown names, both fixed and sampled, bad bounds).
    """
    experiments = list(experiments)
    if not experiments:
        raise ValidationError("experiments", [], "at least one experiment")
    n_f = {e.tissue.n_fibres for e in experiments}
    if len(n_f) != 1:
        raise ValidationError("experiments", sorted(n_f), "the same number of fibre systems")
    inputs = {}
    for e in experiments:
        t = e.tissue
        inputs.update(
            {
                f"{e.name}_directions": np.asarray(t.directions, dtype=float).ravel(),
                f"{e.name}_phi_fibres": np.asarray(t.phi_fibres, dtype=float),
                f"{e.name}_phi_matrix": float(t.phi_matrix),
                f"{e.name}_bulk_kpa": float(t.bulk_kpa),
                f"{e.name}_eps0": np.asarray(t.eps0 if t.eps0 is not None else np.zeros(t.n_fibres), dtype=float),
                f"{e.name}_specimen_mm": np.asarray(e.specimen_mm, dtype=float),
                f"{e.name}_dt_s": float(e.dt_s),
            }
        )
    material: ParameterSet = paper_parameter_set(n_f.pop(), prior=config.prior, fixed_inputs=inputs)
    fixed = config.fixed
    fixed_map = dict(fixed) if isinstance(fixed, Mapping) else {n: None for n in fixed}
    if config.sampled is not None:
        sampled = list(config.sampled)
        unknown = sorted(set(sampled) - set(material.names))
        if unknown:
            raise ValidationError("sampled parameter names", unknown, f"names among {list(material.names)}")
        both = sorted(set(fixed_map) & set(sampled))
        if both:
            raise ValidationError("parameters", both, "each parameter either fixed or sampled, not both")
        for n in material.names:  # the rest are held at their initial values
            if n not in sampled and n not in fixed_map and n not in config.tied:
                fixed_map[n] = None
    material = material.updated(
        fixed=fixed_map,
        sampled=config.sampled,
        bounds=config.bounds,
        priors=config.priors,
        initial=config.initial,
        tied=config.tied,
    )
    if material.n_sampled == 0:
        raise ValidationError("sampled parameters", [], "at least one sampled material parameter")
    terms = []
    for e in experiments:
        if e.displacement_mm is None:
            raise ValidationError(f"experiment {e.name}", "no displacement_mm column", "displacement data to fit")
        terms.append(
            ExperimentTerm(
                e.name,
                e.time_s,
                e.displacement_mm,
                SimulateForward(e),
                make_noise(config.noise, **dict(config.noise_options)),
                {"synthetic": bool(e.synthetic), "source": str(e.source or "")},
            )
        )
    return CalibrationProblem(terms, material, exchangeable=config.exchangeable, coordinates=config.coordinates)


@dataclass
class CalibrationOutcome:
    """Everything :func:`run_calibration` produced."""

    problem: CalibrationProblem
    config: CalibrationConfig
    paper_fit: LeastSquaresResult
    multistart: MultistartResult
    best: LeastSquaresResult
    sample: PosteriorSample | None = None
    report: ConvergenceReport | None = None
    idata: object = None
    table: dict | None = None
    references: dict = field(default_factory=dict)
    times_s: dict = field(default_factory=dict)
    files: dict = field(default_factory=dict)


def run_calibration(
    experiments: Sequence,
    config: CalibrationConfig | None = None,
    *,
    out_dir: str | Path | None = None,
    resume: bool = False,
    progress: Callable[[int, int, int], None] | None = None,
    provenance: Mapping | None = None,
) -> CalibrationOutcome:
    """Calibrate the material parameters on one or several experiments.

    Parameters
    ----------
    experiments : sequence of :class:`bayestissue.mechanics.Experiment`.
    config : CalibrationConfig (default settings if None).
    out_dir : directory for ``posterior.nc``, ``summary.csv``/``summary.md`` and the HDF5
    checkpoints
        (``checkpoints/ensemble_<k>.h5``); nothing is written without it.
    resume : continue the sampler runs checkpointed in ``out_dir``.
    progress : ``progress(ensemble_id, steps_done, max_steps)`` during sampling.
    provenance : global attributes for the results file (version, seed, hashes: see
        :func:`bayestissue.io.results.provenance`).
    """
    config = config or CalibrationConfig()
    rng = np.random.default_rng(config.seed)
    problem = build_problem(experiments, config)
    times = {}
    t0 = time.perf_counter()
    paper_fit = fit_least_squares(problem, max_nfev=config.ls_max_nfev)
    times["paper_least_squares"] = time.perf_counter() - t0
    log.info("paper least squares: cost %.4g in %d iterations", paper_fit.cost, paper_fit.nit)
    t0 = time.perf_counter()
    multi = fit_multistart(
        problem,
        n_starts=config.n_starts,
        rng=rng,
        space="unit",
        max_nfev=config.ls_max_nfev,
    )
    times["multistart"] = time.perf_counter() - t0
    best = min([paper_fit, multi.best], key=lambda r: r.cost)
    refs = {e.name: reference_values(e) for e in experiments}
    outcome = CalibrationOutcome(problem, config, paper_fit, multi, best, references=refs, times_s=times)
    if not config.sample:
        outcome.table = summary_table(problem, best, None, None, references=refs)
        _write(outcome, out_dir)
        return outcome
    t0 = time.perf_counter()
    problem.coordinates = adapt_coordinates(problem, problem.nuisance_estimate(best.x))
    times["coordinates"] = time.perf_counter() - t0
    centers, covs = _ensemble_centres(problem, [paper_fit, *multi.results], best, config)
    ckpt = None if out_dir is None else Path(out_dir) / "checkpoints"
    t0 = time.perf_counter()
    sample = sample_posterior(
        problem,
        centers,
        cov=covs,
        options=config.sampler,
        checkpoint=ckpt,
        resume=resume,
        progress=progress,
        rng=rng,
    )
    times["sampling"] = time.perf_counter() - t0
    report = assess_convergence(sample, tau_factor=config.sampler.tau_factor)
    attrs = dict(provenance or {})
    attrs.update(
        convergence=report.verdict(),
        converged=int(report.converged),
        acceptance_mean=float(np.mean(report.acceptance)),
        rhat_ensembles=",".join(f"{n}={r:.4f}" for n, r in zip(report.names, report.rhat, strict=True)),
        noise_model=config.noise,
        prior=config.prior,
        seed=int(config.seed),
    )
    idata = to_inference_data(
        sample,
        least_squares=best,
        max_draws=config.max_draws,
        n_predictive=config.n_predictive,
        attrs=attrs,
        rng=rng,
    )
    outcome.sample, outcome.report, outcome.idata = sample, report, idata
    outcome.table = summary_table(problem, best, sample, report, references=refs)
    _write(outcome, out_dir)
    return outcome


def _ensemble_centres(problem, fits, best, config):
    """One start per ensemble: distinct least-squares optima whose cost is within
    :math:`\\Delta\\chi^2 = 2\\Delta F / s^2 \\le 20` of the best (plausible modes), best first, cycled
    over the ensembles. Over-dispersed starts let the between-ensemble R-hat detect modes that a
    single start would never visit."""
    s2 = max(best.s2, 1e-300)
    plausible = sorted((r for r in fits if 2.0 * (r.cost - best.cost) / s2 <= 20.0), key=lambda r: r.cost)
    distinct = []
    for r in plausible:
        u = problem.material.to_unit(r.x[None, :])[0]
        if all(np.max(np.abs(u - problem.material.to_unit(d.x[None, :])[0])) > 0.02 for d in distinct):
            distinct.append(r)
    n = config.sampler.n_ensembles
    chosen = [distinct[k % len(distinct)] for k in range(n)]
    centres = problem.canonical(np.array([problem.nuisance_estimate(r.x) for r in chosen]))
    return centres, [r.cov for r in chosen]


def _write(outcome: CalibrationOutcome, out_dir) -> None:
    if out_dir is None:
        return
    from bayestissue.io.results import write_inference_data
    from bayestissue.io.tables import write_table

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    cols, meta = outcome.table["columns"], outcome.table["meta"]
    write_table(out / "summary.csv", cols, meta=meta)
    (out / "summary.md").write_text(table_markdown(outcome.table))
    outcome.files["summary_csv"] = out / "summary.csv"
    outcome.files["summary_md"] = out / "summary.md"
    if outcome.idata is not None:
        outcome.files["posterior"] = write_inference_data(outcome.idata, out / "posterior.nc")
