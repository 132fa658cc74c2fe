"""``bayestissue fit EXPERIMENT... [--config FILE] --out DIR [--resume]``: Bayesian calibration.

Least squares (the paper's method, then multi-start), emcee ensembles with automatic length (or nested
sampling runs with the evidence, ``[sampler] engine = "nested"``), diagnostics; writes ``posterior.nc`` (arviz
InferenceData with provenance), ``summary.csv``/``summary.md``, the figures (``*.png``) and HDF5 checkpoints
(``checkpoints/``) into DIR, and prints the summary and the convergence verdict.
"""

from __future__ import annotations

import time
from pathlib import Path

from bayestissue.cli import seed

__all__ = ["register", "run"]


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "fit",
        help="calibrate the material parameters on one or several experiments (least squares + MCMC)",
        description=__doc__.splitlines()[0].split(": ", 1)[1],
    )
    p.add_argument("experiments", nargs="+", metavar="EXPERIMENT", help="experiment files (TOML)")
    p.add_argument("--config", help="calibration configuration (TOML; every key: docs/config.md)")
    p.add_argument("--out", required=True, help="output directory")
    mode = p.add_mutually_exclusive_group()
    mode.add_argument(
        "--resume",
        action="store_true",
        help="continue the run checkpointed in --out (refused if its inputs, configuration or code differ)",
    )
    mode.add_argument("--overwrite", action="store_true", help="replace the run in a non-empty --out")
    p.add_argument("--seed", type=seed, help="master seed (overrides the configuration)")
    p.add_argument(
        "--engine",
        choices=["emcee", "nested"],
        help="sampling engine (overrides [sampler] engine): emcee ensembles, or nested runs with the evidence",
    )
    p.add_argument(
        "--quick",
        action="store_true",
        help="smoke run in about a minute: 2 starts, 300 steps, short adaptation (emcee) or small capped runs "
        "(nested); not converged",
    )
    p.add_argument(
        "--replicates",
        metavar="TABLE",
        help="stereology replicate table (bayestissue stereology replicates): a cut posterior, one calibration per "
        "chosen row with its directions, fractions and fibre dispersions, pooled (docs/stereology.md)",
    )
    p.add_argument("--n-replicates", type=int, default=4, help="rows of --replicates used (default 4)")
    p.add_argument("--no-sample", action="store_true", help="least squares only")
    p.add_argument("--no-figures", action="store_true", help="do not draw the figures")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=run, outputs={"--out": ("out", "dir")})


#: ``--quick``: every stage scaled down, whatever the configuration asks (a mixture's adaptation included: 3 x 1000
#: discarded steps took 10 of the 14 minutes a quick run with moves = "mixture" used to take).
QUICK_SAMPLER = {
    "max_steps": 300,
    "check_every": 100,
    "prune_rounds": 1,
    "prune_steps": 50,
    "adapt_rounds": 1,
    "adapt_steps": 100,
}
#: ``--quick`` for the nested engine (and the emcee path's nested cross-check): two small runs capped at 5 000
#: evaluations each. At 4 x 20 000 the tendon example took 290 s, nautilus's own work being most of it (about 7 ms per
#: call against 0.35-0.57 ms for the forward solve): two runs are the fewest its verdict compares.
QUICK_NESTED = {"n_live": 100, "n_eff": 100, "n_runs": 2, "n_networks": 1, "max_evaluations": 5_000}


