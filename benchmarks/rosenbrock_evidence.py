"""The nested engine on a twisted 10-dimensional ridge whose evidence and quantiles are known exactly.

The target is a hybrid Rosenbrock density (Pagani, Wiegand & Nadarajah 2022, Scand. J. Stat. 49:657,
doi:10.1111/sjos.12532): one root coordinate x_1 and ``blocks`` chains of ``depth`` coordinates hanging from it,

    log pi(x) = - (x_1 - mu)^2 / (2 s_1^2) - sum_j sum_i (x_{j,i} - x_{j,i-1}^2)^2 / (2 s^2),   x_{j,0} = x_1,

written as a calibration problem of the package: two experiments with known Gaussian noise, one observing x_1 = mu
twice (sd s_1 sqrt 2 each: an experiment needs two observations), one observing every link x_{j,i} - x_{j,i-1}^2 = 0
(sd s). Their likelihood is L(x) = C pi(x) with pi a normalised density on R^n (each coordinate given its parent is
Gaussian) and C = 1 / (2 sqrt(2 pi) s_1) (the two root observations' Gaussian constants, 1 / (4 pi s_1^2), times the
root's integral sqrt(2 pi) s_1), so with uniform priors on a box B

    Z = C P_pi(x in B) / vol(B),

and pi can be sampled exactly (x_1, then each chain link by link): P_pi(B) and every quantile of the box-truncated
posterior come from 2 million exact draws (their own Monte Carlo errors are printed and are far below the engine's).
Each coordinate's quantiles of the curved, heavy-tailed ridge (x_{j,3} ~ x_1^8) test the engine where a Gaussian
cannot. The runs go through ``sample_nested`` and ``assess_nested`` exactly as a calibration's do.

    OPENBLAS_NUM_THREADS=1 python benchmarks/rosenbrock_evidence.py [--n-live 1000] [--runs 4] [--figure PNG]
        [--sampler ultranest [--slice-steps S] [--population P]]
"""

from __future__ import annotations

import argparse
import os
import time
from dataclasses import dataclass

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from bayestissue.inference import (  # noqa: E402
    CalibrationProblem,
    ExperimentTerm,
    GaussianNoise,
    NestedOptions,
    ParameterSet,
    ParameterSpec,
    assess_nested,
    sample_nested,
)
from bayestissue.inference.evidence import LEVELS  # noqa: E402
from bayestissue.inference.sampling.nested import SAMPLERS, SLICE_DIRECTIONS  # noqa: E402


@dataclass(frozen=True)
class Rosenbrock:
    """The hybrid Rosenbrock target (module docstring) and its box ``[lower, upper]`` in every coordinate."""

    blocks: int = 3
    depth: int = 3
    mu: float = 1.0
    sd_root: float = 0.1
    sd_link: float = 0.1
    lower: float = -2.0
    upper: float = 12.0

    @property
    def n(self) -> int:
        return 1 + self.blocks * self.depth

    def names(self) -> list[str]:
        return ["x1"] + [f"x{j + 1}_{i + 1}" for j in range(self.blocks) for i in range(self.depth)]

    def parents(self) -> np.ndarray:
        """Index of each link's parent, in the order of the links (coordinates 1 .. n - 1)."""
        out = []
        for j in range(self.blocks):
            for i in range(self.depth):
                out.append(0 if i == 0 else 1 + j * self.depth + i - 1)
        return np.array(out)

    def draw(self, m: int, rng) -> np.ndarray:
        """``m`` exact draws of pi on R^n (not truncated)."""
        x = np.empty((m, self.n))
        x[:, 0] = self.mu + self.sd_root * rng.standard_normal(m)
        for k, p in enumerate(self.parents(), start=1):
            x[:, k] = x[:, p] ** 2 + self.sd_link * rng.standard_normal(m)
        return x

    def truth(self, m: int = 2_000_000, seed: int = 7) -> dict:
        """Exact log Z (with the Monte Carlo error of P(B)) and the truncated posterior's quantiles."""
        x = self.draw(m, np.random.default_rng(seed))
        inside = np.all((x >= self.lower) & (x <= self.upper), axis=1)
        p = inside.mean()
        log_vol = self.n * np.log(self.upper - self.lower)
        log_c = -np.log(2.0 * np.sqrt(2.0 * np.pi) * self.sd_root)
        return {"log_z": float(log_c + np.log(p) - log_vol), "log_z_err": float(np.sqrt((1 - p) / (p * m))),
                "p_box": float(p), "quantiles": np.quantile(x[inside], LEVELS, axis=0).T}  # fmt: skip


