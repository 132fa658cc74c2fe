"""Simulation-based calibration of the nested engine through the real forward model (issue 18, part 2 (d)).

Talts et al. 2018 (arXiv:1804.06788): draw generating values from the prior, simulate data with noise, sample the
posterior, and record the rank of each generating value among ``L`` posterior draws. If the engine samples the
posterior correctly, every parameter's ranks are uniform on ``0..L``.

The problem: the first ``--n-obs`` observation times of the T1 creep test (its specimen, stress and time step), the
mirror model's fibre law (family 3 tied to family 2) with ``mu``, ``ginf2``, ``beta2`` sampled on log-uniform boxes
narrower than Table 1's (so that every prior draw is a well-posed creep curve; the boxes are printed), every other
parameter at Table 1's T1 value, known noise sd. One nested run per replication (``--live`` live points,
``--neff`` importance ESS, one network per bound; or with ``--sampler ultranest`` UltraNest's classic nested
sampling with its population slice sampler, ``--neff`` its minimum ESS); replications in parallel processes.

Printed (``sbc_ranks.py``): per parameter a chi-square test of the ranks in 10 bins (9 dof) and a KS test of the
randomised fractional ranks, with p-values; the rank histograms go to ``--out`` (PNG) when given. No pass/fail: read
the p-values (with three parameters, one p below 0.01 by chance has probability about 3 %).

    python benchmarks/sbc_nested.py [--sampler nautilus|ultranest] [--reps 100] [--n-obs 60] [--draws 99] [--live 200]
        [--neff 400] [--out sbc.png] [--log sbc.jsonl]
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import multiprocessing as mp
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from sbc_ranks import rank_figure, rank_lines, rank_tests  # noqa: E402

from bayestissue.inference import NestedOptions, sample_nested  # noqa: E402
from bayestissue.mechanics import load_experiment, simulate  # noqa: E402
from bayestissue.paper import MIRROR_TIES, PAPER_PARAMETERS  # noqa: E402
from bayestissue.workflows import CalibrationConfig, build_problem  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
SAMPLED = {"mu": (0.5, 5.0), "ginf2": (5.0, 50.0), "beta2": (2e-3, 5e-2)}
NOISE_SD = 0.01
NAMES = ("mu", "kappa", "ginf1", "gamma1", "beta1", "ginf2", "gamma2", "beta2", "ginf3", "gamma3", "beta3")


def _replication(r, args):
    rng = np.random.default_rng([args.seed, r])
    exp = load_experiment(ROOT / "data" / "T1.toml")
    exp = dataclasses.replace(exp, time_s=exp.time_s[: args.n_obs], displacement_mm=None, force_mN=None)
    truth = dict(zip(NAMES, PAPER_PARAMETERS["T1"], strict=True))
    for name, (lo, hi) in SAMPLED.items():
        truth[name] = float(np.exp(rng.uniform(np.log(lo), np.log(hi))))
    for follower, leader in MIRROR_TIES:
        truth[follower] = truth[leader]
    clean = np.atleast_2d(simulate(exp, np.array([truth[n] for n in NAMES])))[0]
    if not np.all(np.isfinite(clean)):
        return r, None, 0.0
    data = clean + NOISE_SD * rng.standard_normal(clean.size)
    exp = dataclasses.replace(exp, displacement_mm=data)
    config = CalibrationConfig(
        sampled=list(SAMPLED),
        tied=dict(MIRROR_TIES),
        bounds={n: list(b) for n, b in SAMPLED.items()},
        initial={n: truth[n] for n in NAMES if n not in dict(MIRROR_TIES)},
        noise_options={"sd": NOISE_SD},
    )
    problem = build_problem([exp], config)
    t0 = time.perf_counter()
    opts = NestedOptions(n_live=args.live, n_eff=args.neff, n_runs=1, n_networks=1, n_processes=1, sampler=args.sampler)
    sample = sample_nested(problem, options=opts, rng=int(rng.integers(2**31 - 1)))
    draws = sample.flat()
    keep = draws[np.linspace(0, draws.shape[0] - 1, args.draws).astype(int)]
    ranks = np.array([np.sum(keep[:, j] < truth[n]) for j, n in enumerate(problem.names)])
    return r, ranks, time.perf_counter() - t0


def _settings(args) -> dict:
    """What a replication's ranks depend on (a log written under other settings is not reused)."""
    return {k: getattr(args, k) for k in ("sampler", "n_obs", "draws", "live", "neff", "seed")}


