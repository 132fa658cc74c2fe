"""Simulation-based calibration of the emcee path the examples recommend, through the real forward model (issue 36).

The path is the whole of ``bayestissue fit`` with ``examples/creep_T1.toml`` or ``examples/ramp_T2.toml``: the
mirror model (family 3 tied to family 2), the paper's least squares and the multi-start warm start, the creep or ramp
coordinates adapted to the best optimum, ensembles with mixture moves (Student-t independence proposals fitted over
discarded adaptation rounds, plus differential evolution), automatic length, the convergence verdict. Every
replication samples in one process; to fit a 2-core machine's hour, ``--ensembles`` and ``--max-steps`` may lower the
examples' 4 ensembles and step cap (printed; replications stopped at the cap are kept and counted as NOT CONVERGED).

The problems (Talts et al. 2018, arXiv:1804.06788; ranks and their tests in ``sbc_ranks.py``):

- **creep**: the first 240 s of the T1 creep test (its specimen and stress; 81 observations 3 s apart);
- **ramp**: the first 480 s of the T2 test (its specimen; the 240 s hold at 1.6 kPa and 240 s of the force ramp that
  follows; 81 observations 6 s apart).

In both, the five parameters the coordinates reshape (``mu``, ``kappa``, ``ginf2``, ``gamma2``, ``beta2``) are drawn
from the prior the fit then uses: log-uniform (uniform for ``gamma2``) on the boxes of :data:`BOXES`, narrower than
Table 1's so that every draw is a creep curve or ramp the test can inform (they are printed); family 1 is held at
Table 1's value of the same test; the noise sd is known (:data:`NOISE_SD`, about 1 % of the displacement). Each
replication's ``L`` posterior draws are spread evenly over all ensembles, walkers and kept steps.

Printed per problem and parameter: the rank counts per decile, a chi-square test (9 dof) and a KS test with their
p-values, how many central 90 % intervals of the ``L`` draws hold the generating value (binomial 99 % range printed),
and how many replications the verdict called CONVERGED. No pass/fail: read the p-values (5 parameters x 2 tests x 2
problems: one p below 0.01 by chance has probability about 18 %).

    python benchmarks/sbc_emcee.py [--problems creep ramp] [--reps 100] [--draws 99]
        [--max-steps N] [--ensembles N] [--coordinates box] [--processes 2] [--out docs/emcee_sbc.png]
    python benchmarks/sbc_emcee.py --from-log LOG... --out docs/emcee_sbc.png   # tests and figure from printed runs

Every replication prints one line with its ranks as it finishes, so a log holds the results of a run that was
stopped; ``--from-log`` reads those lines back (the rank tests, the interval counts and the figure), a replication
seen in several logs once. ``--start R`` continues with replications R, R + 1, ... (their own seeds).
"""

from __future__ import annotations

import argparse
import dataclasses
import multiprocessing as mp
import os
import re
import sys
import time
import tomllib
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402
from scipy import stats  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from sbc_ranks import rank_figure, rank_lines, rank_tests  # noqa: E402

from bayestissue.mechanics import load_experiment, simulate  # noqa: E402
from bayestissue.paper import MIRROR_TIES, PAPER_PARAMETERS  # noqa: E402
from bayestissue.workflows import config_from_mapping, run_calibration  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
NAMES = ("mu", "kappa", "ginf1", "gamma1", "beta1", "ginf2", "gamma2", "beta2", "ginf3", "gamma3", "beta3")
SAMPLED = ("mu", "kappa", "ginf2", "gamma2", "beta2")
#: Prior boxes of the sampled parameters (kPa, kPa, kPa, -, 1/s), per problem.
BOXES = {
    "creep": dict(mu=(0.5, 5.0), kappa=(0.5, 5.0), ginf2=(5.0, 50.0), gamma2=(0.3, 0.9), beta2=(2e-3, 5e-2)),
    "ramp": dict(mu=(0.05, 0.5), kappa=(20.0, 200.0), ginf2=(3.0, 30.0), gamma2=(0.1, 0.6), beta2=(0.05, 2.5)),
}
#: The test each problem shortens, and the example configuration it runs.
TESTS = {"creep": ("T1", "creep_T1.toml"), "ramp": ("T2", "ramp_T2.toml")}
SECONDS = {"creep": 240.0, "ramp": 480.0}
NOISE_SD = 0.01  # mm
LEVEL = 0.90


