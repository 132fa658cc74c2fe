"""Diagnostics and verdict of the nested engine (:mod:`bayestissue.inference.sampling.nested`).

For importance-weighted points :math:`x_i` with normalised weights :math:`w_i` (one run), the variance of a
weighted mean :math:`\\hat\\mu = \\sum_i w_i f(x_i)` is estimated by :math:`\\sum_i w_i^2 (f(x_i) - \\hat\\mu)^2`
(delta method for the self-normalised estimator; Owen 2013, *Monte Carlo theory, methods and examples*, ch. 9),
so its effective sample size is

.. math:: n_\\text{eff}[f] = \\frac{\\sum_i w_i (f_i - \\hat\\mu)^2}{\\sum_i w_i^2 (f_i - \\hat\\mu)^2},

:math:`n` for equal weights. Following the rank-normalised diagnostics of Vehtari et al. 2021
(doi:10.1214/20-BA1221):

* **bulk ESS** of a parameter: :math:`n_\\text{eff}` of its normal scores :math:`\\Phi^{-1}(\\hat F_w(x_i))`
  (:math:`\\hat F_w` the weighted empirical CDF at mid-weight);
* **tail ESS**: the smaller :math:`n_\\text{eff}` of the indicators :math:`x \\le q_{0.05}` and :math:`x \\le
  q_{0.95}` (weighted quantiles), i.e. :math:`p(1-p)/\\sum_i w_i^2 (I_i - p)^2`;
* each capped at Kish's :math:`(\\sum w)^2/\\sum w^2`: with degenerate weights (one point carrying nearly all of
  them) the delta-method variance vanishes with the dominant point's deviation and the ratio above explodes
  (measured: 1e125 on a capped 11-parameter run whose Kish ESS was 1);
* both summed over the independent runs;
* **R-hat**: rank-normalised split :math:`\\hat R` with one chain per run, on each run's equal-weight draws
  (:meth:`NestedSample.draws`).

The evidence: the runs' :math:`\\log\\hat Z_k` must agree with their own errors :math:`\\sigma_k`
(:attr:`NestedRun.log_z_err`): :math:`\\chi^2 = \\sum_k (\\log\\hat Z_k - \\overline{\\log Z})^2/\\sigma_k^2` with
:math:`n - 1` degrees of freedom, p-value at least 0.01, and their range below 0.2.

The peak: nested sampling compresses the prior towards the likelihood's peak shell by shell, and a run whose
bounds lose the peak region can end with a consistent-looking but wrong answer. Where the peak is known (the runs'
likelihood climbed from the least-squares optima, :mod:`~bayestissue.inference.sampling.peak`), every run's largest
log-likelihood must come within :math:`d/2` of it (``reference_log_l``; :math:`d` the
number of the problem's parameters, its noise sds included also where the runs integrate them out and draw them
afterwards, which loosens the allowance by half a nat per sd: posterior draws of a :math:`d`-dimensional Gaussian
lie about :math:`d/2` below the peak, the best of thousands much closer).

The quantiles: each run estimates the 5, 50 and 95 % quantiles of every parameter from its weighted points
(:func:`weighted_quantile`) and their Monte Carlo error for itself, by a Poisson bootstrap of its points (each point's
weight multiplied by an independent Poisson(1) count, 200 replicates; Hanley & MacGibbon 2006); an UltraNest run by
its own bootstrap, whose replicate weights redraw the live points' shrinkage too (a classic nested run's error is
largely the shrinkage's, which reweighting points cannot see; Higson et al. 2018). Whether those
errors are right is what independent runs can tell (Higson et al. 2018, doi:10.1093/mnras/sty1185, compare the
run-to-run scatter with the bootstrap's): per parameter and level, :math:`\\chi^2 = \\sum_k (\\hat q_k -
\\bar q)^2/\\sigma_k^2` on :math:`n - 1` degrees of freedom must not fall below :math:`p = 0.01/m` (Bonferroni over
the :math:`m` quantities tested). The merged estimate is the runs' quantiles averaged
(:meth:`NestedReport.quantiles`; not the quantile of the pooled draws, which adds the resampling's noise); it carries
the Monte Carlo error
:math:`\\max(\\sqrt{\\sum_k \\sigma_k^2}/n,\\ s_{\\hat q}/\\sqrt n)` (the runs' own errors, or their scatter if larger),
as :attr:`NestedSample.log_z_err` does for the evidence. Points of one run are not independent draws (nautilus's
shells share their bounds), which is exactly what the comparison checks.

The insertion order (UltraNest runs only: classic nested sampling replaces one point at a time, nautilus draws
whole shells): each new point's rank among the live points must be uniform (Fowlie, Handley & Su 2020,
doi:10.1093/mnras/staa2345); :mod:`~bayestissue.inference.sampling.ultranest_run` states the test and its rule.

Verdict (:func:`assess_nested`): at least 4 runs, each finished (not stopped by an evaluation cap) and reaching the
peak, R-hat < 1.01, bulk and tail ESS >= 400 for every sampled parameter, the evidence consistent as above, the
quantiles' scatter consistent with their errors, and (UltraNest) every run's insertion order uniform.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import ndtri
from scipy.stats import chi2

from bayestissue.inference.diagnostics import ParameterChecks, rhat_ensembles, runs_mean_error

__all__ = ["NestedReport", "assess_nested", "quantile_errors", "weighted_ess", "weighted_quantile"]

#: the quantiles every run estimates with its error; the bootstrap replicates
LEVELS, N_BOOT = (0.05, 0.5, 0.95), 200


def weighted_quantile(x, w, q) -> np.ndarray:
    """Quantiles ``q`` of the weighted sample (``x`` ``(n,)``, ``w`` ``(n,)`` summing to one): the inverse of
    the mid-weight empirical CDF, interpolated."""
    o = np.argsort(x)
    return _sorted_quantile(x[o], w[o], q)


def _sorted_quantile(xs, ws, q) -> np.ndarray:
    """:func:`weighted_quantile` of values already sorted, weights in any scale."""
    return np.interp(q, (np.cumsum(ws) - 0.5 * ws) / np.sum(ws), xs)


def _n_eff(f, w) -> float:
    mu = np.sum(w * f)
    d2 = (f - mu) ** 2
    var_is = np.sum(w**2 * d2)
    return float(np.sum(w * d2) / var_is) if var_is > 0 else float(w.size)


def weighted_ess(x, w) -> tuple[np.ndarray, np.ndarray]:
    """Bulk and tail ESS ``(ndim,)`` each of one run's weighted points ``x`` ``(n, ndim)`` (see the module)."""
    x = np.asarray(x, dtype=float)
    w = np.asarray(w, dtype=float) / np.sum(w)
    kish = 1.0 / np.sum(w**2)
    bulk, tail = np.empty(x.shape[1]), np.empty(x.shape[1])
    for j in range(x.shape[1]):
        o = np.argsort(x[:, j], kind="stable")
        cdf = np.empty_like(w)
        cdf[o] = np.cumsum(w[o]) - 0.5 * w[o]
        bulk[j] = min(_n_eff(ndtri(np.clip(cdf, 1e-12, 1 - 1e-12)), w), kish)
        tail[j] = min(
            kish, *(_n_eff((x[:, j] <= weighted_quantile(x[:, j], w, q)).astype(float), w) for q in (0.05, 0.95))
        )
    return bulk, tail