class _Root:
    def __call__(self, params):
        return np.repeat(np.atleast_2d(np.asarray(params, dtype=float))[:, :1], 2, axis=1)


@dataclass(frozen=True)
class _Links:
    parents: tuple

    def __call__(self, params):
        p = np.atleast_2d(np.asarray(params, dtype=float))
        return p[:, 1:] - p[:, list(self.parents)] ** 2


def rosenbrock_problem(target: Rosenbrock) -> CalibrationProblem:
    """The target as a calibration problem: uniform box priors, two experiments with known noise sds."""
    specs = tuple(ParameterSpec(n, "1", target.lower, target.upper, prior="uniform", value=1.0) for n in target.names())
    root = ExperimentTerm("root", np.arange(2.0), np.full(2, target.mu), _Root(),
                          GaussianNoise(sd=target.sd_root * np.sqrt(2.0)))  # fmt: skip
    n_links = target.n - 1
    links = ExperimentTerm("links", np.arange(float(n_links)), np.zeros(n_links), _Links(tuple(target.parents())),
                           GaussianNoise(sd=target.sd_link))  # fmt: skip
    return CalibrationProblem([root, links], ParameterSet(specs, {"model": "hybrid Rosenbrock (benchmark)"}))


def _figure(path, target, truth, sample, report, merged):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(14, 4.2))
    exact = target.draw(20000, np.random.default_rng(1))
    pts, w, _ = sample.weighted()
    rng = np.random.default_rng(2)
    pick = rng.choice(w.size, 4000, p=w)
    j = 1 + target.depth - 1  # the deepest link of the first chain
    axes[0].plot(exact[:, 0], exact[:, j], ".", ms=1.5, alpha=0.3, color="0.5", label="exact draws")
    axes[0].plot(pts[pick, 0], pts[pick, j], ".", ms=1.5, alpha=0.4, color="C0", label="nested (resampled)")
    axes[0].set(xlabel="x1", ylabel=target.names()[j], title=f"the ridge: x1 against {target.names()[j]}")
    axes[0].legend(markerscale=6, fontsize=8)
    runs = report.log_z
    axes[1].errorbar(np.arange(runs.size), runs, yerr=report.log_z_err, fmt="o", capsize=3, label="each run")
    axes[1].axhline(truth["log_z"], color="k", lw=1, label="exact")
    axes[1].axhspan(sample.log_z - sample.log_z_err, sample.log_z + sample.log_z_err, color="C0", alpha=0.2,
                    label="pooled +- its error")  # fmt: skip
    axes[1].set_xticks(np.arange(runs.size))
    axes[1].set(xlabel="run", ylabel="log Z", title="evidence")
    axes[1].legend(fontsize=8)
    z = (merged - truth["quantiles"]) / report.quantile_mc_error
    for k, lv in enumerate(LEVELS):
        axes[2].plot(np.arange(target.n) + (k - 1) * 0.2, z[:, k], "o", label=f"{100 * lv:g} % quantile")
    axes[2].axhspan(-2, 2, color="0.9")
    axes[2].axhline(0, color="k", lw=0.8)
    axes[2].set_xticks(np.arange(target.n), target.names(), rotation=60, fontsize=8)
    axes[2].set(ylabel="(merged - exact) / its MC error", title="quantiles against the exact ones")
    axes[2].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n-live", type=int, default=1000)
    ap.add_argument("--n-eff", type=int, default=2000)
    ap.add_argument("--runs", type=int, default=4)
    ap.add_argument("--networks", type=int, default=1)
    ap.add_argument("--blocks", type=int, default=3)
    ap.add_argument("--depth", type=int, default=3)
    ap.add_argument("--exact-draws", type=int, default=2_000_000)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--figure", help="write the figure here (PNG)")
    ap.add_argument("--sampler", choices=SAMPLERS, default="nautilus", help="the nested engine's sampler")
    ap.add_argument("--slice-steps", type=int, help="UltraNest's slice steps per new point (default 2 per dimension)")
    ap.add_argument("--directions", choices=SLICE_DIRECTIONS, default="region", help="UltraNest's slice directions")
    ap.add_argument(
        "--population",
        type=int,
        default=NestedOptions.population,
        help="UltraNest's chains advanced together (batch size)",
    )
    args = ap.parse_args(argv)
    target = Rosenbrock(blocks=args.blocks, depth=args.depth)
    truth = target.truth(args.exact_draws)
    print(f"hybrid Rosenbrock, {target.n} dimensions ({target.blocks} chains of {target.depth} under x1), sds "
          f"{target.sd_root} / {target.sd_link}, box [{target.lower}, {target.upper}]^{target.n}")  # fmt: skip
    print(f"exact: log Z = {truth['log_z']:.4f} +- {truth['log_z_err']:.4f} (P(box) = {truth['p_box']:.5f} from "
          f"{args.exact_draws} exact draws)")  # fmt: skip
    problem = rosenbrock_problem(target)
    opts = NestedOptions(n_live=args.n_live, n_eff=args.n_eff, n_runs=args.runs, n_networks=args.networks,
                         sampler=args.sampler, slice_steps=args.slice_steps, directions=args.directions,
                         population=args.population)  # fmt: skip
    print(
        f"{args.sampler}: {args.runs} runs of {args.n_live} live points"
        + (f", {args.directions} directions, population {args.population}" if args.sampler == "ultranest" else "")
    )
    t0 = time.perf_counter()
    sample = sample_nested(problem, options=opts, rng=args.seed)
    wall = time.perf_counter() - t0
    report = assess_nested(sample)
    print("| run | log Z | own error | (log Z - exact) / error | likelihood calls | s | insertion test |")
    print("|---|---|---|---|---|---|---|")
    for k, r in enumerate(sample.runs):
        order = "-" if r.insertion_ok is None else f"{'pass' if r.insertion_ok else 'FAIL'} ({r.insertion_run:.0f})"
        print(f"| {k} | {r.log_z:.4f} | {r.log_z_err:.4f} | {(r.log_z - truth['log_z']) / r.log_z_err:+.2f} | "
              f"{r.n_like} | {r.time_s:.0f} | {order} |")  # fmt: skip
    dz = (sample.log_z - truth["log_z"]) / sample.log_z_err
    print(f"pooled: log Z = {sample.log_z:.4f} +- {sample.log_z_err:.4f}, exact {truth['log_z']:.4f}: "
          f"{dz:+.2f} errors; {wall:.0f} s wall for {args.runs} runs")  # fmt: skip
    # the merged quantiles (the runs' weighted quantiles averaged) are the estimate whose Monte Carlo error the
    # report gives and the verdict judges; the pooled draws' quantiles would mix that error with another estimator
    merged = report.quantiles()
    z = (merged - truth["quantiles"]) / report.quantile_mc_error
    worst = np.unravel_index(np.argmax(np.abs(z)), z.shape)
    print(f"quantiles: {np.sum(np.abs(z) <= 2)} of {z.size} within 2 of their MC errors of the exact ones, "
          f"{np.sum(np.abs(z) <= 3)} within 3; worst {target.names()[worst[0]]} at {100 * LEVELS[worst[1]]:g} %: "
          f"{z[worst]:+.2f} (merged {merged[worst]:.4g}, exact {truth['quantiles'][worst]:.4g})")  # fmt: skip
    print(f"verdict: {report.verdict()}")
    if args.figure:
        _figure(args.figure, target, truth, sample, report, merged)
        print(f"wrote {args.figure}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
