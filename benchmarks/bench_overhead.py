"""Inference-layer overhead on the T1 batch: the sampler's target against the bare numba kernel, same process.

    python benchmarks/bench_overhead.py [--sets 18] [--reps 200] [--repeats 5]

Times, per call on a batch of ``--sets`` parameter sets (the paper's T1 estimate; the mirror model in creep
coordinates, as the study samples it):

* ``kernel``: ``solve_batch`` with the fixed inputs computed beforehand (the floor);
* ``ForwardModel``: parameter check + kernel + interpolation (fixed inputs computed once per experiment);
* ``simulate``: the same through a new ForwardModel per call (fixed inputs recomputed, as every call did before
  the one-pipeline redesign);
* ``log-posterior``: ``CalibrationProblem.log_posterior_unconstrained`` (what emcee calls).

and prints the ratios to the kernel (min over ``--repeats`` repeats, each the mean of ``--reps`` calls; the
machine is shared, so compare ratios from one run) and the Python frames between emcee's call and the kernel.
Runs unchanged on a checkout from before the redesign (imports fall back), for the before/after figures.
"""

from __future__ import annotations

import argparse
import os
import sys
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from bayestissue.mechanics import (  # noqa: E402
    ForwardModel,  # noqa: E402
    load_experiment,
    simulate,
)
from bayestissue.mechanics.solver import solve_batch  # noqa: E402

try:  # after the redesign
    from bayestissue.paper import MIRROR_TIES, PAPER_PARAMETERS
    from bayestissue.workflows import CalibrationConfig, build_problem

    KERNEL_MODULE = "bayestissue.mechanics.forward"
except ImportError:  # before it
    from bayestissue.inference.calibration import CalibrationConfig, build_problem

    from bayestissue.inference import MIRROR_TIES
    from bayestissue.mechanics import PAPER_PARAMETERS

    KERNEL_MODULE = "bayestissue.mechanics.simulate"

ROOT = Path(__file__).resolve().parents[1]


def _best(fn, reps, repeats) -> float:
    best = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        for _ in range(reps):
            fn()
        best = min(best, (time.perf_counter() - t0) / reps)
    return best


def _frames(problem, z) -> list[str]:
    module = sys.modules[KERNEL_MODULE]
    kernel, chain = module.solve_batch, []

    def recording(*args):
        frame = sys._getframe(1)
        while frame is not None and frame.f_code.co_name != "log_posterior_unconstrained":
            chain.append(frame.f_code.co_name)
            frame = frame.f_back
        return kernel(*args)

    module.solve_batch = recording
    try:
        problem.log_posterior_unconstrained(z)
    finally:
        module.solve_batch = kernel
    return ["log_posterior_unconstrained", *chain[::-1]]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sets", type=int, default=18)
    ap.add_argument("--reps", type=int, default=200)
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args(argv)
    exp = load_experiment(ROOT / "data" / "T1.toml")
    problem = build_problem([exp], CalibrationConfig(tied=dict(MIRROR_TIES), coordinates="creep"))
    p = np.tile(np.asarray(PAPER_PARAMETERS["T1"]), (args.sets, 1))
    cols = [problem.material.names.index(n) for n in problem.material.sampled_names]
    z = problem.coordinates.to_unconstrained(np.column_stack([p[:, cols], np.full(args.sets, 0.02)]))
    t = exp.tissue
    fixed = ForwardModel(exp).kernel_inputs  # computed before the timing: the floor is the kernel alone
    n_t = exp.n_steps + 1
    p2 = np.ascontiguousarray(p)

    def kernel():
        u, ok = np.empty((args.sets, n_t, 1)), np.empty(args.sets, dtype=np.bool_)
        s, tau, it = np.empty((1, 1, 6)), np.empty((1, 1, t.n_fibres)), np.zeros(args.sets, dtype=np.int64)
        solve_batch(p2, *fixed, u, ok, s, tau, False, it, None)

    timings = {"kernel": kernel, "simulate": lambda: simulate(exp, p)}
    try:
        model = ForwardModel(exp)
        timings["ForwardModel"] = lambda: model(p)
    except ImportError:
        pass
    timings["log-posterior"] = lambda: problem.log_posterior_unconstrained(z)
    for fn in timings.values():
        fn()  # compile and warm
    base = _best(kernel, args.reps, args.repeats)
    print(f"T1 batch of {args.sets} sets, {args.reps} calls x {args.repeats} repeats (min), one core")
    for name, fn in timings.items():
        sec = base if name == "kernel" else _best(fn, args.reps, args.repeats)
        print(f"{name:<14s} {sec * 1e3:8.3f} ms per call  {sec / base:6.3f} x kernel")
    chain = _frames(problem, z)
    print(f"Python frames from emcee's call to the kernel: {len(chain)} ({' -> '.join(chain)})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