def run(args) -> int:
    from bayestissue.io.results import provenance
    from bayestissue.mechanics import load_experiment
    from bayestissue.workflows import load_config, run_calibration
    from bayestissue.workflows.run_directory import open_run_directory, run_manifest

    t0 = time.perf_counter()
    over = {}
    if args.seed is not None:
        over["seed"] = args.seed
    if args.engine is not None:
        over["engine"] = args.engine
    if args.no_sample:
        over["sample"] = False
    if args.quick:
        over.update(n_starts=2, ls_max_nfev=200, sampler=QUICK_SAMPLER, nested=QUICK_NESTED)
    config = load_config(args.config, **over)
    experiments = [load_experiment(p) for p in args.experiments]
    reps = _replicates(args, config, experiments) if args.replicates else None
    if args.config is None and config.sample and all(e.tissue.is_paper_model for e in experiments):
        print("note: no --config: sampling the paper's 11-parameter model, which does not converge on a creep or a "
              "ramp (README, Calibration); examples/creep_T1.toml and examples/ramp_T2.toml tie the mirror families "
              "and converge")  # fmt: skip
    for ridge in _branch_ridges(experiments, config):
        print(ridge.note())
    data_paths = [Path(p) for e in experiments for p in (e.source, e.data_file) if p is not None]
    if reps is not None:
        data_paths.append(Path(args.replicates))
    prov = provenance(seed=config.seed, config_path=args.config, data_paths=data_paths)
    out = Path(args.out)
    progress, close_bar = _progress(config, enabled=config.sample and not args.no_progress)
    names = ", ".join(e.name for e in experiments)
    if not config.sample:
        stage = "least squares only"
    elif config.engine == "nested":
        stage = f"least squares, then {config.nested.n_runs} nested runs"
    else:
        stage = f"least squares, then {config.sampler.n_ensembles} ensembles"
    manifest = run_manifest(config, experiments, config_path=args.config)
    if reps is not None:
        from bayestissue.io.results import file_sha256

        manifest["replicates"] = {"file": str(args.replicates), "file_sha256": file_sha256(args.replicates),
                                  "n_replicates": args.n_replicates}  # fmt: skip
    with open_run_directory(out, manifest, resume=args.resume, overwrite=args.overwrite) as run_dir:
        for note in run_dir.notes:
            print(note)
        if args.resume:
            print(_resume_line(run_dir, config.engine))
        print(f"calibrating on {names}: {stage}")
        if reps is not None:
            _run_cut(args, experiments, config, reps, out, progress, close_bar, prov)
            print(f"wrote {out}/ in {time.perf_counter() - t0:.1f} s")
            return 0
        try:
            outcome = run_calibration(
                experiments,
                config,
                out_dir=out,
                resume=args.resume,
                progress=progress,
                provenance=prov,
                say=lambda line: print(line, flush=True),
            )
        finally:
            close_bar()
        _report(outcome, config, names, out, args.no_figures)
    print(f"wrote {out}/ in {time.perf_counter() - t0:.1f} s")
    return 0


def _branch_ridges(experiments, config) -> list:
    """The Prony branches of the first experiment's tissue whose sampled parameters make flat directions
    (:mod:`~bayestissue.analyses.branch_ridges`; the experiments share one tissue)."""
    from bayestissue.analyses.branch_ridges import branch_ridges
    from bayestissue.workflows.problem import build_problem

    sampled = build_problem(experiments, config).material.sampled_names
    return branch_ridges(experiments[0].tissue, sampled)


def _replicates(args, config, experiments) -> dict:
    """The replicate table, checked before any work: readable, enough rows, a tissue it fits (three families) and,
    for a fibre law with a dispersion, the dispersion columns."""
    from bayestissue._validation import ValidationError
    from bayestissue.io.stereology_files import read_replicates
    from bayestissue.workflows.cut import choose_replicates, replicate_experiments, replicate_fixed

    if not config.sample:
        raise ValidationError("--replicates", "with --no-sample", "a sampled run (the cut pools posterior draws)")
    reps = read_replicates(args.replicates)
    n_rows = len(reps["phi_matrix"])
    if n_rows < 2:
        raise ValidationError(f"{args.replicates}: rows", n_rows, ">= 2 replicates")
    row = choose_replicates(n_rows, args.n_replicates, config.seed)[0]
    for e in experiments:
        try:
            replicate_experiments([e], reps, row)
            replicate_fixed(e.tissue, reps, row)
        except ValidationError as exc:
            raise ValidationError(f"{e.source}: {exc.field}", exc.value, exc.expected, exc.hint) from exc
    return reps


