"""The calibration pipeline: experiments + configuration -> warm start -> posterior -> results.

Steps of :func:`run_calibration` (used by ``bayestissue fit`` and ``studies/calibrate.py``):

1. build the problem (:func:`bayestissue.workflows.problem.build_problem`): the paper's 11 parameters with
   Table 1 boxes and the configured priors, fixed and sampled subsets; one experiment term per experiment
   (shared material parameters, one noise model each);
2. the paper's least squares from its initial guess (trust-region reflective, ``x_scale`` = initial guess);
3. multi-start least squares (Latin hypercube in the scaled box) and clustering of the optima; with ties or fixed
   values, their likelihood-ratio test against the model with them released
   (:mod:`bayestissue.workflows.constraints`);
4. emcee (``[sampler] engine``, the default): the sampler's coordinates adapted to the best optimum, ensembles
   started at distinct plausible optima (Laplace scatter), automatic length, diagnostics, and with
   ``[sampler] cross_check = "nested"`` a nested sample of the same posterior compared with it quantile by quantile
   (:mod:`bayestissue.inference.engine_check`; a disagreement is NOT CONVERGED); or nested: independent
   nautilus runs from the prior, the evidence, diagnostics (:mod:`bayestissue.inference.evidence`);
5. ``InferenceData`` with provenance, the summary table and the tissue terms (moduli, stresses, relaxation with
   intervals: :mod:`bayestissue.workflows.tissue_terms`), written when ``out_dir`` is given.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from bayestissue._validation import ValidationError
from bayestissue.inference import (
    CalibrationProblem,
    ConvergenceReport,
    LeastSquaresResult,
    MultistartResult,
    NestedReport,
    NestedSample,
    PosteriorSample,
    assess_convergence,
    assess_nested,
    fit_least_squares,
    fit_multistart,
    sample_nested,
    sample_posterior,
)
from bayestissue.inference.coordinates import adapt_coordinates
from bayestissue.inference.engine_check import compare_samples
from bayestissue.inference.fit_check import fit_check, fit_check_text
from bayestissue.inference.posterior import evenly, to_inference_data
from bayestissue.inference.sampling.nested import RunPhases
from bayestissue.inference.sampling.peak import peak_reference
from bayestissue.inference.summary import summary_table, table_markdown
from bayestissue.workflows.config import CalibrationConfig
from bayestissue.workflows.constraints import ConstraintTest, constraint_test
from bayestissue.workflows.coordinates import coordinate_advice
from bayestissue.workflows.problem import build_problem, reference_values
from bayestissue.workflows.tissue_terms import TissueTerms, tissue_terms

__all__ = ["CalibrationOutcome", "run_calibration"]


@dataclass
class CalibrationOutcome:
    """Everything :func:`run_calibration` produced."""

    problem: CalibrationProblem
    config: CalibrationConfig
    paper_fit: LeastSquaresResult
    multistart: MultistartResult
    best: LeastSquaresResult
    sample: PosteriorSample | NestedSample | None = None
    report: ConvergenceReport | NestedReport | None = None
    idata: object = None
    fit_check: dict | None = None
    table: dict | None = None
    references: dict = field(default_factory=dict)
    times_s: dict = field(default_factory=dict)
    files: dict = field(default_factory=dict)
    constraints: ConstraintTest | None = None
    tissue_terms: TissueTerms | None = None

    def advice(self) -> list[str]:
        """What to do when the run is not done: the verdict's own advice (:meth:`ConvergenceReport.advice`), and for
        emcee the coordinates' (:func:`coordinate_advice`); empty when sampled and converged, or not sampled."""
        if self.report is None:
            return []
        lines = list(self.report.advice())
        if self.config.engine == "emcee":
            lines.append(coordinate_advice(self.config.coordinates, self.report.converged))
        return [line for line in lines if line]


