"""Coverage of the two-stage hierarchical model (issue 35) over simulated group studies, through the real forward
model.

Each replication draws two groups of 3-6 specimens (sizes drawn) from the known population of
``studies/make_tendon_groups.py`` (ln k1_1 ~ N(ln 5e4 + d, 0.15^2), ln beta1 ~ N(ln 0.1, 0.2^2), tendon relaxation
with an HGO fibre and one Prony branch, noise 5 mN), simulates each specimen's test, calibrates each specimen alone
(stage 1: ``run_calibration`` with emcee, 600 steps per ensemble, about 45 autocorrelation times) and samples the
population (stage 2). It counts how often the 90 % intervals of the group effects d (k1_1, beta1) and of the
population sds s contain the generating values. Positive control: d(k1_1) = ln 0.6, d(beta1) = 0; negative control:
no effect at all (the intervals of d must cover 0 at the nominal rate). Prints each count with its binomial central
95 % range under nominal coverage and writes the figure ``docs/hierarchy_coverage.png`` with ``--figure``.

    OPENBLAS_NUM_THREADS=1 python benchmarks/coverage_hierarchy.py [--reps 20] [--seed 1] [--sizes 3-6] [--figure]

About 40 s per replication on this 2-core machine (8-9 specimens); ``--reps 2`` is the smoke run.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402
from scipy import stats  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from bayestissue.inference.hierarchy import sample_population  # noqa: E402
from bayestissue.mechanics import load_experiment  # noqa: E402
from bayestissue.workflows import load_config, run_calibration  # noqa: E402
from studies.make_tendon_groups import POPULATION, draw_truths, write_specimen  # noqa: E402

PARAMS = ("k1_1", "beta1")
STAGE1 = {"n_starts": 2, "sampler": {"max_steps": 600, "check_every": 100, "prune_rounds": 1, "prune_steps": 50,
                                     "adapt_rounds": 1, "adapt_steps": 100}}  # fmt: skip


def one_replication(rng, effect: dict, config, work: Path, size_range=(3, 6)) -> dict:
    """One simulated study: returns, per quantity, (lower, upper, truth) of its 90 % interval."""
    sizes = rng.integers(size_range[0], size_range[1] + 1, size=2)
    groups = ["fresh"] * int(sizes[0]) + ["incubated"] * int(sizes[1])
    truths = draw_truths(rng, groups, POPULATION, {"incubated": effect})
    draws = []
    for k, (g, t) in enumerate(zip(groups, truths, strict=True)):
        path = work / f"s{k}.toml"
        write_specimen(path, f"s{k}", g, t, int(rng.integers(2**31)))
        outcome = run_calibration([load_experiment(path)], config)
        post = outcome.idata.posterior
        draws.append(np.column_stack([post[n].values.reshape(-1) for n in PARAMS]))
    specs = [outcome.problem.material.sampled[outcome.problem.material.sampled_names.index(n)] for n in PARAMS]
    pop = sample_population(draws, specs, groups, reference="fresh", n_chains=4, n_warmup=1000, n_draws=2000,
                            seed=int(rng.integers(2**31)))  # fmt: skip
    out = {}
    for j, n in enumerate(PARAMS):
        d, s = pop.flat("d")[:, 0, j], pop.flat("s")[:, j]
        out[f"d[{n}]"] = (*np.quantile(d, [0.05, 0.95]), effect.get(n, 0.0))
        out[f"s[{n}]"] = (*np.quantile(s, [0.05, 0.95]), POPULATION[n][1])
    out["sizes"] = tuple(int(x) for x in sizes)
    return out


def binomial_range(n: int, p: float = 0.9) -> tuple[int, int]:
    return int(stats.binom.ppf(0.025, n, p)), int(stats.binom.ppf(0.975, n, p))


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reps", type=int, default=20, help="replications per control")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--stage1-steps", type=int, default=600, help="emcee steps per ensemble of each stage-1 fit")
    ap.add_argument("--sizes", default="3-6", help="range of specimens per group, LO-HI (or one number)")
    ap.add_argument("--figure", action="store_true", help="write docs/hierarchy_coverage.png")
    args = ap.parse_args(argv)
    first, _, last = args.sizes.partition("-")
    size_range = (int(first), int(last or first))
    stage1 = {**STAGE1, "sampler": {**STAGE1["sampler"], "max_steps": args.stage1_steps}}
    config = load_config(ROOT / "data" / "synthetic" / "tendon_groups" / "fit.toml", **stage1)
    controls = {"positive (d k1_1 = ln 0.6)": {"k1_1": math.log(0.6)}, "negative (no effect)": {}}
    results = {}
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        for c, (label, effect) in enumerate(controls.items()):
            rng = np.random.default_rng([args.seed, c])
            rows = []
            for r in range(args.reps):
                rows.append(one_replication(rng, effect, config, Path(tmp), size_range))
                print(f"{label}: replication {r + 1}/{args.reps} done ({time.perf_counter() - t0:.0f} s)", flush=True)
            results[label] = rows
    lo, hi = binomial_range(args.reps)
    print(f"\n90 % intervals covering the generating value, of {args.reps} replications (nominal 90 %: central 95 % "
          f"binomial range {lo}-{hi}); groups of {args.sizes} specimens")  # fmt: skip
    summary = {}
    for label, rows in results.items():
        for q in [k for k in rows[0] if k != "sizes"]:
            hits = sum(r[q][0] <= r[q][2] <= r[q][1] for r in rows)
            summary[(label, q)] = hits
            flag = "" if lo <= hits <= hi else "  <- outside the binomial range"
            print(f"  {label:28s} {q:10s} {hits}/{args.reps}{flag}")
    print(f"total {time.perf_counter() - t0:.0f} s")
    if args.figure:
        _figure(results, ROOT / "docs" / "hierarchy_coverage.png")
    return {"summary": summary, "results": results}


def _figure(results, path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    labels = list(results)
    qs = [k for k in results[labels[0]][0] if k != "sizes"]
    fig, axes = plt.subplots(len(labels), len(qs), figsize=(3.2 * len(qs), 2.8 * len(labels)), squeeze=False)
    for a, label in enumerate(labels):
        rows = results[label]
        for b, q in enumerate(qs):
            ax = axes[a, b]
            for r, row in enumerate(rows):
                lo_, hi_, truth = row[q]
                hit = lo_ <= truth <= hi_
                ax.plot([lo_, hi_], [r, r], color="tab:blue" if hit else "tab:red", lw=2)
            ax.axvline(rows[0][q][2], color="tab:green", ls="--", lw=1.5)
            n_hit = sum(row[q][0] <= row[q][2] <= row[q][1] for row in rows)
            ax.set_title(f"{q}: {n_hit}/{len(rows)} cover\n{label}", fontsize=9)
            ax.set_yticks([])
            ax.tick_params(labelsize=8)
    axes[-1, 0].set_ylabel("replication")
    fig.suptitle("90 % intervals of the two-stage model (red: misses the generating value, dashed)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    main()
