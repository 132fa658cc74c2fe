"""The real model wired for identifiability work: scaled residuals, specimen-level forwards, calibration tasks.

Everything here is picklable and deterministic in its arguments, so it can be fanned out with
:func:`bayestissue.parallel.fan_out` and cached by content hash.

* :class:`ExperimentResiduals` -- stacked scaled residuals :math:`(y_{obs} - u(\\theta))/\\sigma` of one or
  several experiments, for :func:`~bayestissue.identifiability.profile.profile_likelihood`, and the
  predictions for :func:`~bayestissue.identifiability.sensitivity.scaled_sensitivities`.
* :class:`SpecimenForward` -- the forward model of one experiment under a *specimen-level* parameter appended
  to the 11 material parameters: ``"scale"`` multiplies every modulus (mu, kappa, ginf_k) of that
  specimen by :math:`s` (a stiffer or softer piece of the sole, cause 3 of the paper), ``"angle"``
  sets the in-plane half-angle :math:`\\alpha` (degrees) of fibre families 2 and 3, :math:`v_{2,3} =
  (\\cos\\alpha, \\pm\\sin\\alpha, 0)` (the paper's directions have :math:`\\alpha = 20.05^\\circ`;
  cause 2).
* :class:`CalibrationTask` / :func:`run_calibration` -- least squares (multi-start, the paper's method) and
  an emcee posterior through :mod:`bayestissue.inference` with the noise sd known from the data
  file.
* :func:`attach_posterior` -- the posterior of a calibration results file (``bayestissue fit`` or
  ``studies/calibrate.py``: converged chains, tied parameters expanded to the paper's 11) attached to a
  least-squares outcome of the same experiments.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from bayestissue._validation import ValidationError, check_positive
from bayestissue.inference import (
    MIRROR_TIES,
    CalibrationProblem,
    ExperimentTerm,
    GaussianNoise,
    ParameterSet,
    ParameterSpec,
    SamplerOptions,
    fit_least_squares,
    fit_multistart,
    initial_walkers,
    paper_parameter_set,
    sample_posterior,
)
from bayestissue.inference.coordinates import adapt_coordinates
from bayestissue.inference.diagnostics import rhat_ensembles
from bayestissue.inference.likelihood import _tag
from bayestissue.io.results import read_inference_data
from bayestissue.mechanics import Experiment, TissueConfig, simulate

__all__ = [
    "MODULI",
    "PAPER_HALF_ANGLE_DEG",
    "ExperimentResiduals",
    "SpecimenForward",
    "specimen_spec",
    "CalibrationTask",
    "CalibrationOutcome",
    "build_problem",
    "run_calibration",
    "noise_sd",
    "drop_stuck_draws",
    "tissue_with_half_angle",
    "attach_posterior",
    "MIRROR_TIES",
]

#: Indices of the moduli (mu, kappa, ginf1, ginf2, ginf3) in the paper's parameter order.
MODULI = (0, 1, 2, 5, 8)
#: In-plane half-angle of the paper's fibre families 2 and 3: atan(0.3420 / 0.9369), degrees.
PAPER_HALF_ANGLE_DEG = float(np.degrees(np.arctan2(0.3420, 0.9369)))


def noise_sd(experiment: Experiment, default: float | None = None) -> float:
    """The experiment's noise sd (mm) from its data file header, else ``default``; raise if neither."""
    sd = experiment.noise_sd_mm if experiment.noise_sd_mm is not None else default
    if sd is None:
        raise ValidationError(
            f"experiment {experiment.name} noise_sd_mm",
            None,
            "a noise sd in the data file header",
            "or pass a default",
        )
    return check_positive("noise_sd_mm", sd)


def tissue_with_half_angle(tissue: TissueConfig, alpha_deg: float) -> TissueConfig:
    """``tissue`` with fibre families 2 and 3 at :math:`(\\cos\\alpha, \\pm\\sin\\alpha, 0)`."""
    a = np.radians(float(alpha_deg))
    d = np.array(tissue.directions, dtype=float)
    if d.shape[0] != 3:
        raise ValidationError("tissue.directions", d.shape, "three fibre families")
    d[1] = (np.cos(a), np.sin(a), 0.0)
    d[2] = (np.cos(a), -np.sin(a), 0.0)
    return replace(tissue, directions=d)


