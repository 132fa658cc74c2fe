"""The paper's 11 parameters against the mirror model on T1, T2 and both jointly, by the evidence (issue 36;
analyses.model_choice); on the joint data set also shared parameters against a T2 stiffness scale.

``--full`` runs each data set's models through the nested engine (4 runs each; the runs as dask tasks on a
LocalCluster, 47-71 minutes of both cores per single test here) and writes into --out ``model_choice_record.json``
(read by the report: the Bayes factors and the 11-parameter posteriors beside Table 1), ``model_choice_<data>.png``
and ``model_choice_<data>.md``; the record after every model, and ``--data`` and ``--models`` rerun the data sets and
models they name and keep the others' runs (so that a data set's models can be run in separate sessions). A model
whose committed runs match the current code, data and its settings is kept, not rerun. The default study computes
nothing: it reads the committed record and says whether each model's runs still belong to the current code
(:func:`~bayestissue.analyses.model_choice.current_hash`). ``--quick`` is a capped smoke run of the same code on T1
into its own folder.

    python studies/full_model.py [--quick | --full] [--data T1 T2 joint] [--models mirror full scale] [--out DIR]
"""

from __future__ import annotations

import os
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import matplotlib  # noqa: E402
import numpy as np  # noqa: E402

matplotlib.use("Agg")

from bayestissue.analyses.box_width import FACTOR  # noqa: E402
from bayestissue.analyses.model_choice import (  # noqa: E402
    CANDIDATES,
    DATASETS,
    SETTINGS,
    STAGE_SEED,
    DataChoice,
    ModelChoiceRecord,
    current_hash,
    current_hashes,
    model_evidence,
    model_problem,
    model_settings,
    rerun_command,
)
from bayestissue.analyses.records import FILES  # noqa: E402
from bayestissue.cli import run_lines, stage_parser  # noqa: E402
from bayestissue.inference import NestedOptions, fit_least_squares, fit_multistart, sample_nested  # noqa: E402
from bayestissue.inference.evidence import assess_nested  # noqa: E402
from bayestissue.inference.sampling.nested import nested_target  # noqa: E402
from bayestissue.inference.sampling.peak import peak_reference  # noqa: E402
from bayestissue.inference.sampling.ultranest_run import slice_steps  # noqa: E402
from bayestissue.io.records import read_record, write_record  # noqa: E402
from bayestissue.plotting.evidence import plot_model_choice  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
#: Random least-squares starts besides the paper's, for the peak check's reference (``fit``'s default is 8).
LS_STARTS = {"quick": 0, "full": 8}


def _peak(problem, options: NestedOptions, seed: int, n_starts: int) -> float:
    """The peak check's reference (:func:`~bayestissue.inference.sampling.peak.peak_reference`) from the least-squares
    optima of the paper's start and of the best of ``n_starts`` random ones, as ``fit`` does."""
    t0 = time.perf_counter()
    fits = [fit_least_squares(problem)]
    if n_starts:
        fits.append(fit_multistart(problem, n_starts=n_starts, rng=np.random.default_rng(seed), space="unit").best)
    peak = peak_reference(problem, options, [problem.nuisance_estimate(f.x) for f in fits])
    print(f"[full model] least squares: costs {', '.join(f'{f.cost:.6g}' for f in fits)}; {peak.text()} "
          f"({time.perf_counter() - t0:.0f} s)", flush=True)  # fmt: skip
    return peak.value