def _replication_rng(problem: str, r: int, seed: int):
    return np.random.default_rng([seed, list(TESTS).index(problem), r])


def prior_quantiles(problem: str, r: int, seed: int) -> np.ndarray:
    """Where replication ``r``'s generating values lie in their priors (the uniform draws behind them, in the order
    of :data:`SAMPLED`): recomputed from the seed, so logs need not carry them."""
    rng = _replication_rng(problem, r, seed)
    return np.array([rng.uniform() for _ in BOXES[problem]])


def _draw_truth(problem: str, rng) -> dict:
    truth = dict(zip(NAMES, PAPER_PARAMETERS[TESTS[problem][0]], strict=True))
    for name, (lo, hi) in BOXES[problem].items():
        u = rng.uniform()  # the order and count of these draws are prior_quantiles'
        uniform = name.startswith("gamma")
        truth[name] = lo + u * (hi - lo) if uniform else float(np.exp(np.log(lo) + u * np.log(hi / lo)))
    for follower, leader in MIRROR_TIES:
        truth[follower] = truth[leader]
    return truth


def _config(problem: str, truth: dict, seed: int, args):
    with open(ROOT / "examples" / TESTS[problem][1], "rb") as f:
        cfg = tomllib.load(f)
    boxes = BOXES[problem]
    cfg["parameters"].update(
        sampled=list(SAMPLED),
        bounds={n: list(b) for n, b in boxes.items()},
        # the least squares starts at the box's centre (in its log scale), family 1 at the generating values
        initial={n: (float(np.sqrt(boxes[n][0] * boxes[n][1])) if n in boxes else truth[n]) for n in NAMES[:8]},
    )
    cfg["likelihood"] = {"sd": NOISE_SD}
    cfg["sampler"]["seed"] = seed
    cfg["sampler"]["cross_check"] = "none"  # the ranks are the ensembles' draws; the check only adds to the verdict
    cfg["sampler"]["n_processes"] = 1
    if args.max_steps:
        cfg["sampler"]["max_steps"] = args.max_steps
    if args.ensembles:
        cfg["sampler"]["n_ensembles"] = args.ensembles
    if args.coordinates:
        cfg["sampler"]["coordinates"] = args.coordinates
    cfg["output"] = {"n_predictive": 20}
    return config_from_mapping(cfg, where=f"examples/{TESTS[problem][1]}")


def _replication(job):
    problem, r, args = job
    rng = _replication_rng(problem, r, args.seed)
    exp = load_experiment(ROOT / "data" / f"{TESTS[problem][0]}.toml")
    keep = exp.time_s <= SECONDS[problem]
    exp = dataclasses.replace(exp, time_s=exp.time_s[keep], displacement_mm=None, force_mN=None)
    truth = _draw_truth(problem, rng)
    clean = np.atleast_2d(simulate(exp, np.array([truth[n] for n in NAMES])))[0]
    if not np.all(np.isfinite(clean)):
        return problem, r, None
    exp = dataclasses.replace(exp, displacement_mm=clean + NOISE_SD * rng.standard_normal(clean.size))
    t0 = time.perf_counter()
    out = run_calibration([exp], _config(problem, truth, int(rng.integers(2**31 - 1)), args))
    draws = out.sample.flat()
    keep = draws[np.linspace(0, draws.shape[0] - 1, args.draws).astype(int)]
    names = list(out.problem.names)
    cols = [names.index(n) for n in SAMPLED]
    tv = np.array([truth[n] for n in SAMPLED])
    row = {
        "r": r,
        "ranks": np.sum(keep[:, cols] < tv, axis=0),
        "converged": bool(out.report.converged),
        "steps": max(e.n_steps for e in out.sample.ensembles),
        "seconds": time.perf_counter() - t0,
    }
    return problem, r, row


