"""nautilus and UltraNest on one posterior through the real forward model: calls, time, log Z, quantiles, verdicts.

Issue 36 asks what each nested sampler costs and gives on the same problem. The problem: the bundled T1 creep (or T2
ramp), the mirror model by default (``--full``: all 11 parameters), noise integrated out, the default box prior. Each
sampler runs ``--runs`` seeded runs in forked processes; per sampler the benchmark prints every run's likelihood
calls, wall time and log Z with its own error, the merged verdict (the engine's: R-hat between runs, ESS, evidence
scatter against the runs' errors, quantile scatter, and for UltraNest each run's insertion-order test), and the merged
5 / 50 / 95 % quantiles with their Monte Carlo errors. Then the two samples are compared quantile by quantile as the
emcee cross-check compares engines (:func:`bayestissue.inference.engine_check.compare_quantiles`: a quantile differs
when it moves by more than 0.1 of nautilus's 90 % width in box units and by more than 4 combined errors; here the
quantiles are each sampler's weighted run quantiles averaged, the estimates their errors are of), and the log Z
difference is given in units of its combined error.

    OPENBLAS_NUM_THREADS=1 python benchmarks/nested_samplers.py [--data T1] [--full] [--runs 2] [--n-live 200]
        [--slice-steps S] [--population 100] [--seed 1] [--max-evaluations N] [--only nautilus|ultranest]
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from bayestissue.cli import run_lines  # noqa: E402
from bayestissue.inference import NestedOptions, sample_nested  # noqa: E402
from bayestissue.inference.engine_check import compare_quantiles  # noqa: E402
from bayestissue.inference.evidence import assess_nested  # noqa: E402
from bayestissue.mechanics import load_experiment  # noqa: E402
from bayestissue.paper import MIRROR_TIES  # noqa: E402
from bayestissue.workflows import load_config  # noqa: E402
from bayestissue.workflows.problem import build_problem  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", default="T1", choices=("T1", "T2"))
    ap.add_argument("--full", action="store_true", help="all 11 parameters (default: the mirror model, 8)")
    ap.add_argument("--runs", type=int, default=2)
    ap.add_argument("--n-live", type=int, default=200, help="live points of every run of either sampler")
    ap.add_argument("--n-eff", type=int, default=500)
    ap.add_argument("--slice-steps", type=int, default=None, help="UltraNest (default: 2 x sampled dimensions)")
    ap.add_argument("--population", type=int, default=100, help="UltraNest: points per likelihood batch")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--max-evaluations", type=int, default=None, help="cap each run (a smoke run)")
    ap.add_argument("--only", choices=("nautilus", "ultranest"), default=None, help="run one sampler, no comparison")
    args = ap.parse_args(argv)

    exp = load_experiment(ROOT / "data" / f"{args.data}.toml")
    problem = build_problem([exp], load_config(None, tied=None if args.full else dict(MIRROR_TIES)))
    base = {"n_live": args.n_live, "n_eff": args.n_eff, "n_runs": args.runs, "max_evaluations": args.max_evaluations,
            "report_every": 10_000, "n_processes": min(args.runs, os.cpu_count() or 1)}  # fmt: skip
    print(f"{args.data}, {'full' if args.full else 'mirror'} model ({problem.ndim} sampled), {args.runs} runs of "
          f"{args.n_live} live points per sampler, seed {args.seed}; {os.cpu_count()} cores")  # fmt: skip
    samplers = {
        "nautilus": NestedOptions(**base, n_networks=1),
        "ultranest": NestedOptions(
            **base, sampler="ultranest", slice_steps=args.slice_steps, population=args.population
        ),  # fmt: skip
    }
    if args.only:
        samplers = {args.only: samplers[args.only]}
    out = {}
    for name, opts in samplers.items():
        t0 = time.perf_counter()
        s = sample_nested(problem, options=opts, rng=args.seed, progress=run_lines(f"  [{name}]"))
        wall = time.perf_counter() - t0
        rep = assess_nested(s)
        out[name] = (s, rep)
        print(f"\n{name}: wall {wall:.0f} s, {s.n_evaluations} calls in all")
        for k, r in enumerate(s.runs):
            print(f"  run {k}: {r.n_like} calls, {r.time_s:.0f} s, log Z {r.log_z:.3f} +- {r.log_z_err:.3f}, "
                  f"{'finished' if r.finished else 'CAPPED'}")  # fmt: skip
        print(f"  merged log Z {s.log_z:.3f} +- {s.log_z_err:.3f}")
        print(f"  {rep.verdict()}")
        q, e = rep.quantiles(), rep.quantile_errors()
        for i, p in enumerate(s.names):
            print(f"  {p:>8}: {q[i, 1]:.4g} [{q[i, 0]:.4g}, {q[i, 2]:.4g}]  errors {e[i, 1]:.2g} [{e[i, 0]:.2g}, "
                  f"{e[i, 2]:.2g}]")  # fmt: skip
    if args.only:
        return
    (sa, ra), (sb, rb) = out["nautilus"], out["ultranest"]
    check = compare_quantiles(sa.names, ra.quantiles(), ra.quantile_errors(), rb.quantiles(), rb.quantile_errors(),
                              problem.parameters.to_unit, engine="ultranest")  # fmt: skip
    dz = sb.log_z - sa.log_z
    n_err = dz / np.hypot(sa.log_z_err, sb.log_z_err)
    print(f"\nlog Z UltraNest - nautilus: {dz:+.3f} ({n_err:+.1f} combined errors); "
          f"calls UltraNest / nautilus: {sb.n_evaluations / max(sa.n_evaluations, 1):.1f}x")  # fmt: skip
    print(f"quantiles 5 / 50 / 95 %: largest difference over nautilus's 90 % width in box units, and in combined "
          f"errors (differs: > {check.tol} of the width and > {check.z_min:g} errors, as engine_check)")  # fmt: skip
    print("| parameter | nautilus | UltraNest | largest / width | errors | |\n|---|---|---|---|---|---|")
    for i, p in enumerate(check.names):
        j = int(np.argmax(check.rel[i]))
        print(f"| {p} | {' / '.join(f'{v:.4g}' for v in check.q_a[i])} | "
              f"{' / '.join(f'{v:.4g}' for v in check.q_b[i])} | {check.rel[i, j]:.3f} "
              f"({('5 %', 'median', '95 %')[j]}) | {check.z[i, j]:.1f} | "
              f"{'DIFFERS' if check.differs[i].any() else ''} |")  # fmt: skip
    print(f"the samplers {'agree' if check.agree else 'DISAGREE'} on the quantiles")


if __name__ == "__main__":
    main()
