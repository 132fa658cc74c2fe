"""Sampling benchmark: time and ESS per second for the T1 posterior to meet the convergence verdict, either engine.

Prints (no pass/fail): the cost of one forward solve and of one log-posterior evaluation per
parameter set (the sampler's overhead ratio), then runs the calibration sampler on T1 (4 independent
ensembles in parallel processes, automatic length up to a step cap) and prints wall time, steps,
tau, min bulk/tail ESS, ESS per second, max R-hat and the verdict (R-hat < 1.01, ESS >= 400, length
>= 50 tau).

    python benchmarks/bench_sampling.py [--walkers 26] [--max-steps 6000] [--moves de_snooker]
        [--model full|mirror] [--coordinates box|creep] [--adapt-rounds 3] [--adapt-steps 1000]
        [--proposal own|shared]

``--model mirror`` ties fibre family 3's law to family 2's (8 material parameters); ``--coordinates
creep`` samples in the creep-curve coordinates of :mod:`bayestissue.inference.coordinates`.

    python benchmarks/bench_sampling.py --engine nested [--live 1000] [--neff 1000] [--runs 4] [--networks 4]
        [--max-evaluations N]

runs the nested engine instead (no least squares needed; the runs start from the prior) and prints the wall
time, the evaluations, the share of the time spent in the likelihood (evaluations x the measured cost of one),
each run's log evidence with its error, and the verdict (:mod:`bayestissue.inference.evidence`).
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from bayestissue.inference import (  # noqa: E402
    NestedOptions,
    SamplerOptions,
    assess_nested,
    fit_least_squares,
    sample_nested,
    sample_posterior,
)
from bayestissue.inference.coordinates import adapt_coordinates  # noqa: E402
from bayestissue.inference.diagnostics import assess_convergence  # noqa: E402
from bayestissue.mechanics import load_experiment, simulate  # noqa: E402
from bayestissue.paper import (
    MIRROR_TIES,  # noqa: E402
    PAPER_PARAMETERS,  # noqa: E402
)
from bayestissue.workflows import CalibrationConfig, build_problem  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--experiment", default="T1")
    ap.add_argument("--walkers", type=int, default=26, help="walkers per ensemble (26 = 2 ndim + 2)")
    ap.add_argument("--max-steps", type=int, default=6000)
    ap.add_argument("--moves", default="de_snooker")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--model", choices=["full", "mirror"], default="full")
    ap.add_argument("--coordinates", choices=["box", "creep", "ramp"], default="box")
    ap.add_argument("--adapt-rounds", type=int, default=3, help="mixture adaptation rounds (moves=mixture)")
    ap.add_argument("--adapt-steps", type=int, default=1000, help="steps per adaptation round")
    ap.add_argument(
        "--proposal", choices=["own", "shared"], default="own", help="mixture fitted per ensemble or shared"
    )
    ap.add_argument("--engine", choices=["emcee", "nested"], default="emcee")
    ap.add_argument("--live", type=int, default=1000, help="nested: live points per run")
    ap.add_argument("--neff", type=int, default=1000, help="nested: importance ESS per run")
    ap.add_argument("--runs", type=int, default=4, help="nested: independent runs")
    ap.add_argument("--networks", type=int, default=4, help="nested: neural networks per bound")
    ap.add_argument("--max-evaluations", type=int, default=None, help="nested: evaluations per run at most")
    args = ap.parse_args(argv)
    exp = load_experiment(ROOT / "data" / f"{args.experiment}.toml")
    tied = dict(MIRROR_TIES) if args.model == "mirror" else {}
    problem = build_problem([exp], CalibrationConfig(tied=tied, coordinates=args.coordinates))
    print(f"model {args.model}: sampled {', '.join(problem.names)}; coordinates {args.coordinates}")
    p = np.tile(PAPER_PARAMETERS[args.experiment], (args.walkers // 2, 1))
    simulate(exp, p)  # compile
    reps = 20
    t0 = time.perf_counter()
    for _ in range(reps):
        simulate(exp, p)
    t_fwd = (time.perf_counter() - t0) / (reps * p.shape[0])
    cols = [problem.material.names.index(n) for n in problem.material.sampled_names]
    theta = np.column_stack([p[:, cols], np.full(p.shape[0], 0.02)])
    z = problem.coordinates.to_unconstrained(theta)
    t0 = time.perf_counter()
    for _ in range(reps):
        problem.log_posterior_unconstrained(z)
    t_lp = (time.perf_counter() - t0) / (reps * p.shape[0])
    print(f"forward solve: {t_fwd * 1e3:.3f} ms per set; log-posterior: {t_lp * 1e3:.3f} ms per set")
    print(f"overhead of the inference layer: {t_lp / t_fwd:.2f} x the forward solve")
    if args.engine == "nested":
        return _nested(problem, args, t_lp)
    t0 = time.perf_counter()
    ls = fit_least_squares(problem, space="unit", max_nfev=400)
    t_ls = time.perf_counter() - t0
    print(f"least squares (unit space): cost {ls.cost:.5g}, {ls.nit} iterations, {t_ls:.1f} s")
    problem.coordinates = adapt_coordinates(problem, problem.nuisance_estimate(ls.x))
    opts = SamplerOptions(
        n_walkers=args.walkers,
        moves=args.moves,
        max_steps=args.max_steps,
        check_every=100,
        adapt_rounds=args.adapt_rounds,
        adapt_steps=args.adapt_steps,
        proposal=args.proposal,
    )
    sample = sample_posterior(
        problem,
        problem.nuisance_estimate(ls.x),
        cov=ls.cov,
        options=opts,
        rng=args.seed,
    )
    rep = assess_convergence(sample)
    n_eval = sample.n_evaluations
    print(
        f"sampling: {rep.time_s:.1f} s wall, {n_eval} log-posterior evaluations "
        f"({rep.time_s / max(n_eval, 1) * 1e3:.3f} ms each incl. 2 processes), "
        f"steps per ensemble {rep.n_steps.tolist()}"
    )
    print(f"max tau per ensemble (steps): {np.round(rep.tau.max(axis=1), 1).tolist()}")
    print(
        f"min bulk ESS {rep.ess_bulk.min():.0f}, min tail ESS {rep.ess_tail.min():.0f}, "
        f"ESS/s {rep.ess_per_second():.3f}, min bulk ESS per 1000 evaluations "
        f"{1e3 * rep.ess_bulk.min() / max(n_eval, 1):.3f}, max R-hat {rep.rhat.max():.4f}, "
        f"median acceptance {np.median(rep.acceptance):.3f}"
    )
    print(rep.verdict())
    return 0


def _nested(problem, args, t_eval) -> int:
    opts = NestedOptions(
        n_live=args.live,
        n_eff=args.neff,
        n_runs=args.runs,
        n_networks=args.networks,
        max_evaluations=args.max_evaluations,
    )
    t0 = time.perf_counter()

    def progress(k, n_like, n_eff, explored, log_z):
        phase = f"sampling, n_eff {n_eff:.0f}" if explored else "exploring"
        print(f"  [{time.perf_counter() - t0:7.1f} s] run {k}: {n_like} evaluations, {phase}, log Z {log_z:.2f}")

    sample = sample_nested(problem, options=opts, progress=progress, rng=args.seed)
    rep = assess_nested(sample)
    n_eval = sample.n_evaluations
    cpu = sum(r.time_s for r in sample.runs)
    print(
        f"nested: {sample.time_s:.1f} s wall, {cpu:.1f} s summed over runs, {n_eval} evaluations; likelihood "
        f"about {n_eval * t_eval:.1f} s of it ({100 * n_eval * t_eval / cpu:.0f} %), the rest nautilus (bounds, "
        "network training)"
    )
    for k, r in enumerate(sample.runs):
        print(
            f"run {k}: {r.n_like} evaluations, {r.time_s:.1f} s, n_eff {r.n_eff:.0f}, log Z {r.log_z:.3f} +- "
            f"{r.log_z_err:.3f}, finished {r.finished}"
        )
    print(
        f"log Z {sample.log_z:.3f} +- {sample.log_z_err:.3f}; min bulk ESS {rep.ess_bulk.min():.0f}, "
        f"min tail ESS {rep.ess_tail.min():.0f}, max R-hat {rep.rhat.max():.4f}"
    )
    print(rep.verdict())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