def _summary(problem: str, rows: list[dict], args) -> tuple[np.ndarray, list[dict], np.ndarray]:
    """Print and return the ranks, their tests and the verdicts; the 90 % interval of the ``L`` draws holds the
    generating value when its rank is within ``[0.05 (L + 1), L - 0.05 (L + 1)]`` (90 of the 100 ranks when L = 99)."""
    ranks = np.array([row["ranks"] for row in rows])
    n = len(rows)
    cut = round((1 - LEVEL) / 2 * (args.draws + 1))
    inside = (ranks >= cut) & (ranks <= args.draws - cut)
    lo, hi = stats.binom.ppf([0.005, 0.995], n, LEVEL)
    secs = [row["seconds"] for row in rows if "seconds" in row]
    timing = f"; seconds per fit median {np.median(secs):.0f} (range {min(secs):.0f}-{max(secs):.0f})" if secs else ""
    print(
        f"\n{problem} ({TESTS[problem][0]}, first {SECONDS[problem]:.0f} s, examples/{TESTS[problem][1]}): "
        f"{n} replications, {sum(row['converged'] for row in rows)} CONVERGED{timing}"
    )
    print(f"boxes: {BOXES[problem]}")
    tests = rank_tests(ranks, args.draws, SAMPLED)
    for line, j in zip(rank_lines(tests), range(len(SAMPLED)), strict=True):
        held = int(inside[:, j].sum())
        print(f"  {line}; 90 % intervals holding the truth {held}/{n} (99 % range {lo:.0f}-{hi:.0f})")
    _where_missed(problem, rows, ranks, inside, args)
    return ranks, tests, np.array([row["converged"] for row in rows])


def _where_missed(problem: str, rows: list[dict], ranks: np.ndarray, inside: np.ndarray, args) -> None:
    """Where the misses lie. Per verdict, the rank tests of that subset (conditioning on the verdict, which depends on
    the data, is not itself a calibration test: it shows where the misses are). And per parameter, how many missed
    intervals had the generating value in its prior's outer 10 %: a posterior no narrower than the prior (a parameter
    the test does not inform) misses exactly those, 10 % of replications in expectation."""
    conv = np.array([row["converged"] for row in rows])
    for label, sel in (("CONVERGED", conv), ("NOT CONVERGED", ~conv)):
        if sel.sum() < 2:
            continue
        print(f"  {label} only ({sel.sum()} fits; conditioned on the verdict, not an SBC by itself):")
        for line, j in zip(rank_lines(rank_tests(ranks[sel], args.draws, SAMPLED)), range(len(SAMPLED)), strict=True):
            print(f"    {line}; intervals holding the truth {int(inside[sel, j].sum())}/{sel.sum()}")
    u = np.array([prior_quantiles(problem, row["r"], args.seed) for row in rows])
    edge = (u < (1 - LEVEL) / 2) | (u > 1 - (1 - LEVEL) / 2)
    for j, name in enumerate(SAMPLED):
        miss = ~inside[:, j]
        print(
            f"  {name}: {int(miss.sum())} missed, {int((miss & edge[:, j]).sum())} of them with the truth in the "
            f"prior's outer {1 - LEVEL:.0%} ({int(edge[:, j].sum())} truths there of {len(rows)}, "
            f"{(1 - LEVEL) * len(rows):.1f} expected); {int((miss & ~conv).sum())} of them NOT CONVERGED"
        )


