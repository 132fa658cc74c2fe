"""Forward-model speed: T1 simulations per second on one core, against a straightforward baseline in the same run,
and against the kernel before the laws became plug-ins (benchmarks/legacy_kernel.py: same sets, same process, ratio
over repeated alternating rounds; the target is no more than 10 % slower).

The batch: parameter sets drawn from the Table 1 box (docs/model.md) the way the default prior draws them (log-uniform
for the moduli and rates, uniform for gamma), seeded. The baseline: per set, per step ``scipy.optimize.root`` on the
six equilibrium equations with a NumPy stress (bayestissue.mechanics.reference). Also the first-call compile time
(cold numba cache, in a fresh process) and the warm-cache start-up.

    OPENBLAS_NUM_THREADS=1 python benchmarks/bench_forward.py [--n-sets 2000] [--n-baseline 5] [--rounds 5]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from bayestissue.mechanics import load_experiment, simulate  # noqa: E402
from bayestissue.mechanics.fibres import fibre_structure  # noqa: E402
from bayestissue.mechanics.forward import ForwardModel  # noqa: E402
from bayestissue.mechanics.reference import reference_simulate_experiment  # noqa: E402
from bayestissue.paper import PAPER_BOUNDS, PAPER_PARAMETERS  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from benchmarks.legacy_kernel import legacy_solve_uniaxial_batch  # noqa: E402

_STARTUP = (
    "import time; t = time.perf_counter(); import numpy as np; "
    "from bayestissue.mechanics import load_experiment, simulate; from bayestissue.paper import PAPER_PARAMETERS; "
    f"e = load_experiment({str(ROOT / 'data' / 'T1.toml')!r}); simulate(e, PAPER_PARAMETERS['T1']); "
    "print(time.perf_counter() - t)"
)


def draw_box(n: int, rng) -> np.ndarray:
    lo, hi = PAPER_BOUNDS.T
    p = np.exp(rng.uniform(np.log(lo), np.log(hi), (n, lo.size)))
    for j in (3, 6, 9):  # gamma: uniform
        p[:, j] = rng.uniform(lo[j], hi[j], n)
    return p


def kernel_runs(exp, sets: np.ndarray):
    """``(run_new, run_legacy)``: callables that run the plug-in kernel and the frozen pre-plug-in kernel on
    ``sets`` (rows of T1 parameters), filling arrays only (no observation at the data times)."""
    fm, t = ForwardModel(exp), exp.tissue
    sets = np.ascontiguousarray(sets)
    n = sets.shape[0]
    old, ok = np.empty((n, fm.load.size)), np.empty(n, dtype=bool)
    args = (fibre_structure(t.directions), np.ascontiguousarray(t.phi_fibres), t.phi_matrix, t.bulk_kpa,
            np.ascontiguousarray(t.eps0), fm.load, exp.dt_s, exp.specimen_mm[0])  # fmt: skip

    def run_legacy():
        legacy_solve_uniaxial_batch(sets, *args, old, ok, np.empty((1, 1, 6)), np.empty((1, 1, 3)), False,
                                    np.zeros(n, dtype=np.int64), False)  # fmt: skip

    def run_new():
        fm._run(sets, False, False)

    return run_new, run_legacy


def legacy_ratio(exp, sets: np.ndarray, rounds: int) -> tuple[list[float], float, float]:
    """Per round, time(plug-in kernel) / time(frozen pre-plug-in kernel) on the same ``sets`` (alternating order,
    the plug-in first in even rounds); also the best time per set of each (s). Both fill arrays only
    (:func:`kernel_runs`), so the ratio is of the kernels alone."""
    n = sets.shape[0]
    run_new, run_legacy = kernel_runs(exp, sets)

    run_new(), run_legacy()  # compile / load outside the timing
    ratios, best_new, best_old = [], np.inf, np.inf
    for r in range(rounds):
        times = {}
        for name, fn in (("new", run_new), ("old", run_legacy))[:: 1 if r % 2 == 0 else -1]:
            t0 = time.perf_counter()
            fn()
            times[name] = time.perf_counter() - t0
        ratios.append(times["new"] / times["old"])
        best_new, best_old = min(best_new, times["new"] / n), min(best_old, times["old"] / n)
    return ratios, best_new, best_old


def first_call_seconds(cache_dir: str) -> float:
    env = dict(os.environ, NUMBA_CACHE_DIR=cache_dir, OPENBLAS_NUM_THREADS="1")
    out = subprocess.run([sys.executable, "-c", _STARTUP], env=env, capture_output=True, text=True, check=True)
    return float(out.stdout.strip().splitlines()[-1])


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n-sets", type=int, default=2000)
    ap.add_argument("--n-baseline", type=int, default=5)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--rounds", type=int, default=5, help="alternating rounds of the plug-in vs frozen kernel")
    ap.add_argument("--skip-compile", action="store_true", help="skip the cold-cache compile timing (about a minute)")
    args = ap.parse_args(argv)

    cold = warm = float("nan")
    if not args.skip_compile:
        with tempfile.TemporaryDirectory() as cache:
            cold = first_call_seconds(cache)
            warm = first_call_seconds(cache)
        print(f"first call (compile, cold numba cache): {cold:.2f} s; with warm cache: {warm:.2f} s (target < 10 s)")

    exp = load_experiment(ROOT / "data" / "T1.toml")
    rng = np.random.default_rng(args.seed)
    sets = draw_box(args.n_sets, rng)
    simulate(exp, sets[:4])  # compile / load from cache outside the timing
    t0 = time.perf_counter()
    u = simulate(exp, sets)
    fast = time.perf_counter() - t0
    ok = np.isfinite(u[:, -1])
    per_fast = fast / args.n_sets
    print(
        f"compiled batch: {args.n_sets} T1 simulations ({exp.n_steps} steps) in {fast:.3f} s = {per_fast * 1e6:.1f} us "
        f"each, {1 / per_fast:,.0f}/s; {np.count_nonzero(~ok)} sets flagged failed ({np.mean(~ok):.1%})"
    )
    ratios, t_new, t_old = legacy_ratio(exp, sets, args.rounds)
    print(
        f"plug-in kernel / frozen pre-plug-in kernel (T1, same {args.n_sets} sets, {args.rounds} alternating rounds): "
        f"ratio {min(ratios):.3f}-{max(ratios):.3f} (median {np.median(ratios):.3f}; target <= 1.10); best "
        f"{t_new * 1e6:.1f} vs {t_old * 1e6:.1f} us per set (ratio of the best rounds {t_new / t_old:.3f}: load slows "
        "some rounds, rarely the best)"
    )
    near = PAPER_PARAMETERS["T1"] * np.exp(rng.normal(0, 0.2, (args.n_sets, 11)))
    near[:, [3, 6, 9]] = np.clip(near[:, [3, 6, 9]], 0.1, 0.95)
    t0 = time.perf_counter()
    u_near = simulate(exp, near)
    per_near = (time.perf_counter() - t0) / args.n_sets
    print(
        f"compiled batch near the T1 optimum (log-normal 20 % scatter): {per_near * 1e6:.1f} us each, "
        f"{1 / per_near:,.0f}/s; {np.count_nonzero(np.isnan(u_near[:, -1]))} failed"
    )

    base_sets = sets[ok][: args.n_baseline]
    t0 = time.perf_counter()
    for p in base_sets:
        reference_simulate_experiment(exp, p)
    per_base = (time.perf_counter() - t0) / len(base_sets)
    print(
        f"baseline (scipy.optimize.root per step, NumPy stress): {per_base * 1e3:.1f} ms each ({len(base_sets)} sets)"
    )
    ratio = per_base / per_fast
    print(
        f"ratio baseline/compiled: {ratio:,.0f}x (target >= 1000x); compiled rate {1 / per_fast:,.0f}/s "
        f"(target >= 10,000/s)"
    )
    return {
        "per_sim_s": per_fast,
        "per_sim_near_s": per_near,
        "baseline_s": per_base,
        "ratio": ratio,
        "compile_s": cold,
        "warm_start_s": warm,
        "failed_fraction": float(np.mean(~ok)),
        "legacy_ratios": ratios,
    }


if __name__ == "__main__":
    main()
