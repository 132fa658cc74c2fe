"""Nested runs as dask tasks: wall time with 1, 2, ... workers of a LocalCluster, against forked processes on the same
runs, and what that projects for a cluster (issue 36: the 11-parameter posterior as a distributed job).

The problem: the bundled T1 creep (or T2 ramp) through the real forward model, the mirror model by default (``--full``
samples all 11 parameters), noise integrated out. Every configuration runs the same ``--runs`` seeded runs, so they must
return the same runs bit for bit (checked and printed). Projection: the runs are independent and none is split, so on
W workers the wall time is the start-up plus the longest chain of runs one worker gets,

    t(W) ~ t_start + ceil(R / W) * t_run,

with t_run the mean run time measured with every worker busy (runs sharing a machine slow each other: memory, turbo)
and t_start the excess of the 1-worker wall time over the sum of its run times; beyond W = R workers only more runs
(more effective draws, a tighter merged error) use the cores.

    OPENBLAS_NUM_THREADS=1 python benchmarks/cluster_scaling.py [--data T1] [--full] [--runs 2] [--workers 1 2]
        [--sampler nautilus|ultranest] [--n-live 300] [--n-eff 500] [--max-evaluations N]
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from bayestissue.inference import NestedOptions, sample_nested  # noqa: E402
from bayestissue.mechanics import load_experiment  # noqa: E402
from bayestissue.paper import MIRROR_TIES  # noqa: E402
from bayestissue.parallel import projected_wall_time  # noqa: E402
from bayestissue.workflows import load_config  # noqa: E402
from bayestissue.workflows.problem import build_problem  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", default="T1", choices=("T1", "T2"))
    ap.add_argument("--full", action="store_true", help="all 11 parameters (default: the mirror model, 8)")
    ap.add_argument("--runs", type=int, default=2)
    ap.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    ap.add_argument(
        "--sampler",
        default="nautilus",
        choices=("nautilus", "ultranest"),
        help="ultranest: the full-model stage's engine (population slice sampler, population 100)",
    )
    ap.add_argument("--n-live", type=int, default=300)
    ap.add_argument("--n-eff", type=int, default=500)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--max-evaluations", type=int, default=None, help="cap each run (a smoke run)")
    args = ap.parse_args(argv)

    exp = load_experiment(ROOT / "data" / f"{args.data}.toml")
    problem = build_problem([exp], load_config(None, tied=None if args.full else dict(MIRROR_TIES)))
    base = {"sampler": args.sampler, "n_live": args.n_live, "n_eff": args.n_eff, "n_runs": args.runs,
            "max_evaluations": args.max_evaluations, "report_every": 1000}  # fmt: skip
    base.update({"n_networks": 1} if args.sampler == "nautilus" else {"population": 100})
    model = "full" if args.full else "mirror"
    print(f"{args.data}, {model} model ({problem.ndim} sampled), {args.runs} {args.sampler} runs of {args.n_live} live "
          f"points, n_eff {args.n_eff}, seed {args.seed}; {os.cpu_count()} cores")  # fmt: skip
    configs = [(f"forked processes, {max(args.workers)}", NestedOptions(**base, n_processes=max(args.workers)))]
    configs += [(f"dask LocalCluster, {w} worker(s)", NestedOptions(**base, n_processes=w, scheduler="local"))
                for w in args.workers]  # fmt: skip
    rows, reference = [], None
    for label, opts in configs:
        t0 = time.perf_counter()
        s = sample_nested(problem, options=opts, rng=args.seed)
        wall = time.perf_counter() - t0
        same = reference is None or all(
            a.log_z == b.log_z and np.array_equal(a.points, b.points, equal_nan=True)
            for a, b in zip(reference.runs, s.runs, strict=True)
        )
        reference = reference or s
        run_s = [r.time_s for r in s.runs]
        rows.append((label, opts, wall, run_s))
        print(f"  {label}: wall {wall:.1f} s, runs {', '.join(f'{t:.1f}' for t in run_s)} s, "
              f"{sum(r.n_like for r in s.runs)} evaluations, log Z {s.log_z:.3f}, same runs as the first: "
              f"{'yes' if same else 'NO'}")  # fmt: skip
    dask = [(opts.n_processes, wall, run_s) for label, opts, wall, run_s in rows if opts.scheduler]
    w1 = next(((wall, run_s) for w, wall, run_s in dask if w == 1), None)
    for w, wall, _ in dask:
        if w1 is not None and w > 1:
            print(f"  speed-up {w} workers over 1: {w1[0] / wall:.2f}x (ideal {min(w, args.runs)}x)")
    if w1 is not None:
        w_max, _, loaded = max(dask)
        t_alone, t_run = float(np.mean(w1[1])), float(np.mean(loaded))
        t_start = max(w1[0] - sum(w1[1]), 0.0)
        print(f"  mean run time alone {t_alone:.1f} s, beside {w_max - 1} other(s) {t_run:.1f} s "
              f"({t_run / t_alone:.2f}x: runs sharing this machine)")  # fmt: skip
        proj = ", ".join(f"{w} workers {projected_wall_time(args.runs, t_run, w, t_start):.0f} s" for w in (4, 16, 64))
        print(f"  projected for {args.runs} runs (t_start {t_start:.1f} s + ceil(R/W) x t_run {t_run:.1f} s): {proj}; "
              f"R = W runs take the same wall time for W times the draws")  # fmt: skip


if __name__ == "__main__":
    main()