def _from_logs(args) -> int:
    """Rank tests and figure from the per-replication lines of earlier runs' logs."""
    pattern = re.compile(r"^  (\w+) (\d+): (NOT CONVERGED|CONVERGED), .*ranks \[([\d, ]+)\]")
    found = {}
    for path in args.from_log:
        for line in Path(path).read_text().splitlines():
            m = pattern.match(line)
            if m:
                row = {"r": int(m[2]), "converged": m[3] == "CONVERGED", "ranks": [int(v) for v in m[4].split(",")]}
                found.setdefault(m[1], {})[int(m[2])] = row
    results = {p: _summary(p, list(reps.values()), args) for p, reps in found.items()}
    if args.out and results:
        _figure(results, args)
    return 0


def _figure(results, args) -> None:
    title = (
        "simulation-based calibration of the recommended emcee path (mirror model, "
        f"{args.coordinates or 'creep / ramp'} coordinates, "
        f"mixture moves), L = {args.draws}"
    )
    panels = [(ranks, tests, f"{p}, {len(ranks)} fits") for p, (ranks, tests, _) in results.items()]
    panels += [
        (ranks[conv], rank_tests(ranks[conv], args.draws, SAMPLED), f"{p}, {conv.sum()} CONVERGED only")
        for p, (ranks, _, conv) in results.items()
        if 30 <= conv.sum() < len(conv)  # a subset large enough for its histogram to say something
    ]
    rank_figure(panels, args.draws, SAMPLED, title, args.out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--problems", nargs="+", choices=list(TESTS), default=list(TESTS))
    ap.add_argument("--reps", type=int, default=100)
    ap.add_argument("--start", type=int, default=0, help="first replication's index (its seed): continue a run")
    ap.add_argument("--draws", type=int, default=99, help="posterior draws ranked against (L)")
    ap.add_argument("--max-steps", type=int, default=0, help="step cap per ensemble (0: the example's)")
    ap.add_argument("--ensembles", type=int, default=0, help="ensembles per fit (0: the example's)")
    ap.add_argument(
        "--coordinates", choices=("box", "creep", "ramp"), help="sampler coordinates (default: the example's)"
    )
    ap.add_argument("--seed", type=int, default=2026)
    ap.add_argument("--processes", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--out", help="PNG of the rank histograms")
    ap.add_argument("--from-log", nargs="+", help="logs of earlier runs: their replications' ranks, nothing run")
    args = ap.parse_args(argv)
    if args.from_log:
        return _from_logs(args)
    print(
        f"noise sd {NOISE_SD} mm (known); L = {args.draws}; {args.reps} replications each; "
        f"ensembles {args.ensembles or 'as the example'}, step cap {args.max_steps or 'as the example'}, "
        f"coordinates {args.coordinates or 'as the example'}"
    )
    t0 = time.perf_counter()
    jobs = [(p, r, args) for p in args.problems for r in range(args.start, args.start + args.reps)]
    rows = {p: [] for p in args.problems}
    skipped = dict.fromkeys(args.problems, 0)  # the forward solve failed at the generating values
    with ProcessPoolExecutor(args.processes, mp_context=mp.get_context("fork")) as ex:
        for problem, _r, row in ex.map(_replication, jobs):
            if row is None:
                skipped[problem] += 1
                continue
            rows[problem].append(row)
            verdict = "CONVERGED" if row["converged"] else "NOT CONVERGED"
            print(
                f"  {problem} {_r}: {verdict}, {row['steps']} steps, {row['seconds']:.0f} s, "
                f"ranks {row['ranks'].tolist()} ({time.perf_counter() - t0:.0f} s)",
                flush=True,
            )
    print(f"{time.perf_counter() - t0:.0f} s wall")
    print(f"skipped (forward solve failed at the generating values): {skipped}")
    results = {p: _summary(p, rows[p], args) for p in args.problems}
    if args.out:
        _figure(results, args)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
