"""The identifiability stage's record (:class:`~bayestissue.analyses.records.IdentifiabilityRecord`).

Per calibration (T1, T2, joint): least squares and posterior summaries, the profile reference and restarts, the local
analysis (singular values, collinearity, sloppiest/stiffest directions), the profiles, posterior-vs-prior measures;
the fibre-1 sanity check with its Monte Carlo tolerance and fibre-1 tension at the optima; the mirror-swap symmetry.
"""

from __future__ import annotations

import numpy as np

from bayestissue.analyses.identifiability import (
    FIBRE1_NAMES,
    LABELS,
    MAX_RESTARTS,
    NAMES,
    SALT,
    at_bound,
    distinct,
    fibre1_tension_share,
    profile_interval,
)
from bayestissue.analyses.records import (
    Fibre1Check,
    FitCheck,
    IdentifiabilityRecord,
    LocalAnalysis,
    PosteriorMeasures,
    PosteriorSummary,
    Profile,
    ProfileReference,
)
from bayestissue.identifiability import uninformed_mc
from bayestissue.mechanics import simulate

__all__ = ["identifiability_record"]

_FAMILY1 = [NAMES.index(n) for n in FIBRE1_NAMES]


def _moments(u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Skewness and kurtosis of every column of the scaled-box draws ``u``."""
    z = u - u.mean(0)
    sd = np.maximum(u.std(0), 1e-12)
    return (z**3).mean(0) / sd**3, (z**4).mean(0) / sd**4


def _posterior(c, n_obs: int) -> PosteriorSummary:
    skew, kurt = _moments(c.u)
    return PosteriorSummary(
        ls_x=c.ls_x, ls_chi2=c.ls_chi2, chi2_parts=c.chi2_parts, ls_active=[bool(a) for a in c.ls_active],
        ls_start_chi2=[s[1] for s in c.ls_starts], n_obs=n_obs, median=np.median(c.draws, axis=0),
        q05=np.quantile(c.draws, 0.05, axis=0), q95=np.quantile(c.draws, 0.95, axis=0), rhat=c.rhat,
        acceptance=c.acceptance, n_draws=c.draws.shape[0], n_failed=c.n_failed, n_dropped=c.n_dropped,
        time_mcmc_s=c.time_mcmc_s, results_file=c.results_file, converged=c.converged, convergence=c.convergence,
        fit={k: FitCheck(noise_ratio=v["noise_ratio"], lag1=v["lag1"], coverage=v["coverage"], misfit=v["misfit"])
             for k, v in c.fit.items()},
        tied=dict(c.tied), u_mean=c.u.mean(axis=0), u_sd=c.u.std(axis=0), skew=skew, kurt=kurt,
    )  # fmt: skip


def _reference(c, ps) -> ProfileReference:
    return ProfileReference(
        chi2_calibration=c.ls_chi2, chi2_polished=ps.chi2_start, chi2_final=ps.chi2_min, n_restarts=ps.n_restarts,
        improvements=list(ps.improvements), restart_from=list(ps.restart_from), converged=ps.converged,
        improvement_tol=ps.improvement_tol, max_restarts=MAX_RESTARTS, theta_final=ps.theta_hat,
        theta_calibration=c.ls_x, at_bound_final=at_bound(ps.theta_hat),
        first_classifications={p.name: c0 for p, c0 in zip(ps.profiles, ps.first_classifications, strict=True)},
    )  # fmt: skip


def _local(a) -> LocalAnalysis:
    gam = sorted(a.collinearity, key=lambda t: (len(t[0]), t[1]))
    return LocalAnalysis(
        theta=a.theta, singular_values=a.singular_values, se_log=a.std_error_log, delta_msqr=a.delta_msqr,
        sloppiest=[{n: float(w) for n, w in d.items()} for d in a.sloppiest(3)],
        stiffest=[{n: float(w) for n, w in zip(NAMES, row, strict=True) if abs(w) > 0.1} for row in a.directions[:3]],
        largest_subsets=[(list(s), float(g)) for s, g in a.largest_subsets[:5]],
        pairs=[(list(s), float(g)) for s, g in gam if len(s) == 2],
        n_subsets_ok=int(sum(g < 10 for _, g in a.collinearity)), n_subsets=len(a.collinearity),
        n_informed=int(np.sum(a.singular_values > 1.0)),
    )  # fmt: skip


def _profile(p) -> Profile:
    return Profile(
        name=p.name, classification=p.classification, ci=profile_interval(p.ci), theta_hat=p.theta_hat,
        open=tuple(p.open_sides), improved=p.improved, n_points=int(p.values.size),
        max_delta=float(np.nanmax(p.delta_chi2)), min_delta=float(np.nanmin(p.delta_chi2)),
    )  # fmt: skip


def _measures(pm, c) -> PosteriorMeasures:
    js = distinct(c)
    corr = pm["corr"]
    pairs = sorted(((i, j) for i in js for j in js if i < j), key=lambda ij: -abs(corr[ij]))[:5]
    return PosteriorMeasures(
        contraction=pm["contraction"], kl=pm["kl"], at_lower=pm["flags"]["at_lower"],
        at_upper=pm["flags"]["at_upper"], share_lower=pm["flags"]["share_lower"],
        share_upper=pm["flags"]["share_upper"],
        max_abs_corr=[(NAMES[i], NAMES[j], float(corr[i, j])) for i, j in pairs],
    )  # fmt: skip


def _fibre1(c, contraction, kl, sensitivity, exps, lab, best_x) -> Fibre1Check:
    """The sanity check's tolerance is t_{B-1}(0.995) x the batch-means Monte Carlo error (B = 10 contiguous
    batches), fixed in advance; where fibre 1 never carries tension the likelihood is exactly flat in its
    parameters."""
    mc = uninformed_mc(c.u, prior_var=np.full(len(NAMES), 1 / 12), prior_logpdf=lambda x: np.zeros_like(x),
                       n_bins=30, n_batches=10, level=0.99)  # fmt: skip
    runs = {e.name: simulate(e, best_x, full=True) for e in exps}
    return Fibre1Check(
        contraction=contraction[_FAMILY1], kl=kl[_FAMILY1], sensitivity=sensitivity[_FAMILY1],
        **{k: mc[k][_FAMILY1] for k in ("contraction_corrected", "kl_corrected", "se_contraction", "se_kl",
                                       "tol_contraction", "tol_kl", "uninformed")},
        t=mc["t"], n_batches=mc["n_batches"], n_draws=int(c.u.shape[0]),
        share_draws_fibre1_tension=fibre1_tension_share(c, exps, lab),
        max_E22={k: float(r.strain[0, :, 1].max()) for k, r in runs.items()},
        max_tau1_kpa={k: float(r.tension_kpa[0, :, 0].max()) for k, r in runs.items()},
    )  # fmt: skip


def identifiability_record(args, cal: dict, res: dict, pset: dict, loc: dict, post: dict, figures, timings: dict):
    """The record of one run: calibrations ``cal``, residuals ``res``, profile sets ``pset``, local analyses
    ``loc`` and posterior measures ``post``, each by label; the names of the ``figures`` written; ``timings`` (s)
    by step."""
    e1, e2 = res["joint"].experiments  # the experiments the residuals were built from (T1, T2)
    x = np.asarray(cal["T1"].ls_x, float)
    swapped = x.copy()
    swapped[5:8], swapped[8:11] = x[8:11], x[5:8]
    swap = max(float(np.max(np.abs(simulate(e, x) - simulate(e, swapped)))) for e in (e1, e2))
    return IdentifiabilityRecord(
        mode=args.mode.name,
        names=list(NAMES),
        cache_salt=SALT,
        calibration={lab: _posterior(cal[lab], int(res[lab].sd.size)) for lab in LABELS},
        profile_reference={lab: _reference(cal[lab], pset[lab]) for lab in LABELS},
        local={lab: _local(loc[lab]) for lab in LABELS},
        profiles={lab: [_profile(p) for p in pset[lab].profiles] for lab in LABELS},
        posterior={lab: _measures(post[lab], cal[lab]) for lab in LABELS},
        fibre1={
            lab: _fibre1(
                cal[lab],
                post[lab]["contraction"],
                post[lab]["kl"],
                loc[lab].delta_msqr,
                (e1, e2),
                lab,
                pset[lab].theta_hat,
            )
            for lab in LABELS
        },  # fmt: skip
        swap_symmetry_max_abs_mm=swap,
        figures=list(figures),
        timings_s=timings,
    )