def run_calibration(
    experiments: Sequence,
    config: CalibrationConfig | None = None,
    *,
    out_dir: str | Path | None = None,
    resume: bool = False,
    progress: Callable | None = None,
    provenance: Mapping | None = None,
    say: Callable[[str], None] | None = None,
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
    progress : during sampling, ``progress(ensemble_id, steps_done, steps_total, phase)`` (emcee; phases
        pruning, adaptation, sampling) or
        ``progress(run, n_evaluations, n_eff, explored, log_z)`` (nested).
    provenance : global attributes for the results file (version, seed, hashes: see
        :func:`bayestissue.io.results.provenance`).
    say : receives one line per finished least-squares fit (the stages before sampling can take minutes).
    """
    say = say or (lambda line: None)
    config = config or CalibrationConfig()
    rng = np.random.default_rng(config.seed)
    problem = build_problem(experiments, config)
    n_walkers, least = config.sampler.n_walkers, 2 * problem.ndim + 2
    if config.sample and n_walkers is not None and n_walkers < least:
        raise ValidationError(
            "[sampler] n_walkers", n_walkers, f"an integer >= {least} (2 ndim + 2, ndim = {problem.ndim}) or omitted"
        )
    times = {}
    t0 = time.perf_counter()
    paper_fit = fit_least_squares(problem, max_nfev=config.ls_max_nfev, jacobian=config.ls_jacobian)
    times["paper_least_squares"] = time.perf_counter() - t0
    say(
        f"paper's least squares: cost {paper_fit.cost:.5g}, {paper_fit.nit} iterations, {paper_fit.time_s:.1f} s, "
        f"active bounds: {', '.join(paper_fit.active_names()) or 'none'}"
    )
    t0 = time.perf_counter()
    multi = fit_multistart(
        problem,
        n_starts=config.n_starts,
        rng=rng,
        space="unit",
        max_nfev=config.ls_max_nfev,
        jacobian=config.ls_jacobian,
        progress=lambda k, n, r: say(f"multi-start {k}/{n}: cost {r.cost:.5g}, {r.nit} iterations, {r.time_s:.1f} s"),
    )
    times["multistart"] = time.perf_counter() - t0
    if multi.n_redrawn:
        say(f"multi-start: {multi.n_redrawn} random start(s) redrawn (the fit could not move from them)")
    best = min([paper_fit, multi.best], key=lambda r: r.cost)
    refs = {e.name: reference_values(e) for e in experiments}
    outcome = CalibrationOutcome(problem, config, paper_fit, multi, best, references=refs, times_s=times)
    t0 = time.perf_counter()
    outcome.constraints = constraint_test(experiments, config, problem, best)
    times["constraint_test"] = time.perf_counter() - t0
    if outcome.constraints is not None:
        say(outcome.constraints.text())
    if not config.sample:
        outcome.table = summary_table(problem, best, None, None, references=refs)
        return _finish(outcome, experiments, out_dir, say)
    ckpt = None if out_dir is None else Path(out_dir) / "checkpoints"
    if config.engine == "nested":
        t0 = time.perf_counter()
        sample = sample_nested(
            problem, options=config.nested, checkpoint=ckpt, resume=resume, progress=progress, rng=rng
        )
        times["sampling"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        peak = peak_reference(problem, config.nested, [problem.nuisance_estimate(f.x) for f in (paper_fit, multi.best)])
        times["peak_reference"] = time.perf_counter() - t0
        say(f"peak check: {peak.text()}")
        report = assess_nested(sample, reference_log_l=peak.value)
        engine_attrs = {}
    else:
        t0 = time.perf_counter()
        problem.coordinates = adapt_coordinates(problem, problem.nuisance_estimate(best.x))
        times["coordinates"] = time.perf_counter() - t0
        centers, covs = _ensemble_centres(problem, [paper_fit, *multi.results], best, config)
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
        if config.cross_check == "nested":
            report = _cross_check(problem, sample, report, config, ckpt, resume, say)
            times["cross_check"] = report.engine_check.time_s
        engine_attrs = {"acceptance_mean": float(np.mean(report.acceptance))}
    attrs = dict(provenance or {})
    attrs.update(
        convergence=report.verdict(),
        converged=int(report.converged),
        **engine_attrs,
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
        rhat=dict(zip(report.names, report.rhat, strict=True)),
        rng=rng,
    )
    outcome.fit_check = fit_check(idata)
    idata.posterior.attrs["fit_check"] = fit_check_text(outcome.fit_check)
    outcome.sample, outcome.report, outcome.idata = sample, report, idata
    outcome.table = summary_table(problem, best, sample, report, references=refs)
    outcome.table["meta"]["fit_check"] = idata.posterior.attrs["fit_check"]
    return _finish(outcome, experiments, out_dir, say)


def _cross_check(problem, sample, report, config, ckpt, resume, say):
    """``report`` with the comparison of ``sample`` (emcee) and a nested sample of the same posterior under the
    ``[nested]`` settings (:mod:`bayestissue.inference.engine_check`), checkpointed in ``ckpt/cross_check``."""
    opts = config.nested
    say(f"cross-check: {opts.n_runs} nested run(s) of the same posterior, {opts.n_live} live points each")
    t0 = time.perf_counter()
    path = None if ckpt is None else Path(ckpt) / "cross_check"
    nested = sample_nested(
        problem,
        options=opts,
        checkpoint=path,
        resume=resume,
        progress=_every(30.0, say, opts.n_eff),
        rng=[config.seed, 36],
    )
    nested_report = assess_nested(nested)
    a, b = sample.flat(), nested.flat()
    check = compare_samples(
        problem.names, a, report.quantile_errors(a), b, nested_report.quantile_errors(b), problem.parameters.to_unit,
        other_verdict=nested_report.verdict(), time_s=time.perf_counter() - t0,
    )  # fmt: skip
    say(check.text())
    return replace(report, engine_check=check)


def _every(seconds: float, say, n_eff: int):
    """A nested progress callback that says where the runs are at most every ``seconds`` (the cross-check has no
    bar of its own: the sampling bar above it has closed)."""
    phases, last = RunPhases(n_eff), [time.perf_counter()]

    def progress(k, n_like, eff, explored, log_z):
        phases.update(k, n_like, eff, explored)
        if time.perf_counter() - last[0] >= seconds:
            last[0] = time.perf_counter()
            say(f"cross-check: {phases.evaluations:,} evaluations; {phases.text()}")

    return progress


def _finish(outcome: CalibrationOutcome, experiments, out_dir, say) -> CalibrationOutcome:
    """What every run ends with, sampled or not: the ties test as a line of the summary, the tissue terms, the
    files."""
    if outcome.constraints is not None:
        outcome.table["meta"]["constraint_test"] = outcome.constraints.text()
    advice = outcome.advice()
    if advice:
        outcome.table["meta"]["what_to_do"] = " ".join(advice)
    outcome.tissue_terms = _tissue_terms(outcome, experiments, say)
    _write(outcome, out_dir)
    return outcome


def _tissue_terms(outcome: CalibrationOutcome, experiments, say) -> TissueTerms | None:
    """The tissue terms of the first experiment's tissue (:mod:`bayestissue.workflows.tissue_terms`) over up to 400
    posterior draws, or at the least-squares optimum without sampling; None (said) where they do not apply."""
    problem = outcome.problem
    if outcome.sample is not None:
        d = outcome.sample.flat()[:, : problem.n_material]
        d = d[evenly(d.shape[0], 400)]
    else:
        d = outcome.best.x[None, :]
    try:
        return tissue_terms(experiments[0], problem.material.expand(d))
    except ValidationError as exc:
        say(f"tissue terms: not computed ({exc})")
        return None


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
    if not distinct:  # every start failed to solve, or every cost is NaN (issue 34: a ZeroDivisionError before)
        names = ", ".join(sorted({e.name for e in problem.experiments}))
        raise ValidationError(
            f"least-squares warm start on {names}", f"{len(fits)} fits, none with a finite cost",
            "a parameter set in the boxes that the model can solve and that comes near the data",
            "the data may be far outside what the boxes allow (units? a displacement in um read as mm?), "
            "or every solve failed",
        )  # fmt: skip
    # an optimum in another labelling of an ordered group that cannot be relabelled (Prony branches) starts no
    # ensemble: the prior is zero there (inference.ordering.OrderedGroup)
    centres = problem.canonical(np.array([problem.nuisance_estimate(r.x) for r in distinct]))
    ordered = problem.parameters.in_order(centres)
    if not np.any(ordered):
        raise ValidationError(
            "least-squares warm start",
            f"{len(distinct)} plausible optima, none with {problem.parameters.ordered_text}",
            "an optimum in the ordered labelling the prior keeps",
            "give more starts ([warmstart] n_starts) or use the nested engine, which needs no warm start",
        )  # fmt: skip
    distinct = [r for r, ok in zip(distinct, ordered, strict=True) if ok]
    centres = centres[ordered]
    n = config.sampler.n_ensembles
    pick = [k % len(distinct) for k in range(n)]
    return centres[pick], [distinct[k].cov for k in pick]


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
    check = getattr(outcome.report, "engine_check", None)
    if check is not None:
        (out / "cross_check.md").write_text(check.markdown())
        outcome.files["cross_check"] = out / "cross_check.md"
    if outcome.tissue_terms is not None:
        (out / "tissue_terms.md").write_text(outcome.tissue_terms.markdown())
        outcome.files["tissue_terms"] = out / "tissue_terms.md"
    if outcome.idata is not None:
        outcome.files["posterior"] = write_inference_data(outcome.idata, out / "posterior.nc")