def _case(mode: str, data: str, n_workers: int, old: DataChoice | None, chosen, save) -> DataChoice:
    """The ``chosen`` models on ``data`` (the others keep their runs in ``old``, if any), calling ``save`` with the
    case after every model. Under --full, a model whose runs in ``old`` match the current code, data and settings
    (:func:`~bayestissue.analyses.model_choice.current_hash`) is kept as it is, and checkpoints are keyed by that
    hash: a killed --full run resumes only runs that match it."""
    settings = SETTINGS[mode]
    seed = STAGE_SEED + 10 * DATASETS.index(data)
    models = {}
    for k, model in enumerate(CANDIDATES[data]):
        key = current_hash(mode, ROOT / "data", data, model)
        kept = old.models.get(model) if old is not None else None
        if kept is not None and (model not in chosen or (mode == "full" and kept.numbers_hash == key)):
            state = "matches the current code" if kept.numbers_hash == key else "not chosen to run"
            print(f"[full model] {data}, {model} model: kept ({kept.numbers_hash}, {state})", flush=True)
            models[model] = kept
            continue
        if model not in chosen:
            continue
        cache = ROOT / ".cache" / "model_choice" / key
        problem = model_problem(ROOT / "data", data, model)
        opts = NestedOptions(**model_settings(mode, data, model), scheduler=settings["scheduler"],
                             n_processes=n_workers, report_every=50_000)  # fmt: skip
        n_dim = nested_target(problem, opts)[0]
        print(f"[full model] {data}, {model} model ({n_dim} sampled, {problem.ndim - n_dim} noise sds integrated out): "
              f"{opts.n_runs} {opts.sampler} runs of {opts.n_live} live points ({slice_steps(opts, n_dim)} slice "
              f"steps) on {settings['scheduler'] or 'forked processes'} ({n_workers} workers); checkpoints in {cache}",
              flush=True)  # fmt: skip
        t0 = time.perf_counter()
        # a killed --full run resumes its finished points; a capped --quick run starts afresh (a resumed capped run
        # goes on past its cap and would not repeat itself)
        sample = sample_nested(problem, options=opts, checkpoint=cache, resume=mode == "full",
                               rng=seed + k, progress=run_lines(f"[full model] {data} {model}"))  # fmt: skip
        wall = time.perf_counter() - t0
        rep = assess_nested(sample, reference_log_l=_peak(problem, opts, seed + k, LS_STARTS[mode]))
        models[model] = model_evidence(model, sample, rep, opts, wall, key)
        print(f"[full model] {data} {model}: log Z {sample.log_z:.3f} +- {sample.log_z_err:.3f}, {wall:.0f} s; "
              f"{rep.verdict()}", flush=True)  # fmt: skip
        save(DataChoice(data=data, seed=seed, models=dict(models)))  # a killed stage keeps every model it finished
    return DataChoice(data=data, seed=seed, models=models)


def _summary(case: DataChoice, mode: str) -> str:
    *first, last = case.models
    names = f"{', '.join(first)} and {last} models" if first else f"{last} model"
    wait = f"; not run yet: {', '.join(case.missing)}" if case.missing else ""
    lines = [f"# The {names} on {case.data} ({mode}{wait})", ""]
    for a, b in case.factors_run:
        log_b, err = case.log_bayes(a, b)
        undecided = "" if case.factor_decides(a, b) else " (a model's runs disagree on its evidence: no verdict)"
        lines.append(f"log Bayes factor {a} over {b}: {log_b:.2f} +- {err:.2f}{undecided}\n")
        moves = case.log_bayes_moves(a, b)
        if moves is not None:
            lines.append(f"Every log box narrowed by {FACTOR:g} at each end: ln B {moves['narrowed'][0]:+.2f} +- "
                         f"{moves['narrowed'][1]:.2f}; widened: volume terms {moves['widened_volume'][0]:+.2f}, flat "
                         f"estimate {moves['widened_flat'][0]:+.2f} (analyses/box_width.py)\n")  # fmt: skip
    for e in case.models.values():
        lines.append(
            f"## {e.model} ({len(e.names)} parameters; {e.sampler}, {e.n_live} live points, "
            f"{e.wall_text}; "
            f"code and data {e.numbers_hash})\n"
        )
        agree = "agree" if e.runs_agree else "DISAGREE"
        lines.append(f"log Z {e.merged[0]:.3f} +- {e.merged[1]:.3f}; the runs {agree} on the evidence (scatter p = "
                     f"{e.log_z_p:.2g}, finished {e.finished}, at the peak {e.peak_reached}: best log-likelihood "
                     f"{', '.join(f'{v:.2f}' for v in e.max_log_l)} against the likelihood's peak climbed from the "
                     f"least-squares optima, {e.reference_log_l:.2f}, less d/2 = {len(e.names) / 2:g}, d counting the "
                     f"noise sds)\n")  # fmt: skip
        lines.append(f"posterior: {e.verdict}\n")
        lines.append("| run | log Z | calls | s |\n|---|---|---|---|")
        for k, (z, ze, c, t) in enumerate(zip(e.log_z, e.log_z_err, e.calls, e.time_s, strict=True)):
            lines.append(f"| {k} | {z:.3f} +- {ze:.3f} | {c} | {f'{t:.0f}' if np.isfinite(t) else 'not recorded'} |")
        if e.box is not None:
            b = e.box
            edges = ", ".join(f"{n} {lo:.2f}/{hi:.2f}" for n, (lo, hi) in zip(b.names, b.edge_share, strict=True))
            lines.append(f"\nlog boxes x 1/{b.factor:g} at each end: log Z {b.narrowed[0]:+.3f} +- {b.narrowed[1]:.3f} "
                         f"(runs {', '.join(f'{v:+.3f}' for v in b.narrowed_runs)}); x {b.factor:g}: volume terms "
                         f"{b.widened_volume:+.3f}, flat estimate {b.widened_flat:+.3f}; posterior share in the "
                         f"outermost decade, low/high: {edges}")  # fmt: skip
        lines.append("\n| parameter | 5 % | median | 95 % |\n|---|---|---|---|")
        for n, q, qe in zip(e.names, e.quantiles, e.quantile_errors, strict=True):
            lines.append(f"| {n} | " + " | ".join(f"{v:.4g} +- {s:.2g}" for v, s in zip(q, qe, strict=True)) + " |")
        lines.append("")
    return "\n".join(lines)


