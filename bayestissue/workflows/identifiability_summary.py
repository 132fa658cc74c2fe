"""The identifiability study's summary (``identifiability_summary.json``): every number REPORT.md section 1 reads.

Per calibration (T1, T2, joint): least squares and posterior summaries, the profile reference and restarts, the local
analysis (singular values, collinearity, sloppiest/stiffest directions), the profiles, posterior-vs-prior measures;
the fibre-1 sanity check with its Monte Carlo tolerance; fibre-1 tension at the optima; the mirror-swap symmetry.
"""

from __future__ import annotations

import numpy as np

from bayestissue.identifiability import uninformed_mc
from bayestissue.mechanics import simulate
from bayestissue.workflows.identifiability import (
    LABELS,
    MAX_RESTARTS,
    NAMES,
    SALT,
    at_bound,
    distinct,
    fibre1_tension_share,
)

__all__ = ["identifiability_summary"]


def identifiability_summary(args, cal: dict, res: dict, pset: dict, loc: dict, post: dict) -> dict:
    """The summary of one run: calibrations ``cal``, residuals ``res``, profile sets ``pset``, local analyses
    ``loc`` and posterior measures ``post``, each by label (JSON-ready after :func:`~.identifiability.json_safe`)."""
    prof = {lab: list(pset[lab].profiles) for lab in LABELS}
    best_x = {lab: pset[lab].theta_hat for lab in LABELS}
    summary = {
        "mode": args.mode.name,
        "names": NAMES,
        "cache_salt": SALT,
        "calibration": {},
        "profile_reference": {},
        "local": {},
        "profiles": {},
        "posterior": {},
    }
    for lab in LABELS:
        c = cal[lab]
        summary["calibration"][lab] = {
            "ls_x": c.ls_x,
            "ls_chi2": c.ls_chi2,
            "chi2_parts": c.chi2_parts,
            "ls_active": c.ls_active,
            "ls_start_chi2": [s[1] for s in c.ls_starts],
            "n_obs": int(res[lab].sd.size),
            "median": np.median(c.draws, axis=0),
            "q05": np.quantile(c.draws, 0.05, axis=0),
            "q95": np.quantile(c.draws, 0.95, axis=0),
            "rhat": c.rhat,
            "acceptance": c.acceptance,
            "n_draws": c.draws.shape[0],
            "n_failed": c.n_failed,
            "n_dropped": c.n_dropped,
            "time_mcmc_s": c.time_mcmc_s,
            "sampler": c.sampler,
            "fit_check": c.fit_check,
            "tied": c.tied,
            "u_mean": c.u.mean(axis=0),
            "u_sd": c.u.std(axis=0),
            "skew": ((c.u - c.u.mean(0)) ** 3).mean(0) / np.maximum(c.u.std(0), 1e-12) ** 3,
            "kurt": ((c.u - c.u.mean(0)) ** 4).mean(0) / np.maximum(c.u.std(0), 1e-12) ** 4,
        }
        ps = pset[lab]
        summary["profile_reference"][lab] = {
            "chi2_calibration": c.ls_chi2,
            "chi2_polished": ps.chi2_start,
            "chi2_final": ps.chi2_min,
            "n_restarts": ps.n_restarts,
            "improvements": list(ps.improvements),
            "restart_from": list(ps.restart_from),
            "converged": ps.converged,
            "improvement_tol": ps.improvement_tol,
            "max_restarts": MAX_RESTARTS,
            "theta_final": ps.theta_hat,
            "theta_calibration": c.ls_x,
            "at_bound_final": at_bound(ps.theta_hat),
            "first_classifications": {p.name: c0 for p, c0 in zip(ps.profiles, ps.first_classifications, strict=True)},
        }
        a = loc[lab]
        gam = sorted(a.collinearity, key=lambda t: (len(t[0]), t[1]))
        summary["local"][lab] = {
            "theta": a.theta,
            "singular_values": a.singular_values,
            "se_log": a.std_error_log,
            "delta_msqr": a.delta_msqr,
            "sloppiest": a.sloppiest(3),
            "stiffest": [
                {n: float(w) for n, w in zip(NAMES, row, strict=True) if abs(w) > 0.1} for row in a.directions[:3]
            ],
            "largest_subsets": [[list(s), g] for s, g in a.largest_subsets[:5]],
            "pairs": [[list(s), g] for s, g in gam if len(s) == 2],
            "n_subsets_ok": int(sum(g < 10 for _, g in a.collinearity)),
            "n_subsets": len(a.collinearity),
            "n_informed": int(np.sum(a.singular_values > 1.0)),
        }
        summary["profiles"][lab] = [
            {
                "name": p.name,
                "classification": p.classification,
                "ci": p.ci,
                "theta_hat": p.theta_hat,
                "open": p.open_sides,
                "improved": p.improved,
                "n_points": int(p.values.size),
                "max_delta": float(np.nanmax(p.delta_chi2)),
                "min_delta": float(np.nanmin(p.delta_chi2)),
            }
            for p in prof[lab]
        ]
        pm = post[lab]
        js = distinct(c)
        summary["posterior"][lab] = {
            "contraction": pm["contraction"],
            "kl": pm["kl"],
            "at_lower": pm["flags"]["at_lower"],
            "at_upper": pm["flags"]["at_upper"],
            "share_lower": pm["flags"]["share_lower"],
            "share_upper": pm["flags"]["share_upper"],
            "max_abs_corr": [
                [NAMES[i], NAMES[j], float(pm["corr"][i, j])]
                for i, j in sorted(((i, j) for i in js for j in js if i < j), key=lambda ij: -abs(pm["corr"][ij]))[:5]
            ],
        }
    fam1 = [NAMES.index(n) for n in ("ginf1", "gamma1", "beta1")]
    e1, e2 = res["joint"].experiments  # the experiments the residuals were built from (T1, T2)
    summary["fibre1_check"] = {}
    for lab in LABELS:
        # tolerance = t_{B-1}(0.995) x batch-means Monte Carlo error (B = 10 contiguous batches), fixed in advance
        mc = uninformed_mc(
            cal[lab].u,
            prior_var=np.full(len(NAMES), 1 / 12),
            prior_logpdf=lambda x: np.zeros_like(x),
            n_bins=30,
            n_batches=10,
            level=0.99,
        )
        summary["fibre1_check"][lab] = {
            "contraction": post[lab]["contraction"][fam1],
            "kl": post[lab]["kl"][fam1],
            "sensitivity": loc[lab].delta_msqr[fam1],
            **{k: mc[k][fam1] for k in ("contraction_corrected", "kl_corrected", "se_contraction", "se_kl")},
            **{k: mc[k][fam1] for k in ("tol_contraction", "tol_kl", "uninformed")},
            "t": mc["t"],
            "n_batches": mc["n_batches"],
            "n_draws": int(cal[lab].u.shape[0]),
            "pass": bool(np.all(mc["uninformed"][fam1])),
            # where fibre 1 never carries tension the likelihood is exactly flat in its parameters
            "share_draws_fibre1_tension": fibre1_tension_share(cal[lab], (e1, e2), lab),
        }
    summary["fibre1_tension"] = {}
    for lab in LABELS:
        row = {}
        for e in (e1, e2):
            r = simulate(e, best_x[lab], full=True)
            row[e.name] = {
                "max_E22": float(r.strain[0, :, 1].max()),
                "max_tau1_kpa": float(r.tension_kpa[0, :, 0].max()),
            }
        summary["fibre1_tension"][lab] = row
    x = np.asarray(cal["T1"].ls_x, float)
    swapped = x.copy()
    swapped[5:8], swapped[8:11] = x[8:11], x[5:8]
    summary["swap_symmetry_max_abs_mm"] = max(
        float(np.max(np.abs(simulate(e, x) - simulate(e, swapped)))) for e in (e1, e2)
    )
    return summary