def quantile_errors(
    x, w, levels=LEVELS, *, n_boot: int = N_BOOT, seed: int = 0, replicates=None
) -> tuple[np.ndarray, np.ndarray]:
    """One run's weighted quantiles ``(ndim, len(levels))`` and their bootstrap standard errors (module
    docstring): every replicate reweights the points by independent Poisson(1) counts, or, with ``replicates``
    ``(n, B)``, the replicate weights given (an UltraNest run's own bootstrap, which redraws the live points'
    shrinkage as well). On the 10-dimensional ridge both gave errors of one size (x1_1's 95 % quantile: 0.0096
    and 0.0091) and UltraNest runs at 20 slice steps scattered 7 times beyond them: a bias of the sampler, which
    only the run-to-run comparison sees."""
    x = np.asarray(x, dtype=float)
    w = np.asarray(w, dtype=float) / np.sum(w)
    if replicates is None:
        rng = np.random.default_rng(seed)
        reps = np.stack([w * rng.poisson(1.0, w.size) for _ in range(n_boot)], axis=1)
    else:
        reps = np.asarray(replicates, dtype=float)
    est, err = np.empty((x.shape[1], len(levels))), np.empty((x.shape[1], len(levels)))
    for j in range(x.shape[1]):
        o = np.argsort(x[:, j], kind="stable")
        xs, ws = x[o, j], w[o]
        est[j] = weighted_quantile(xs, ws, levels)
        boot = np.array([_sorted_quantile(xs, reps[o, b], levels) for b in range(reps.shape[1])])
        err[j] = boot.std(axis=0, ddof=1)
    return est, err