def _read_back(path: Path) -> int:
    """The default study: read the committed record and say, per data set, whether it belongs to the current code."""
    if not path.is_file():
        print(f"[full model] {path} not found: the default study reads the committed --full record; compute it "
              "with `python studies/run_study.py --full --only 'full model'`")  # fmt: skip
        return 0
    rec = read_record(path, ModelChoiceRecord)
    now = current_hashes(rec, ROOT / "data")
    for data, case in rec.cases.items():
        for model, e in case.models.items():
            current = now[data][model]
            stale = f"STALE, the current code is {current} (rerun: {rerun_command(data, [model])})"
            state = "matches the current code" if current == e.numbers_hash else stale
            print(
                f"[full model] read {path} ({rec.mode}, {data}, {model} model, code and data {e.numbers_hash}): {state}"
            )
    return 0


def main(argv=None) -> int:
    ap = stage_parser(
        __doc__, "capped smoke run", "compute the record (47-71 min of both cores a test)", ROOT / "figures"
    )
    ap.add_argument("--data", nargs="+", choices=DATASETS, help="data sets to run (default: all; --quick T1)")
    ap.add_argument("--models", nargs="+", choices=sorted({m for c in CANDIDATES.values() for m in c}),
                    help="models to run on each data set (default: all of its candidates; the others keep the "
                         "record's runs)")  # fmt: skip
    args = ap.parse_args(argv)
    path = args.out / FILES[ModelChoiceRecord]
    if not (args.quick or args.full):
        return _read_back(path)
    mode = "quick" if args.quick else "full"
    data = args.data or (("T1",) if args.quick else DATASETS)
    args.out.mkdir(parents=True, exist_ok=True)
    # a data set not run now keeps its case from an existing record of the same mode, and a model whose runs match
    # the current code is not run again (each model's runs carry their own hash)
    old = read_record(path, ModelChoiceRecord) if path.is_file() else None
    cases = dict(old.cases) if old is not None and old.mode == mode else {}
    n_workers = min(4, os.cpu_count() or 1)

    def save(case: DataChoice) -> None:
        cases[case.data] = case
        rec = ModelChoiceRecord(mode=mode, scheduler=SETTINGS[mode]["scheduler"] or "processes", n_workers=n_workers,
                                cases={k: cases[k] for k in DATASETS if k in cases})  # fmt: skip
        write_record(path, rec)

    for d in data:
        save(_case(mode, d, n_workers, cases.get(d), set(args.models or CANDIDATES[d]), save))
        (args.out / f"model_choice_{d}.md").write_text(_summary(cases[d], mode))
        plot_model_choice(cases[d], mode, args.out / f"model_choice_{d}.png")
        print(f"[full model] wrote {path}, model_choice_{d}.md and .png", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