class ExperimentResiduals:
    """Stacked scaled residuals of ``experiments`` as a function of the 11 material parameters.

    ``r(theta)`` for ``theta`` (11,) -> (n_obs_total,), or (n_sets, 11) -> (n_sets, n_obs_total);
    NaN where a solve failed. :meth:`predict` gives the stacked predictions (the same shapes).
    """

    def __init__(self, experiments, *, sd: float | None = None):
        self.experiments = tuple(experiments)
        if not self.experiments:
            raise ValidationError("experiments", (), "at least one Experiment")
        for e in self.experiments:
            if e.displacement_mm is None:
                raise ValidationError(f"experiment {e.name}", "no displacement data", "observed data")
        self.sd = np.concatenate([np.full(e.time_s.size, noise_sd(e, sd)) for e in self.experiments])
        self.observed = np.concatenate([e.displacement_mm for e in self.experiments])

    def predict(self, theta) -> np.ndarray:
        return np.concatenate([simulate(e, theta) for e in self.experiments], axis=-1)

    def __call__(self, theta) -> np.ndarray:
        return (self.observed - self.predict(theta)) / self.sd


def specimen_spec(kind: str) -> ParameterSpec:
    """Prior box of a specimen-level parameter: ``scale`` log-uniform on [0.05, 20]; ``angle`` uniform on
    [0, 60] degrees (family 2/3 half-angle; the paper's 20.05 in the middle third)."""
    if kind == "scale":
        return ParameterSpec("scale", "1", 0.05, 20.0, prior="loguniform", value=1.0)
    if kind == "angle":
        return ParameterSpec("angle", "deg", 0.0, 60.0, prior="uniform", value=PAPER_HALF_ANGLE_DEG)
    raise ValidationError("specimen parameter kind", kind, "'scale' or 'angle'")


class SpecimenForward:
    """Forward model of ``experiment`` taking ``(n_sets, 11 + k)``: the material parameters, then extra
    columns; ``kind`` None ignores the extras, ``"scale"`` / ``"angle"`` use column ``column``."""

    def __init__(self, experiment: Experiment, kind: str | None = None, column: int = 11):
        if kind not in (None, "scale", "angle"):
            raise ValidationError("kind", kind, "None, 'scale' or 'angle'")
        self.experiment, self.kind, self.column = experiment, kind, int(column)

    def __call__(self, params) -> np.ndarray:
        p = np.atleast_2d(np.asarray(params, dtype=float))
        mat = p[:, :11].copy()
        if self.kind is None:
            return simulate(self.experiment, mat)
        extra = p[:, self.column]
        if self.kind == "scale":
            mat[:, list(MODULI)] *= extra[:, None]
            return simulate(self.experiment, mat)
        out = np.empty((p.shape[0], self.experiment.time_s.size))
        for i in range(p.shape[0]):
            tis = tissue_with_half_angle(self.experiment.tissue, extra[i])
            out[i] = simulate(replace(self.experiment, tissue=tis), mat[i])
        return out


@dataclass(frozen=True)
class CalibrationTask:
    """One calibration: experiments, an optional specimen-level parameter, and the run settings.

    Parameters
    ----------
    experiments : the experiments calibrated together (shared material parameters).
    specimen : None, or ``(kind, experiment name)``: a ``"scale"`` or ``"angle"`` parameter acting on that
        experiment only (see :class:`SpecimenForward`).
    n_starts : Latin-hypercube least-squares starts besides the paper's initial guess.
    extra_starts : further least-squares starts (natural units; 11 values, the specimen parameter's
        initial value is appended when the problem has one), e.g. the paper's Table 1 estimates.
    n_steps : emcee steps per ensemble (0: least squares only); n_ensembles, n_walkers : ensemble layout.
    keep : number of posterior draws kept (thinned evenly).
    max_nfev : function-evaluation cap of each least-squares fit.
    paper_start : also start from the paper's initial guess (the multi-start); False with
        ``n_starts=0`` fits only from ``extra_starts`` (warm starts, e.g. per stereology replicate).
    seed : seed of the multi-start and the sampler.
    tied : pairs ``(name, target)``: ``name`` takes ``target``'s value (e.g. :data:`MIRROR_TIES`); the
        draws are still reported for all 11 parameters.
    coordinates, moves, adapt_rounds, adapt_steps : the sampler's coordinate system
        (:data:`bayestissue.inference.coordinates.COORDINATES`; sheared ones are adapted to the best
        optimum as in the calibration stage) and moves (:class:`~bayestissue.inference.SamplerOptions`).
        Defaults: box coordinates with DE/snooker moves, a fixed-length chain of ``n_steps``.
    """

    experiments: tuple
    specimen: tuple | None = None
    n_starts: int = 3
    extra_starts: tuple = ()
    n_steps: int = 1500
    n_ensembles: int = 2
    n_walkers: int | None = None
    keep: int = 4000
    seed: int = 0
    label: str = ""
    paper_start: bool = True
    max_nfev: int = 400
    tied: tuple = ()
    coordinates: str = "box"
    moves: str = "de_snooker"
    adapt_rounds: int = 2
    adapt_steps: int = 500


