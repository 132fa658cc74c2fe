"""The hybrid Rosenbrock target of benchmarks/rosenbrock_evidence.py: its exact evidence against quadrature of the
calibration problem's own likelihood, and a small nested run against that evidence and the exact quantiles (the
10-dimensional run is the benchmark's)."""

import sys
from pathlib import Path

import numpy as np

from bayestissue.inference import NestedOptions, assess_nested, sample_nested
from bayestissue.inference.evidence import LEVELS, weighted_quantile

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
from benchmarks.rosenbrock_evidence import Rosenbrock, rosenbrock_problem  # noqa: E402


def test_exact_evidence_is_the_quadrature_of_the_problems_likelihood():
    """Three dimensions (x1 and a chain of two links), a box that cuts the ridge (<= 1.2 removes a third of the mass):
    the box integral of exp(problem.log_likelihood) by tensor Gauss-Legendre quadrature (160 nodes a side; 200
    nodes change log Z by 3e-14), minus log vol, against the closed form C P(box) / vol(B) with P(box) from
    2e6 exact draws, within 3 of the latter's Monte Carlo errors (5e-4; measured 0.9)."""
    t = Rosenbrock(blocks=1, depth=2, lower=-0.5, upper=1.2)
    problem = rosenbrock_problem(t)
    truth = t.truth(2_000_000)
    u, wq = np.polynomial.legendre.leggauss(160)
    x = 0.5 * (t.upper - t.lower) * (u + 1.0) + t.lower
    wq = 0.5 * (t.upper - t.lower) * wq
    total = 0.0
    for i, x1 in enumerate(x):  # one slab of x1 at a time: 160^2 likelihood calls per batch
        g2, g3 = np.meshgrid(x, x, indexing="ij")
        pts = np.column_stack([np.full(g2.size, x1), g2.ravel(), g3.ravel()])
        ll = problem.log_likelihood(pts).reshape(g2.shape)
        total += wq[i] * np.sum(np.exp(ll) * wq[:, None] * wq[None, :])
    log_z = np.log(total) - t.n * np.log(t.upper - t.lower)
    assert 0.5 < truth["p_box"] < 0.8, truth["p_box"]
    assert abs(log_z - truth["log_z"]) < 3 * truth["log_z_err"], (log_z, truth["log_z"], truth["log_z_err"])


def test_nested_runs_on_a_small_ridge_match_the_exact_answer():
    """Three dimensions (one chain of two links), 2 runs of 300 live points: log Z within 4 of its error of the
    exact value, every pooled 5/50/95 % quantile within 4 of its Monte Carlo error of the exact one."""
    t = Rosenbrock(blocks=1, depth=2)
    truth = t.truth(1_000_000)
    sample = sample_nested(rosenbrock_problem(t), options=NestedOptions(n_live=300, n_eff=800, n_runs=2,
                                                                         n_networks=1), rng=2)  # fmt: skip
    report = assess_nested(sample)
    assert abs(sample.log_z - truth["log_z"]) < 4 * sample.log_z_err
    pts, w, _ = sample.weighted()
    pooled = np.array([weighted_quantile(pts[:, j], w, LEVELS) for j in range(t.n)])
    assert np.all(np.abs(pooled - truth["quantiles"]) < 4 * report.quantile_mc_error), (pooled, truth["quantiles"])