def _logged(args) -> dict:
    """Replication -> (ranks or None, seconds) from ``args.log`` (lines of other settings refused)."""
    done = {}
    if args.log is None or not args.log.is_file():
        return done
    for k, line in enumerate(args.log.read_text().splitlines(), 1):
        row = json.loads(line)
        if row["settings"] != _settings(args):
            raise SystemExit(f"{args.log} line {k}: settings {row['settings']}, expected {_settings(args)}")
        if row["rep"] < args.reps:
            done[row["rep"]] = (None if row["ranks"] is None else np.array(row["ranks"]), row["seconds"])
    return done


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sampler", choices=("nautilus", "ultranest"), default="nautilus")
    ap.add_argument("--reps", type=int, default=100)
    ap.add_argument("--n-obs", type=int, default=60, help="first observations of T1 kept (3 s apart)")
    ap.add_argument("--draws", type=int, default=99, help="posterior draws ranked against (L)")
    ap.add_argument("--live", type=int, default=200)
    ap.add_argument("--neff", type=int, default=400)
    ap.add_argument("--seed", type=int, default=2026)
    ap.add_argument("--processes", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--out", help="PNG of the rank histograms")
    ap.add_argument("--log", type=Path, help="JSON lines, one per finished replication; a rerun with the same settings "
                    "skips the replications it holds (a long run can be stopped and resumed)")  # fmt: skip
    args = ap.parse_args(argv)
    print(
        f"{args.sampler}, {args.live} live points; boxes (log-uniform): {SAMPLED}; noise sd {NOISE_SD} mm; "
        f"{args.n_obs} observations; L = {args.draws}"
    )
    t0 = time.perf_counter()
    done = _logged(args)
    todo = [r for r in range(args.reps) if r not in done]
    if done:
        print(f"{len(done)} replications read from {args.log}, {len(todo)} to run")
    ctx = mp.get_context("fork")
    with ProcessPoolExecutor(args.processes, mp_context=ctx) as ex:
        for r, rk, dt in ex.map(_replication, todo, [args] * len(todo)):
            done[r] = (rk, dt)
            if args.log:
                with args.log.open("a") as f:
                    f.write(json.dumps({"settings": _settings(args), "rep": r, "ranks": None if rk is None else
                                        rk.tolist(), "seconds": dt}) + "\n")  # fmt: skip
            if len(done) % 10 == 0:
                print(f"  {len(done)} replications, {time.perf_counter() - t0:.0f} s", flush=True)
    kept = [done[r] for r in range(args.reps) if done[r][0] is not None]
    skipped = args.reps - len(kept)
    ranks = np.array([rk for rk, _ in kept])
    times = [dt for _, dt in kept]
    n = ranks.shape[0]
    print(
        f"{n} replications ({skipped} skipped: forward solve failed at the generating values), "
        f"{time.perf_counter() - t0:.0f} s wall, {np.median(times):.1f} s median per nested run"
    )
    tests = rank_tests(ranks, args.draws, list(SAMPLED))
    for line in rank_lines(tests):
        print(line)
    # the truth inside the central 90 % of the L draws: between the 5 % and 95 % order statistics
    lo, hi = int(np.ceil(0.05 * args.draws)), int(np.floor(0.95 * args.draws))
    inside = ((ranks >= lo) & (ranks <= hi)).sum(axis=0)
    print("90 % intervals holding the generating value: " + ", ".join(
        f"{name} {k} of {n}" for name, k in zip(SAMPLED, inside, strict=True)))  # fmt: skip
    if args.out:
        title = f"simulation-based calibration of the nested engine ({args.sampler}), {n} replications (short T1 creep)"
        rank_figure([(ranks, tests, f"{n} runs")], args.draws, list(SAMPLED), title, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