@dataclass
class CalibrationOutcome:
    """Result of :func:`run_calibration` (natural units unless stated).

    ``draws`` (n, p) posterior draws, ``u`` the same in the scaled box :math:`[0, 1]^p` (the space
    where every prior is uniform), ``loglik`` (n, n_experiments) per-experiment log-likelihood of
    each draw, ``ls_x``/``ls_chi2`` the least-squares optimum and its :math:`\\chi^2`,
    ``chi2_parts`` its split by experiment, ``ls_starts`` (x, chi2) of every start,
    ``rhat``/``acceptance`` sampler diagnostics.
    """

    label: str
    names: tuple
    lower: np.ndarray
    upper: np.ndarray
    ls_x: np.ndarray
    ls_chi2: float
    chi2_parts: np.ndarray
    ls_active: np.ndarray
    ls_starts: list = field(default_factory=list)
    draws: np.ndarray | None = None
    u: np.ndarray | None = None
    loglik: np.ndarray | None = None
    rhat: np.ndarray | None = None
    acceptance: float = float("nan")
    n_failed: int = 0
    time_ls_s: float = 0.0
    time_mcmc_s: float = 0.0
    experiment_names: tuple = ()
    sampler: str = "inference.sample_posterior"
    n_dropped: int = 0
    tied: dict = field(default_factory=dict)


def build_problem(
    experiments, *, specimen: tuple | None = None, sd: float | None = None, tied=(), coordinates: str = "box"
) -> CalibrationProblem:
    """A :class:`~bayestissue.inference.CalibrationProblem` of ``experiments`` with known noise sd, the
    paper's box priors (log-uniform moduli and rates, uniform gamma), an optional specimen parameter,
    optional tied parameters (pairs ``(name, target)``) and the sampler's coordinate system."""
    material = paper_parameter_set()
    if tied:
        material = material.updated(tied=dict(tied))
    if specimen is not None:
        kind, target = specimen
        if target not in [e.name for e in experiments]:
            raise ValidationError("specimen target", target, f"one of {[e.name for e in experiments]}")
        material = ParameterSet(material.specs + (specimen_spec(kind),), material.fixed_inputs)
    terms = []
    for e in experiments:
        kind = specimen[0] if specimen is not None and specimen[1] == e.name else None
        terms.append(
            ExperimentTerm(
                name=e.name,
                time_s=e.time_s,
                observed=e.displacement_mm,
                forward=SpecimenForward(e, kind),
                noise=GaussianNoise(sd=noise_sd(e, sd)),
            )
        )
    return CalibrationProblem(terms, material, coordinates=coordinates)


def _chi2_parts(problem: CalibrationProblem, x) -> np.ndarray:
    preds = problem.predict_material(np.atleast_2d(x))
    return np.array(
        [
            float(np.sum(((p[0] - e.observed) / e.noise.sd) ** 2))
            for p, e in zip(preds, problem.experiments, strict=True)
        ]
    )


