"""Exact sensitivities: their cost against a forward run, and the warm start with them against forward differences.

1. Cost (T1 and T2, batches of parameter sets drawn from the Table 1 box as the prior draws them, seeded): one call of
   ``ForwardModel.sensitivities`` (forward run with states kept + the differentiation pass, all 11 parameters)
   against one plain forward call of the same batch, and against the 12 forward calls a forward-difference Jacobian
   costs. Median of ``--repeats`` timings each, interleaved, in one process; the issue's target is <= 3x a forward
   run.
2. Least squares (``fit_least_squares``, the paper's TRF) from the same starts with the batched forward-difference
   Jacobian and with the exact one: cost reached, iterations, evaluations, time. Starts: the paper's initial guess
   (where the paper's T1 fit stalled) and both Table 1 results, in the paper's natural scaling and in the scaled box.

    OPENBLAS_NUM_THREADS=1 python benchmarks/bench_sensitivity.py [--n-sets 64] [--repeats 7]
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402
from bench_forward import draw_box  # noqa: E402  (benchmarks/ is on the path when a script here runs)

from bayestissue.inference import fit_least_squares  # noqa: E402
from bayestissue.mechanics import ForwardModel, load_experiment  # noqa: E402
from bayestissue.paper import PAPER_PARAMETERS  # noqa: E402
from bayestissue.workflows.config import CalibrationConfig  # noqa: E402
from bayestissue.workflows.problem import build_problem  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def _median_time(fn, repeats):
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return float(np.median(times))


def cost(name: str, n_sets: int, repeats: int, seed: int) -> None:
    fm = ForwardModel(load_experiment(ROOT / "data" / f"{name}.toml"))
    p = draw_box(n_sets, np.random.default_rng(seed))
    fm(p[:2])
    fm.sensitivities(p[:2])  # compile / load the cache
    ok = np.isfinite(fm(p)).all(axis=1)
    t_fwd = _median_time(lambda: fm(p), repeats)
    t_sens = _median_time(lambda: fm.sensitivities(p), repeats)
    print(
        f"{name}: {n_sets} sets ({ok.sum()} solved): forward {1e6 * t_fwd / n_sets:.0f} us/set, "
        f"sensitivities (11 parameters) {1e6 * t_sens / n_sets:.0f} us/set = {t_sens / t_fwd:.2f} x a forward run "
        f"(forward differences: 12 x)"
    )


def least_squares(name: str) -> None:
    prob = build_problem([load_experiment(ROOT / "data" / f"{name}.toml")], CalibrationConfig())
    print(f"\n{name}: least squares from the same starts (cost = 0.5 sum r^2, residuals in mm)")
    print("| start | space | Jacobian | cost | iterations | nfev | time (s) | status |")
    print("|---|---|---|---|---|---|---|---|")
    for start in ("initial", "T1", "T2"):
        for space in ("natural", "unit"):
            for jac in ("differences", "exact"):
                t = time.perf_counter()
                r = fit_least_squares(prob, PAPER_PARAMETERS[start], jacobian=jac, space=space, max_nfev=2000)
                dt = time.perf_counter() - t
                print(f"| {start} | {space} | {jac} | {r.cost:.6g} | {r.nit} | {r.nfev} | {dt:.2f} | {r.status} |")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n-sets", type=int, default=64)
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args(argv)
    for name in ("T1", "T2"):
        cost(name, args.n_sets, args.repeats, args.seed)
    for name in ("T1", "T2"):
        least_squares(name)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
