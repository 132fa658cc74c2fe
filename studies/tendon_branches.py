"""How many relaxing branches does the synthetic tendon relaxation support? One, two and three Prony branches by the
evidence (issue 32; analyses.branch_count).

``--full`` fits each branch count with its ``examples/`` configuration through ``fit``'s workflow (least squares, then 4
nautilus runs of 500 live points; 3-9 CPU-minutes for one or two branches, about 80 for three on this machine) and
writes into --out ``branch_count_record.json`` (read by the report), ``branch_count.png`` and ``branch_count.md``; the
record after every count, and a count whose committed runs match the current code, data and configuration is kept, not
rerun (``--branches`` runs only the counts it names, each only where it is stale). Each count's run directory (results
file and checkpoints) is ``.cache/branch_count/<hash>/``: a killed --full run resumes only runs that match it. The
default study computes nothing: it reads the committed record, redraws the figure and says whether each count's runs
still belong to the current code. ``--quick`` is a capped smoke run of one and two branches into its own folder.

    python studies/tendon_branches.py [--quick | --full] [--branches 1 2 3] [--out DIR]
"""

from __future__ import annotations

import os
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import matplotlib  # noqa: E402
import numpy as np  # noqa: E402

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from bayestissue.analyses.branch_count import (  # noqa: E402
    BRANCHES,
    CONFIGS,
    DATA,
    QUICK,
    SCATTER_RULE,
    TRUE_BRANCHES,
    BranchCountRecord,
    BranchFit,
    count_hash,
)
from bayestissue.analyses.model_choice import model_evidence  # noqa: E402
from bayestissue.analyses.records import FILES  # noqa: E402
from bayestissue.cli import run_lines, stage_parser  # noqa: E402
from bayestissue.io.records import read_record, write_record  # noqa: E402
from bayestissue.mechanics import load_experiment  # noqa: E402
from bayestissue.plotting.branch_count import plot_branch_count  # noqa: E402
from bayestissue.workflows import load_config, run_calibration  # noqa: E402
from bayestissue.workflows.problem import reference_values  # noqa: E402
from bayestissue.workflows.tissue_terms import tissue_terms  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
#: Every THIN-th sample of the data goes into the record (the figure's grid; the 161 samples are few).
THIN = 1


def _fit(mode: str, n: int) -> BranchFit:
    """Count ``n`` calibrated as ``fit`` would with its configuration (under --quick with :data:`QUICK`)."""
    key = count_hash(mode, ROOT, n)
    experiment = load_experiment(ROOT / "data" / "synthetic" / DATA[n])
    over = {"nested": QUICK["nested"], "n_starts": QUICK["n_starts"]} if mode == "quick" else {}
    config = load_config(ROOT / "examples" / CONFIGS[n], **over)
    run_dir = None if mode == "quick" else ROOT / ".cache" / "branch_count" / key
    print(f"[branches] {n} branch(es): {config.nested.n_runs} nautilus runs of {config.nested.n_live} live points"
          f"{f'; run directory {run_dir}' if run_dir else ''}", flush=True)  # fmt: skip
    t0 = time.perf_counter()
    out = run_calibration([experiment], config, out_dir=run_dir, resume=run_dir is not None,
                          progress=run_lines(f"[branches] {n} branch(es)"),
                          say=lambda line: print(f"[branches] {n}: {line}", flush=True))  # fmt: skip
    wall = time.perf_counter() - t0
    evidence = model_evidence(f"{n} branch{'es' if n > 1 else ''}", out.sample, out.report, config.nested, wall, key)
    check = out.fit_check[experiment.name]
    pp = out.idata.posterior_predictive
    model = np.asarray(pp[f"{experiment.name}_model"], dtype=float).reshape(-1, experiment.observed.size)
    noisy = np.asarray(pp[experiment.name], dtype=float).reshape(-1, experiment.observed.size)
    mid, lo, hi = np.quantile(model[:, ::THIN], [0.5, 0.05, 0.95], axis=0)
    band = np.quantile(noisy[:, ::THIN], [0.05, 0.95], axis=0)
    print(f"[branches] {n} branch(es): log Z {out.sample.log_z:.3f} +- {out.sample.log_z_err:.3f}, {wall:.0f} s; "
          f"{out.report.verdict()}; {out.idata.posterior.attrs['fit_check']}", flush=True)  # fmt: skip
    terms = {r["quantity"]: (r["lower"], r["median"], r["upper"]) for r in out.tissue_terms.rows()}
    return BranchFit(branches=n, evidence=evidence, noise_ratio=float(check["noise_ratio"]), lag1=float(check["lag1"]),
                     fits=not check["misfit"], fit_check=str(out.idata.posterior.attrs["fit_check"]),
                     median=mid.tolist(), lower=lo.tolist(), upper=hi.tolist(),
                     band=(band[0].tolist(), band[1].tolist()),
                     terms=terms, units={q: unit for q, (unit, _) in out.tissue_terms.values.items()})  # fmt: skip