@dataclass(frozen=True)
class NestedReport(ParameterChecks):
    """Diagnostics of a :class:`~bayestissue.inference.sampling.NestedSample`."""

    names: tuple[str, ...]
    rhat: np.ndarray
    ess_bulk: np.ndarray
    ess_tail: np.ndarray
    log_z: np.ndarray  # (n_runs,)
    log_z_err: np.ndarray  # (n_runs,)
    n_like: np.ndarray  # (n_runs,)
    finished: np.ndarray  # (n_runs,) bool
    n_draws: int
    time_s: float
    max_log_l: np.ndarray  # (n_runs,) largest log-likelihood of each run
    q_runs: np.ndarray  # (n_runs, ndim, len(LEVELS)) each run's weighted quantiles
    q_errs: np.ndarray  # (n_runs, ndim, len(LEVELS)) and their bootstrap errors
    reference_log_l: float | None = None
    #: (n_runs,) the insertion-order test of each run and its shortest alarm-free stretch (UltraNest runs only)
    insertion_ok: np.ndarray | None = None
    insertion_run: np.ndarray | None = None
    rhat_max: float = 1.01
    ess_min: float = 400.0
    spread_max: float = 0.2
    p_min: float = 0.01
    min_runs: int = 4

    @property
    def log_z_spread(self) -> float:
        return float(np.ptp(self.log_z))

    @property
    def log_z_p(self) -> float:
        """p-value of the runs' evidence scatter against their own errors (chi-square, n - 1 dof)."""
        if self.log_z.size < 2:
            return float("nan")
        w = 1.0 / self.log_z_err**2
        mean = np.sum(w * self.log_z) / np.sum(w)
        return float(chi2.sf(np.sum(w * (self.log_z - mean) ** 2), self.log_z.size - 1))

    @property
    def evidence_ok(self) -> bool:
        return bool(self.log_z_spread < self.spread_max and self.log_z_p >= self.p_min)

    @property
    def quantile_p(self) -> np.ndarray:
        """``(ndim, len(LEVELS))`` p-values of the runs' quantile scatter against their own errors (chi-square,
        n - 1 dof); NaN with one run."""
        if self.q_runs.shape[0] < 2:
            return np.full(self.q_runs.shape[1:], np.nan)
        w = 1.0 / np.maximum(self.q_errs, 1e-300) ** 2
        mean = np.sum(w * self.q_runs, axis=0) / np.sum(w, axis=0)
        return chi2.sf(np.sum(w * (self.q_runs - mean) ** 2, axis=0), self.q_runs.shape[0] - 1)

    @property
    def quantiles_ok(self) -> bool:
        p = self.quantile_p
        return bool(self.q_runs.shape[0] < 2 or np.all(p >= self.p_min / p.size))

    def quantiles(self, draws=None) -> np.ndarray:
        """``(ndim, len(LEVELS))`` the runs' weighted quantiles averaged over the runs: the estimate whose error
        :attr:`quantile_mc_error` is (not the quantiles of resampled equal-weight ``draws``, which add the
        resampling's noise; ``draws`` are not needed)."""
        return self.q_runs.mean(axis=0)

    def quantile_errors(self, draws=None) -> np.ndarray:
        """:attr:`quantile_mc_error` (the runs' bootstraps; ``draws`` are not needed)."""
        return self.quantile_mc_error

    @property
    def quantile_mc_error(self) -> np.ndarray:
        """``(ndim, len(LEVELS))`` Monte Carlo error of :meth:`quantiles` (module docstring)."""
        return runs_mean_error(self.q_runs, self.q_errs)

    def _quantile_clause(self) -> str:
        """The quantities whose run-to-run scatter exceeds the runs' own errors, worst first (at most three)."""
        p = self.quantile_p
        bad = np.argwhere(p < self.p_min / p.size)
        bad = sorted(bad.tolist(), key=lambda jk: p[jk[0], jk[1]])
        parts = []
        for j, k in bad[:3]:
            scatter = self.q_runs[:, j, k].std(ddof=1)
            own = np.sqrt(np.mean(self.q_errs[:, j, k] ** 2))
            runs = ", ".join(f"{v:.4g}" for v in self.q_runs[:, j, k])
            parts.append(f"{100 * LEVELS[k]:g} % quantile of {self.names[j]} (runs {runs}: scatter {scatter:.2g} vs "
                         f"own errors {own:.2g}, p = {p[j, k]:.1g})")  # fmt: skip
        more = f" and {len(bad) - 3} more" if len(bad) > 3 else ""
        return (f"runs disagree beyond their own Monte Carlo errors (p < {self.p_min:g}/{p.size} needed): "
                + "; ".join(parts) + more)  # fmt: skip

    @property
    def short_of_peak(self) -> np.ndarray:
        """Runs whose largest log-likelihood stays more than d/2 below ``reference_log_l``."""
        if self.reference_log_l is None:
            return np.zeros(self.log_z.size, dtype=bool)
        return self.max_log_l < self.reference_log_l - 0.5 * len(self.names)

    @property
    def converged(self) -> bool:
        return bool(
            self.log_z.size >= self.min_runs
            and np.all(self.finished)
            and not np.any(self.short_of_peak)
            and np.all(self.parameters_ok)
            and self.evidence_ok
            and self.quantiles_ok
            and self.insertion_passed
        )

    @property
    def insertion_passed(self) -> bool:
        """Every run's insertion order uniform (true where the sampler has no such test)."""
        return self.insertion_ok is None or bool(np.all(self.insertion_ok))

    def verdict(self) -> str:
        """Plain-language verdict, one clause per failed criterion."""
        evidence = (
            f"log Z per run {', '.join(f'{z:.2f}' for z in self.log_z)} (range {self.log_z_spread:.3f}, "
            f"own errors {np.sqrt(np.mean(self.log_z_err**2)):.3f}, scatter p = {self.log_z_p:.2g})"
        )
        if self.converged:
            return (
                f"CONVERGED: {self.log_z.size} nested runs, R-hat < {self.rhat_max} (max {np.max(self.rhat):.4f}), "
                f"bulk ESS >= {self.ess_min:g} (min {np.min(self.ess_bulk):.0f}), tail ESS >= {self.ess_min:g} "
                f"(min {np.min(self.ess_tail):.0f}), {evidence}, 5/50/95 % quantiles consistent with their own errors "
                f"(min p = {np.min(self.quantile_p):.2g})"
                + ("" if self.insertion_ok is None else ", insertion order uniform in every run")
            )
        lines = []
        if self.log_z.size < self.min_runs:
            lines.append(f"{self.log_z.size} run(s), at least {self.min_runs} needed")
        if not np.all(self.finished):
            lines.append(f"runs {np.flatnonzero(~self.finished).tolist()} stopped at the evaluation cap")
        if np.any(self.short_of_peak):
            lines.append(
                f"runs {np.flatnonzero(self.short_of_peak).tolist()} never came within d/2 = {0.5 * len(self.names):g} "
                f"of the likelihood's peak climbed from the least-squares optima {self.reference_log_l:.1f} (best "
                f"{', '.join(f'{v:.1f}' for v in self.max_log_l)}): they missed the peak"
            )
        bad = [n for n, r in zip(self.names, self.rhat, strict=True) if not r < self.rhat_max]
        if bad and self.log_z.size >= 2:  # one run has no R-hat (said above)
            lines.append(f"R-hat >= {self.rhat_max} for {bad} (max {np.nanmax(self.rhat):.3f})")
        for label, ess in (("bulk", self.ess_bulk), ("tail", self.ess_tail)):
            bad = [n for n, e in zip(self.names, ess, strict=True) if not e >= self.ess_min]
            if bad:
                lines.append(f"{label} ESS < {self.ess_min:g} for {bad} (min {np.min(ess):.0f})")
        if not self.insertion_passed:
            bad = np.flatnonzero(~self.insertion_ok)
            lines.append(
                f"insertion-order test failed in runs {bad.tolist()} (4-sigma alarm after "
                f"{', '.join(f'{v:.0f}' for v in self.insertion_run[bad])} iterations): new points are not fair draws "
                "inside their contour; more slice_steps"
            )
        if not self.quantiles_ok:
            lines.append(self._quantile_clause())
        if not self.evidence_ok:
            lines.append(
                f"evidence not consistent across runs (range < {self.spread_max:g} and p >= {self.p_min:g} "
                f"needed): {evidence}"
            )
        return "NOT CONVERGED: " + "; ".join(lines)


