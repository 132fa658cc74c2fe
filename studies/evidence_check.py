"""The evidence of the model-choice stage's models by importance sampling (issue 36; analyses.evidence_check): a
second estimator beside the nested runs, and the Bayes factors it gives.

``--full`` runs, per data set and model, one nautilus run (the proposal's draws) and importance sampling from a
mixture fitted to it (6-29 minutes of one core per model here: nautilus 173-1 123 s, importance sampling 45-735 s;
the models of a data set go to 2 processes) and writes
into --out ``evidence_check_record.json`` (read by the report beside the model-choice record), ``evidence_check.md``
and ``evidence_check.png`` (each model's nested runs against the importance-sampling estimate); the record after every
model, and a model whose committed check matches the current code, data and settings is kept, not rerun; each
nautilus run's draws are kept in the cache under a hash without the importance sampler (analyses.evidence_check.
proposal_hash), so that after a change of the sampler alone only the importance sampling reruns. The default
study computes nothing: it reads the committed record, redraws the figure and says whether each check still belongs to
the current code. ``--data`` and ``--models`` check the data sets and models they name and keep the record's others
(so that a data set's models can be checked in separate sessions). ``--quick`` is a capped smoke run on T1 into its
own folder.

    python studies/evidence_check.py [--quick | --full] [--data T1 T2 joint] [--models mirror full scale] [--out DIR]
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import matplotlib  # noqa: E402

matplotlib.use("Agg")

from bayestissue.analyses.box_width import FACTOR  # noqa: E402
from bayestissue.analyses.evidence_check import (  # noqa: E402
    CHECK_SEED,
    CheckCase,
    DataProblems,
    EvidenceCheckRecord,
    cached_check,
    check_hash,
    check_task,
)
from bayestissue.analyses.model_choice import CANDIDATES, DATASETS, ModelChoiceRecord  # noqa: E402
from bayestissue.analyses.records import FILES  # noqa: E402
from bayestissue.cli import stage_parser  # noqa: E402
from bayestissue.inference.sampling.processes import run_in_processes  # noqa: E402
from bayestissue.io.records import RecordError, read_record, write_record  # noqa: E402
from bayestissue.plotting.evidence_check import plot_evidence_check  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
#: Each finished check is written here at once (analyses.evidence_check.cached_check), so that a killed stage loses
#: no model it had finished.
CACHE = ROOT / ".cache" / "evidence_check"


def _case(mode: str, data: str, old: CheckCase | None, chosen, save) -> CheckCase:
    """The checks of the ``chosen`` models on ``data`` (the others keep their checks in ``old``, if any): a model whose
    committed (or cached, :data:`CACHE`) check matches the current code is kept; the others run, two processes at a
    time."""
    checks, todo = {}, []
    for k, model in enumerate(CANDIDATES[data]):
        key = check_hash(mode, ROOT / "data", data, model)
        kept = old.checks.get(model) if old is not None else None
        if model not in chosen:
            if kept is not None:
                state = "matches the current code" if kept.numbers_hash == key else "STALE, not chosen to run"
                print(f"[evidence check] {data}, {model} model: kept ({kept.numbers_hash}, {state})", flush=True)
                checks[model] = kept
            continue
        kept = kept if kept is not None and kept.numbers_hash == key else cached_check(CACHE, mode, data, model, key)
        if kept is not None:
            print(f"[evidence check] {data}, {model} model: kept ({key}, matches the current code)", flush=True)
            checks[model] = kept
        else:
            todo.append((model, CHECK_SEED + 10 * DATASETS.index(data) + k))
    if todo:
        problems = DataProblems(ROOT / "data", data, [m for m, _ in todo], cache=CACHE)
        args = [(m, mode, s) for m, s in todo]
        results = run_in_processes(problems, check_task, args, min(2, os.cpu_count() or 1),
                                   lambda line: print(f"[evidence check] {line}", flush=True))  # fmt: skip
        for (model, _), res in zip(todo, results, strict=True):
            if isinstance(res, str):
                print(f"[evidence check] {data} {model}: FAILED ({res}); not recorded", flush=True)
            else:
                checks[model] = res
    case = CheckCase(data=data, checks={m: checks[m] for m in CANDIDATES[data] if m in checks})
    save(case)
    return case


def _summary(rec: EvidenceCheckRecord, nested: ModelChoiceRecord | None) -> str:
    lines = [f"# The evidence by importance sampling ({rec.mode})", ""]
    for case in rec.ordered():
        lines += [f"## {case.data}", "", "| model | log Z (importance sampling) | k-hat | ESS / draws | batches p | "
                  "verdict | nautilus's own log Z | nested runs' log Z (model-choice record) | code and data |",
                  "|---|---|---|---|---|---|---|---|---|"]  # fmt: skip
        for model, c in case.checks.items():
            e = nested.cases[case.data].models.get(model) if nested and case.data in nested.cases else None
            runs = ", ".join(f"{z:.2f}" for z in e.log_z) if e is not None else "not run"
            lines.append(f"| {model} | {c.log_z:.3f} +- {c.log_z_err:.3f} | {c.k_hat:.2f} | {c.ess:.0f} / {c.n_draws} "
                         f"| {c.batch_p:.2g} | {'TRUSTED' if c.trusted else 'NOT TRUSTED'} | {c.proposal_log_z:.3f} | "
                         f"{runs} | {c.numbers_hash} |")  # fmt: skip
        for a, b in case.factors_run:
            f = case.factor(a, b)
            why = "decides" if f["decides"] else ("does not decide" if f["trusted"] else "not both trusted")
            (narrow, err), (volume, _), (flat, _) = (case.box_moves(a, b)[k] for k in
                                                     ("narrowed", "widened_volume", "widened_flat"))  # fmt: skip
            lines.append(f"\nln B {a} over {b}: {f['log_b']:.2f} +- {f['err']:.2f} ({f['grade']} for {f['favours']}; "
                         f"{why}); with every log box of the material parameters {FACTOR:g} times narrower at each end "
                         f"it moves by {narrow:+.2f} +- {err:.2f}, wider {volume:+.2f} (volume terms) or {flat:+.2f} "
                         "(flat estimate; analyses/box_width.py)")  # fmt: skip
        for model, c in case.checks.items():
            lines += ["", f"### {case.data}, {model}: {c.verdict}", ""]
            if c.swapped:
                a, b = (", ".join(g) for g in c.swapped)
                lines += [f"The proposal is symmetrised over the exchange of {a} with {b} (the likelihood's mirror "
                          "symmetry); the quantiles are folded.", ""]  # fmt: skip
            lines += ["| parameter | 5 % | median | 95 % |", "|---|---|---|---|"]
            lines += [f"| {n} | " + " | ".join(f"{v:.4g}" for v in q) + " |" for n, q in zip(c.names, c.quantiles,
                                                                                            strict=True)]  # fmt: skip
        lines.append("")
    return "\n".join(lines)


def _outputs(rec: EvidenceCheckRecord, out: Path) -> None:
    """The summary and the figure, from the record and the model-choice record beside it (if any)."""
    nested_path = out / FILES[ModelChoiceRecord]
    nested = read_record(nested_path, ModelChoiceRecord) if nested_path.is_file() else None
    (out / "evidence_check.md").write_text(_summary(rec, nested))
    plot_evidence_check(rec, nested, out / "evidence_check.png")


def _read_back(path: Path) -> int:
    """The default study: read the committed record, say whether each check belongs to the current code, redraw."""
    if not path.is_file():
        print(f"[evidence check] {path} not found: the default study reads the committed --full record; compute it "
              "with `python studies/evidence_check.py --full`")  # fmt: skip
        return 0
    try:
        rec = read_record(path, EvidenceCheckRecord)
    except RecordError as err:
        print(f"[evidence check] {err}", file=sys.stderr)
        return 2
    for case in rec.ordered():
        for model, c in case.checks.items():
            now = check_hash(rec.mode, ROOT / "data", case.data, model)
            rerun = f"rerun: python studies/evidence_check.py --full --data {case.data}"
            state = "matches the current code" if now == c.numbers_hash else f"STALE ({now} now; {rerun})"
            print(f"[evidence check] read {path} ({rec.mode}, {case.data}, {model} model, {c.numbers_hash}): {state}")
    _outputs(rec, path.parent)
    return 0


def main(argv=None) -> int:
    ap = stage_parser(
        __doc__, "capped smoke run on T1", "compute the record (6-29 min of one core a model)", ROOT / "figures"
    )
    ap.add_argument("--data", nargs="+", choices=DATASETS, help="data sets to check (default: all; --quick T1)")
    ap.add_argument("--models", nargs="+", choices=sorted({m for c in CANDIDATES.values() for m in c}),
                    help="models to check on each data set (default: all of its candidates; the others keep the "
                         "record's checks)")  # fmt: skip
    args = ap.parse_args(argv)
    path = args.out / FILES[EvidenceCheckRecord]
    if not (args.quick or args.full):
        return _read_back(path)
    mode = "quick" if args.quick else "full"
    args.out.mkdir(parents=True, exist_ok=True)
    try:
        old = read_record(path, EvidenceCheckRecord) if path.is_file() else None
    except RecordError as err:  # another version's record: none of its checks can be kept, the cache's can
        print(f"[evidence check] {err}; its checks are not kept", flush=True)
        old = None
    cases = dict(old.cases) if old is not None and old.mode == mode else {}

    def save(case: CheckCase) -> None:
        cases[case.data] = case
        write_record(path, EvidenceCheckRecord(mode=mode, cases={d: cases[d] for d in DATASETS if d in cases}))

    for d in args.data or (("T1",) if args.quick else DATASETS):
        _case(mode, d, cases.get(d), set(args.models or CANDIDATES[d]), save)
    rec = read_record(path, EvidenceCheckRecord)
    _outputs(rec, args.out)
    print(f"[evidence check] wrote {path}, evidence_check.md and .png", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