def run_calibration(task: CalibrationTask) -> CalibrationOutcome:
    """Least squares (paper's start + ``n_starts`` Latin-hypercube starts) then, if ``n_steps > 0``, an emcee
    posterior started around the best optimum. Runs in one process (safe inside a dask worker)."""
    if not task.experiments:
        raise ValidationError("task.experiments", (), "at least one Experiment")
    problem = build_problem(task.experiments, specimen=task.specimen, tied=task.tied, coordinates=task.coordinates)
    rng = np.random.default_rng(task.seed)
    t0 = time.perf_counter()
    fits = []
    if task.paper_start or task.n_starts > 0:
        kw = {"include_initial": task.paper_start}
        fits = list(fit_multistart(problem, n_starts=task.n_starts, rng=rng, max_nfev=task.max_nfev, **kw).results)
    mat = problem.material
    for start in task.extra_starts:
        fits.append(fit_least_squares(problem, _sampled_start(mat, start), max_nfev=task.max_nfev))
    if not fits:
        raise ValidationError("task", "no least-squares start", "paper_start, n_starts > 0 or extra_starts")
    best = min(fits, key=lambda r: r.cost)
    t_ls = time.perf_counter() - t0
    parts = _chi2_parts(problem, best.x)
    untied = _untied(mat)
    out = CalibrationOutcome(
        label=task.label,
        names=mat.names,
        lower=untied.lower,
        upper=untied.upper,
        ls_x=mat.expand(best.x),
        ls_chi2=float(parts.sum()),
        chi2_parts=parts,
        ls_active=mat.expand(np.asarray(best.active, dtype=float)).astype(bool),
        ls_starts=[(mat.expand(r.x), 2 * r.cost) for r in fits],
        time_ls_s=t_ls,
        experiment_names=tuple(e.name for e in task.experiments),
        tied=mat.tied,
    )
    if task.n_steps <= 0:
        return out
    opts = SamplerOptions(
        n_walkers=task.n_walkers,
        n_ensembles=task.n_ensembles,
        n_processes=1,
        max_steps=task.n_steps,
        min_steps=task.n_steps,
        check_every=max(50, task.n_steps // 10),
        moves=task.moves,
        adapt_rounds=task.adapt_rounds,
        adapt_steps=task.adapt_steps,
    )
    t1 = time.perf_counter()
    problem.coordinates = adapt_coordinates(problem, best.x)
    try:
        post = sample_posterior(problem, best.x, cov=best.cov, options=opts, rng=rng)
        draws4 = post.draws()  # (n_ens, n_draws, n_walkers, ndim)
        out.acceptance = float(np.mean([e.acceptance.mean() for e in post.ensembles]))
        out.n_failed = int(post.n_failed)
    except ValueError:
        # inference.sampling fails on a NaN autocorrelation time (a short chain in which some parameter
        # never moved); fall back to plain emcee with the same start and length, second half kept
        draws4, out.acceptance = _plain_emcee(problem, best, opts, task.n_steps, rng)
        out.sampler = "plain emcee (fallback)"
    out.time_mcmc_s = time.perf_counter() - t1
    if draws4.shape[0] >= 2 and draws4.shape[1] >= 4:
        out.rhat = rhat_ensembles(draws4)
    flat = draws4.reshape(-1, draws4.shape[-1])
    idx = _evenly(flat.shape[0], task.keep)
    out.loglik = np.column_stack([ll.sum(axis=1) for ll in problem.log_likelihood_pointwise(flat[idx])])
    out.draws = mat.expand(flat[idx])
    out.u = untied.to_unit(out.draws)
    return out


def _evenly(n: int, keep: int) -> np.ndarray:
    """At most ``keep`` evenly spaced indices into ``n`` draws (thinning)."""
    return np.unique(np.linspace(0, n - 1, min(keep, n)).astype(int))


def _sampled_start(mat: ParameterSet, start) -> np.ndarray:
    """A least-squares start given for every parameter (the paper's 11, a specimen parameter's initial
    value appended when missing) -> the sampled ones, clipped into the box."""
    x0 = np.asarray(start, dtype=float).ravel()
    if x0.size == len(mat.names) - 1:
        x0 = np.append(x0, mat.specs[-1].value)
    if x0.size != len(mat.names):
        raise ValidationError("least-squares start", f"{x0.size} values", f"{len(mat.names)} ({', '.join(mat.names)})")
    x0 = x0[[mat.names.index(n) for n in mat.sampled_names]]
    return np.clip(x0, mat.lower, mat.upper)


def _untied(mat: ParameterSet) -> ParameterSet:
    """``mat`` with every tie released (same boxes and priors): the space of the reported draws."""
    return ParameterSet(tuple(replace(s, tied_to=None) for s in mat.specs), mat.fixed_inputs)


def _parse_pairs(text: str) -> dict:
    """``"a=b, c=d"`` (e.g. ParameterSet.tied_text) -> ``{"a": "b", "c": "d"}``."""
    pairs = [t.split("=") for t in str(text).split(",") if "=" in t]
    return {a.strip(): b.strip() for a, b in pairs}


def attach_posterior(outcome: CalibrationOutcome, path, *, keep: int = 4000) -> CalibrationOutcome:
    """A copy of the least-squares ``outcome`` with the posterior of a calibration results file.

    The file (:func:`bayestissue.io.results.write_inference_data`: ``bayestissue fit`` or
    ``studies/calibrate.py``) must calibrate the same experiments. Its material draws are expanded to
    the paper's 11 parameters (a tied parameter takes its target's draw; file attribute
    ``parameters_tied``), thinned evenly to at most ``keep``; ``u`` is their scaled box;
    ``loglik`` the file's pointwise log-likelihood summed per experiment (its own noise model, e.g.
    a sampled sd); ``rhat`` the file's between-ensemble R-hat (attribute ``rhat_ensembles``);
    ``sampler`` names the file and its convergence verdict. Nuisance draws (noise sd) are dropped.
    """
    box = paper_parameter_set()
    if tuple(outcome.names) != box.names:
        raise ValidationError("outcome.names", outcome.names, f"the paper's 11 parameters {box.names}")
    path = Path(path)
    idata = read_inference_data(path)
    post, attrs = idata.posterior, idata.posterior.attrs
    tags = [_tag(n) for n in outcome.experiment_names]
    have = sorted(idata.log_likelihood.data_vars)
    if have != sorted(tags):
        raise ValidationError(f"results file {path.name} experiments", have, f"the experiments {sorted(tags)}")
    tied = _parse_pairs(attrs.get("parameters_tied", ""))
    missing = [n for n in outcome.names if tied.get(n, n) not in post.data_vars]
    if missing:
        raise ValidationError(f"results file {path.name}", f"no draws of {missing}", f"draws of {list(outcome.names)}")
    draws = np.column_stack([post[tied.get(n, n)].values.ravel() for n in outcome.names])
    n = draws.shape[0]
    ll = np.column_stack([idata.log_likelihood[t].values.reshape(n, -1).sum(axis=1) for t in tags])
    idx = _evenly(n, keep)
    rh = _parse_pairs(attrs.get("rhat_ensembles", ""))  # "mu=1.0013,kappa=1.0012,..."
    out = replace(outcome)
    out.draws, out.loglik = draws[idx], ll[idx]
    out.u = box.to_unit(out.draws)
    out.rhat = np.array([float(rh.get(tied.get(n, n), "nan")) for n in outcome.names])
    out.acceptance = float(attrs.get("acceptance_mean", float("nan")))
    out.n_failed = int(attrs.get("n_failed_forward", 0))
    out.time_mcmc_s = float(attrs.get("sampling_time_s", float("nan")))
    out.sampler = f"{path.name}: {attrs.get('convergence', 'no verdict recorded')}"
    out.tied = tied
    return out


def drop_stuck_draws(outcome: CalibrationOutcome, *, p: float = 1e-6) -> CalibrationOutcome:
    """Remove draws of stuck walkers: log-likelihood more than :math:`\\chi^2_{d, 1-p}/2` below the best draw.

    Near the mode :math:`2(\\ell_{max} - \\ell) \\sim \\chi^2_d` (d sampled parameters, tied ones not
    counted), so with ``p = 1e-6`` a legitimate draw is dropped with probability about 1e-6; an ensemble walker that
    started in (or jumped to) a region a million times less likely and never moved is not a
    posterior draw. Returns a copy with ``n_dropped`` set.
    """
    from scipy.stats import chi2

    if outcome.draws is None:
        return outcome
    ll = outcome.loglik.sum(axis=1)
    d = outcome.draws.shape[1] - len(outcome.tied)  # tied columns repeat their targets
    keep = 2 * (ll.max() - ll) <= chi2.ppf(1 - p, d)
    out = replace(outcome)
    out.draws, out.u, out.loglik = outcome.draws[keep], outcome.u[keep], outcome.loglik[keep]
    out.n_dropped = int((~keep).sum())
    return out


def _plain_emcee(problem, best, opts, n_steps, rng):
    """emcee without the automatic-length machinery: (n_ens, n_steps // 2, n_walkers, ndim) draws."""
    import emcee

    nw = opts.walkers(problem.ndim)
    runs, acc = [], []
    for _ in range(opts.n_ensembles):
        p0 = initial_walkers(problem, best.x, nw, cov=best.cov, rng=rng)
        sampler = emcee.EnsembleSampler(
            nw,
            problem.ndim,
            problem.log_posterior_unconstrained,
            vectorize=True,
            moves=[(emcee.moves.DEMove(), 0.8), (emcee.moves.DESnookerMove(), 0.2)],
        )
        sampler.random_state = np.random.RandomState(int(rng.integers(2**32 - 1))).get_state()
        sampler.run_mcmc(p0, n_steps)
        z = sampler.get_chain(discard=n_steps // 2)
        runs.append(problem.coordinates.from_unconstrained(z.reshape(-1, z.shape[-1])).reshape(z.shape))
        acc.append(float(np.mean(sampler.acceptance_fraction)))
    return np.stack(runs), float(np.mean(acc))