def assess_nested(
    sample, *, reference_log_l: float | None = None, rhat_max: float = 1.01, ess_min: float = 400.0
) -> NestedReport:
    """Diagnostics and verdict of a :class:`~bayestissue.inference.sampling.NestedSample`; ``reference_log_l`` the
    log-likelihood at a known optimum (e.g. least squares with the plug-in noise), checked against every run's best."""
    draws = sample.draws()
    ndim = draws.shape[-1]
    with np.errstate(invalid="ignore", divide="ignore"):  # runs collapsed onto one point: NaN, i.e. not < 1.01
        rhat = rhat_ensembles(draws[:, :, None, :]) if draws.shape[0] >= 2 else np.full(ndim, np.nan)
    bulk, tail, q_runs, q_errs = np.zeros(ndim), np.zeros(ndim), [], []
    for k, r in enumerate(sample.runs):
        pts = sample.problem.canonical(r.points)
        b, t = weighted_ess(pts, r.weights)
        bulk += b
        tail += t
        q, e = quantile_errors(pts, r.weights, seed=k, replicates=r.bootstrap_weights)
        q_runs.append(q)
        q_errs.append(e)
    insertion = sample.insertion_tests()
    return NestedReport(
        names=tuple(sample.names),
        rhat=rhat,
        ess_bulk=bulk,
        ess_tail=tail,
        log_z=np.array([r.log_z for r in sample.runs]),
        log_z_err=np.array([r.log_z_err for r in sample.runs]),
        n_like=np.array([r.n_like for r in sample.runs]),
        finished=np.array([r.finished for r in sample.runs]),
        n_draws=int(draws.shape[0] * draws.shape[1]),
        time_s=float(sample.time_s),
        max_log_l=np.array([np.max(r.log_l) for r in sample.runs]),
        q_runs=np.array(q_runs),
        q_errs=np.array(q_errs),
        reference_log_l=None if reference_log_l is None else float(reference_log_l),
        insertion_ok=None if insertion is None else insertion[0],
        insertion_run=None if insertion is None else insertion[1],
        rhat_max=rhat_max,
        ess_min=ess_min,
    )