def _run_cut(args, experiments, config, reps, out, progress, close_bar, prov) -> None:
    from bayestissue.workflows.cut import run_cut_calibration, write_cut_summary

    try:
        cut = run_cut_calibration(experiments, config, reps, n_replicates=args.n_replicates, out_dir=out,
                                  resume=args.resume, progress=progress, provenance=prov,
                                  say=lambda line: print(line, flush=True))  # fmt: skip
    finally:
        close_bar()
    for r, o in zip(cut.rows, cut.outcomes, strict=True):
        print(f"replicate {r + 1}: {o.report.verdict()}; {o.table['meta']['fit_check']}")
    print(write_cut_summary(cut, out, figures=not args.no_figures))


def _progress(config, *, enabled: bool):
    """The sampling progress callback (a tqdm bar on stderr, created on the first report, after the input checks)
    and the function that closes the bar; ``(None, no-op)`` when disabled."""
    bar = None

    def close():
        if bar is not None:
            bar.close()

    if not enabled:
        return None, close
    from tqdm import tqdm

    if config.engine == "nested":
        from bayestissue.inference.sampling.nested import RunPhases

        phases = RunPhases(config.nested.n_eff)

        def progress(k, n_like, n_eff, explored, log_z):
            nonlocal bar
            if bar is None:
                bar = tqdm(unit="eval", desc="nested sampling")
            phases.update(k, n_like, n_eff, explored)
            bar.update(phases.evaluations - bar.n)
            bar.set_postfix_str(phases.text())

        return progress, close
    opts = config.sampler
    done, phases = {}, {}

    def progress(k, n, total, phase):
        nonlocal bar
        if bar is None:
            bar = tqdm(total=opts.n_ensembles * opts.max_steps, unit="step", desc="sampling")
        if phase == "sampling":  # the bar counts production steps; the discarded phases show beside it
            done[k] = n
            phases.pop(k, None)
            bar.update(sum(done.values()) - bar.n)
        else:
            phases[k] = f"ensemble {k} {phase} {n}/{total}"
        bar.set_postfix_str(", ".join(phases[j] for j in sorted(phases)), refresh=True)

    return progress, close


def _resume_line(run_dir, engine: str) -> str:
    what = "run" if engine == "nested" else "ensemble"
    if not any(run_dir.resumed):
        return f"resuming {run_dir.path}: nothing was checkpointed yet, sampling starts at 0 {run_dir.unit}"
    at = ", ".join(f"{what} {k} at {n} {run_dir.unit}" for k, n in enumerate(run_dir.resumed))
    return f"resuming {run_dir.path}: {at}"


def _report(outcome, config, names, out, no_figures) -> None:
    from bayestissue.inference.summary import table_markdown

    ms = outcome.multistart  # the redrawn starts were said as the warm start ran (workflows.calibration)
    print(
        f"multi-start: {len(ms.results)} starts, best cost {ms.best.cost:.5g}, "
        f"{int(ms.labels.max()) + 1} cost clusters, {ms.time_s:.1f} s; the table's least-squares column is the best "
        f"fit (cost {outcome.best.cost:.5g}, active bounds: {', '.join(outcome.best.active_names()) or 'none'})"
    )
    print(table_markdown(outcome.table, title=f"Calibration on {names}"))
    if outcome.report is not None:
        rep = outcome.report
        print(rep.verdict())
        for line in outcome.advice():
            print(f"what to do: {line}")
        print("posterior predictive check:", outcome.table["meta"]["fit_check"])
        if config.engine == "nested":
            print(f"log evidence: {outcome.sample.log_z:.3f} +- {outcome.sample.log_z_err:.3f}")
        print(
            f"sampling: {rep.time_s:.1f} s, min bulk ESS {rep.ess_bulk.min():.0f} "
            f"({rep.ess_per_second():.2f} ESS/s), failed forward solves: "
            f"{outcome.sample.n_failed} of {outcome.sample.n_evaluations}"
        )
    if outcome.tissue_terms is not None:
        print(outcome.tissue_terms.markdown())
    if not no_figures:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        from bayestissue.plotting.inference import calibration_figures

        for name, fig in calibration_figures(outcome).items():
            fig.savefig(out / f"{name}.png", dpi=110)
            plt.close(fig)
