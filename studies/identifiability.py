"""Identifiability of the paper's 11 parameters from T1, T2 and both: local (sensitivities, SVD,
collinearity), profile likelihoods, and what the posteriors learnt (contraction, KL, bounds, correlation).

The posteriors are the calibration stage's mirror-model runs (figures/calibration_{T1,T2,joint}_mirror_posterior.nc
from studies/calibrate.py, which make study runs first; --posteriors DIR to read them elsewhere), expanded to the 11
parameters; least squares, profiles and sensitivities use the paper's 11 free parameters.

Writes figures/identifiability_*.png and figures/identifiability_summary.json (read by studies/report.py).
Independent runs fan out over dask.distributed (LocalCluster, or --scheduler tcp://host:8786) and are cached
on disk by content hash (--cache-dir): a re-run, or a run after a lost worker, computes only what is missing.
The cache key (bayestissue.parallel.task_key) hashes a task's function name and arguments, not its code, so the
salt here is a hash of the package's source: any change to bayestissue/ starts a fresh set of keys.

Profiles are relative to the best optimum found: when a profile point improves on the least-squares optimum by
more than 1e-3 in -2 log L, all parameters are re-optimised from it and every profile of that test is recomputed
(bayestissue.identifiability.profile_all); the restarts are recorded in the summary.

    python studies/identifiability.py [--quick | --full] [--scheduler ADDR] [--n-workers N]
"""

from __future__ import annotations

import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from bayestissue.identifiability import (  # noqa: E402
    CHI2_1_95,
    uninformed_mc,
)
from bayestissue.io.figures import save_figure  # noqa: E402
from bayestissue.mechanics import simulate
from bayestissue.plotting.identifiability import (  # noqa: E402
    plot_collinearity,
    plot_contraction,
    plot_corner_overlay,
    plot_marginals_overlay,
    plot_profiles,
    plot_singular_values,
)
from bayestissue.workflows.identifiability import (  # noqa: E402
    LABELS,
    MAX_RESTARTS,
    NAMES,
    SALT,
    Timer,
    at_bound,
    calibrations,
    client_for,
    close_client,
    distinct,
    experiments,
    fibre1_tension_share,
    json_safe,
    local_analyses,
    parse_args,
    posterior_measures,
    profiles,
    residuals_for,
)

ROOT = Path(__file__).resolve().parents[1]


def main(argv=None) -> int:
    args = parse_args(argv, __doc__, root=ROOT)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    T = Timer("identifiability")
    print(f"[identifiability] mode {args.mode.name}, cache {args.cache_dir}")
    client = client_for(args)
    try:
        T.stage("least squares + calibration posteriors")
        cal = calibrations(args, client)
        for lab in LABELS:
            c = cal[lab]
            print(
                f"  {lab}: chi2_min {c.ls_chi2:.1f} (n = {c.loglik.shape[0] if c.loglik is not None else 0}"
                f" draws, acceptance {c.acceptance:.3f}, max R-hat "
                f"{np.nanmax(c.rhat) if c.rhat is not None else float('nan'):.3f})"
            )
        res = residuals_for(args)
        T.stage("profile likelihoods")
        pset = profiles(args, client, res, cal)
        best_x = {lab: pset[lab].theta_hat for lab in LABELS}
        T.stage("local sensitivities")
        loc = local_analyses(res, best_x)
    finally:
        close_client(client)
    T.stage("posterior measures + figures")
    post = posterior_measures(cal)
    prof = {lab: list(pset[lab].profiles) for lab in LABELS}

    save_figure(
        plot_profiles(prof, [p for p in NAMES if p in args.mode.profile_params], threshold=CHI2_1_95),
        out / "identifiability_profiles.png",
    )
    save_figure(
        plot_singular_values({lab: loc[lab].singular_values for lab in LABELS}),
        out / "identifiability_singular_values.png",
    )
    save_figure(
        plot_collinearity({lab: [(s, g) for s, g in loc[lab].collinearity] for lab in LABELS}),
        out / "identifiability_collinearity.png",
    )
    save_figure(
        plot_contraction(
            {lab: post[lab]["contraction"] for lab in LABELS}, NAMES, ylabel="contraction 1 - var_post/var_prior"
        ),
        out / "identifiability_contraction.png",
    )
    save_figure(
        plot_contraction({lab: post[lab]["kl"] for lab in LABELS}, NAMES, ylabel="KL(posterior || prior) (nats)"),
        out / "identifiability_kl.png",
    )
    save_figure(plot_marginals_overlay({lab: cal[lab].u for lab in LABELS}, NAMES), out / "posterior_marginals.png")
    for lab in LABELS if args.mode.corners else ():
        js = distinct(cal[lab])
        fig = plot_corner_overlay({lab: cal[lab].u[:, js]}, [NAMES[j] for j in js])
        save_figure(fig, out / f"posterior_corner_{lab}.png")
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.6))
    for ax, lab in zip(axes, LABELS, strict=True):
        js = distinct(cal[lab])
        im = ax.imshow(post[lab]["corr"][np.ix_(js, js)], vmin=-1, vmax=1, cmap="RdBu_r")
        ax.set_xticks(range(len(js)), [NAMES[j] for j in js], rotation=90, fontsize=7)
        ax.set_yticks(range(len(js)), [NAMES[j] for j in js], fontsize=7)
        ax.set_title(f"{lab}: posterior correlation (scaled box)", fontsize=9)
    fig.colorbar(im, ax=axes, shrink=0.8)
    save_figure(fig, out / "posterior_correlation.png")

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
            "share_draws_fibre1_tension": fibre1_tension_share(cal[lab], experiments(args), lab),
        }
    e1, e2 = experiments(args)
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
    summary["timings_s"] = T.done()
    (out / "identifiability_summary.json").write_text(json.dumps(json_safe(summary), indent=1))
    print(f"  wrote {out / 'identifiability_summary.json'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