def _summary(rec: BranchCountRecord) -> str:
    lines = [f"# Relaxation branches of the synthetic tendon ({rec.mode}; generated with {rec.true_branches})", ""]
    chosen = rec.chosen
    picks = chosen if chosen is not None else "no count yet"
    lines.append(f"The evidence picks: {picks} (largest log Z: {rec.best})\n")
    for n, (b, e, grade) in rec.grades().items():
        ok, rule = rec.decides(n)
        bound = f"; over its {SCATTER_RULE}: {rec.scatter_bound(n):.2f}" if rule == SCATTER_RULE else ""
        lines.append(f"- ln B {rec.best} over {n} branch(es): {b:.2f} +- {e:.2f} ({grade}{bound}): "
                     f"{'decides' if ok else 'does not decide'} ({rule})")  # fmt: skip
    lines += ["", "| branches | parameters | log Z per run (own error) | merged | runs agree | fit | verdict | code "
              "and data |", "|---|---|---|---|---|---|---|---|"]  # fmt: skip
    for n in rec.counts:
        f = rec.fits[str(n)]
        e = f.evidence
        runs = ", ".join(f"{z:.3f} ({s:.3f})" for z, s in zip(e.log_z, e.log_z_err, strict=True))
        lines.append(f"| {n} | {len(e.names)} | {runs} | {e.merged[0]:.3f} +- {e.merged[1]:.3f} | "
                     f"{'yes' if e.runs_agree else 'no'} (p = {e.log_z_p:.2g}) | {f.fit_check} | {e.verdict} | "
                     f"{e.numbers_hash} |")  # fmt: skip
    lines += ["", "Tissue terms (median [90 %]; `workflows/tissue_terms.py`) against the generating values:", "",
              "| quantity | unit | generating | " + " | ".join(f"{n} branch(es)" for n in rec.counts) + " |",
              "|---|---|---|" + "---|" * len(rec.counts)]  # fmt: skip
    for q in rec.term_names:
        truth = rec.truth_terms.get(q)
        cells = [f"{t[1]:.4g} [{t[0]:.4g}, {t[2]:.4g}]" if (t := rec.fits[str(n)].terms.get(q)) else "-"
                 for n in rec.counts]  # fmt: skip
        lines.append(f"| {q} | {rec.unit(q)} | {'-' if truth is None else f'{truth:.4g}'} | "
                     + " | ".join(cells) + " |")  # fmt: skip
    for n in rec.counts:
        e = rec.fits[str(n)].evidence
        lines += ["", f"## {n} branch(es): {sum(e.calls)} likelihood calls, {e.wall_text}", "",
                  "| parameter | 5 % | median | 95 % |", "|---|---|---|---|"]  # fmt: skip
        for name, q in zip(e.names, e.quantiles, strict=True):
            lines.append(f"| {name} | " + " | ".join(f"{v:.4g}" for v in q) + " |")
    return "\n".join(lines) + "\n"


def _write(rec: BranchCountRecord, out: Path) -> None:
    (out / "branch_count.md").write_text(_summary(rec))
    fig = plot_branch_count(rec)
    fig.savefig(out / "branch_count.png", dpi=100)
    plt.close(fig)


def _read_back(path: Path) -> int:
    """The default study: read the committed record, redraw its figure, and say whether each count's runs belong to
    the current code."""
    if not path.is_file():
        print(f"[branches] {path} not found: the default study reads the committed --full record; compute it with "
              "`python studies/run_study.py --full --only branches`")  # fmt: skip
        return 0
    rec = read_record(path, BranchCountRecord)
    for n in rec.counts:
        e = rec.fits[str(n)].evidence
        now = count_hash(rec.mode, ROOT, n)
        state = (
            "matches the current code"
            if now == e.numbers_hash
            else (f"STALE, the current code is {now} (rerun: python studies/tendon_branches.py --full --branches {n})")
        )
        print(f"[branches] read {path} ({rec.mode}, {n} branch(es), code and data {e.numbers_hash}): {state}")
    _write(rec, path.parent)
    return 0


def main(argv=None) -> int:
    ap = stage_parser(
        __doc__,
        "capped smoke run of one and two branches",
        "compute the record (about an hour of both cores)",
        ROOT / "figures",
    )
    ap.add_argument("--branches", nargs="+", type=int, choices=BRANCHES, help="counts to (re)run (default: all)")
    args = ap.parse_args(argv)
    path = args.out / FILES[BranchCountRecord]
    if not (args.quick or args.full):
        return _read_back(path)
    mode = "quick" if args.quick else "full"
    chosen = set(args.branches or (QUICK["branches"] if args.quick else BRANCHES))
    args.out.mkdir(parents=True, exist_ok=True)
    old = read_record(path, BranchCountRecord) if path.is_file() else None
    fits = dict(old.fits) if old is not None and old.mode == mode else {}
    experiment = load_experiment(ROOT / "data" / "synthetic" / DATA[TRUE_BRANCHES])
    truth = tissue_terms(experiment, reference_values(experiment)["generating"][None, :])
    for n in sorted(chosen | {int(k) for k in fits}):
        kept = fits.get(str(n))
        current = kept is not None and kept.evidence.numbers_hash == count_hash(mode, ROOT, n)
        if kept is not None and (n not in chosen or (mode == "full" and current)):
            state = "matches the current code" if current else "not chosen to run"
            print(f"[branches] {n} branch(es): kept ({kept.evidence.numbers_hash}, {state})", flush=True)
            continue
        fits[str(n)] = _fit(mode, n)
        rec = BranchCountRecord(mode=mode, true_branches=TRUE_BRANCHES, thin=THIN,
                                time_s=experiment.time_s[::THIN].tolist(),
                                force_mN=np.asarray(experiment.observed, dtype=float)[::THIN].tolist(),
                                fits={k: fits[k] for k in sorted(fits)},
                                truth_terms={q: float(v[0]) for q, (_, v) in truth.values.items()})  # fmt: skip
        write_record(path, rec)  # a killed stage keeps every count it finished
    rec = read_record(path, BranchCountRecord)
    _write(rec, args.out)
    print(f"[branches] wrote {path}, branch_count.md and .png", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
