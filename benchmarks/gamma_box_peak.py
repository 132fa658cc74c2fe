"""How much likelihood the paper's gamma box costs a model-choice stage's model: the runs' log-likelihood (noise sds
integrated out, what the nested runs see: ``nested_target``) maximised over the whole box for gamma's upper bound
at the paper's 0.95 and above.

The model's instantaneous fibre modulus is :math:`g_\\infty/(1-\\gamma)` (docs/model.md), so gamma is physically in
[0, 1); the paper's search box stops at 0.95. Where the peak of the likelihood lies on that bound, the box cuts the
posterior. Each box: differential evolution in box coordinates (0 at a bound, 1 at the other; log scale where the
prior is log-uniform), vectorised over the batched forward model, from ``--seeds`` seeds, each polished by
Nelder-Mead; the largest value is the peak. Prints each search's optimum and the peak of each box.

    OPENBLAS_NUM_THREADS=1 python benchmarks/gamma_box_peak.py [--data joint] [--model mirror]
        [--upper 0.95 0.99 0.999] [--seeds 3] [--maxiter 600] [--popsize 20]
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402
from scipy.optimize import differential_evolution, minimize  # noqa: E402

from bayestissue.analyses.model_choice import CANDIDATES, DATASETS, TESTS, model_settings  # noqa: E402
from bayestissue.inference import NestedOptions  # noqa: E402
from bayestissue.inference.sampling.nested import nested_target  # noqa: E402
from bayestissue.mechanics import load_experiment  # noqa: E402
from bayestissue.paper import PAPER_BOUNDS  # noqa: E402
from bayestissue.workflows import load_config  # noqa: E402
from bayestissue.workflows.problem import build_problem  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
GAMMAS = ("gamma1", "gamma2", "gamma3")


def problem_with_gamma_box(data: str, model: str, upper: float):
    """The stage's problem of ``model`` on ``data`` with every gamma's box [Table 1 lower, ``upper``]."""
    overrides = dict(CANDIDATES[data][model])
    lower = PAPER_BOUNDS[3, 0]  # Table 1 order: mu, kappa, ginf1, gamma1, ...
    overrides["bounds"] = {g: [float(lower), upper] for g in GAMMAS}
    experiments = [load_experiment(ROOT / "data" / f"{test}.toml") for test in TESTS[data]]
    return build_problem(experiments, load_config(None, **overrides))


def peak(problem, options: NestedOptions, seed: int, maxiter: int, popsize: int) -> tuple[float, dict]:
    """The largest log-likelihood one search finds (differential evolution, then Nelder-Mead), and where."""
    n, _, log_l, _ = nested_target(problem, options)
    box = problem.material if n == problem.n_material else problem.parameters

    def minus_log_l(u):  # u: (n, S), differential evolution's vectorised layout
        v = -np.asarray(log_l(box.from_unit(np.clip(np.atleast_2d(np.asarray(u).T), 0.0, 1.0))))
        return np.where(np.isfinite(v), v, 1e12)

    r = differential_evolution(minus_log_l, [(0.0, 1.0)] * n, vectorized=True, updating="deferred", seed=seed,
                               popsize=popsize, maxiter=maxiter, tol=1e-10, polish=False)  # fmt: skip
    r = minimize(lambda u: float(minus_log_l(u[:, None])[0]), r.x, method="Nelder-Mead",
                 options={"maxfev": 6000, "xatol": 1e-9, "fatol": 1e-9, "adaptive": True})  # fmt: skip
    x = box.from_unit(np.clip(r.x, 0.0, 1.0)[None, :])[0]
    return -float(r.fun), dict(zip([s.name for s in box.sampled], x, strict=True))


def main(argv=None) -> dict[float, float]:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", choices=DATASETS, default="joint")
    ap.add_argument("--model", default="mirror")
    ap.add_argument("--upper", type=float, nargs="+", default=[0.95, 0.99, 0.999])
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--maxiter", type=int, default=600)
    ap.add_argument("--popsize", type=int, default=20)
    args = ap.parse_args(argv)
    if args.model not in CANDIDATES[args.data]:
        ap.error(f"--model {args.model!r}: expected one of {sorted(CANDIDATES[args.data])} for --data {args.data}")
    options = NestedOptions(**model_settings("full", args.data, args.model))
    peaks = {}
    for upper in args.upper:
        t0 = time.perf_counter()
        problem = problem_with_gamma_box(args.data, args.model, upper)
        found = []
        for seed in range(1, args.seeds + 1):
            value, where = peak(problem, options, seed, args.maxiter, args.popsize)
            found.append(value)
            print(f"  gamma <= {upper}, seed {seed}: {value:.3f} at "
                  + ", ".join(f"{k} {v:.4g}" for k, v in where.items()), flush=True)  # fmt: skip
        peaks[upper] = max(found)
        print(f"{args.data}, {args.model} model, gamma <= {upper}: peak log-likelihood {peaks[upper]:.3f} "
              f"({time.perf_counter() - t0:.0f} s)", flush=True)  # fmt: skip
    base = peaks.get(0.95)
    if base is not None:
        for upper, value in peaks.items():
            if upper != 0.95:
                print(f"gamma <= {upper} against the paper's 0.95: peak {value - base:+.3f} nats")
    return peaks


if __name__ == "__main__":
    main()
