"""T1 versus T2: is the difference real, and which of the paper's three causes explains it?

Overlap of the separate posteriors, cross-prediction, tension of a joint fit, leave-one-experiment-out,
principal angles; then simulated tests of the causes: (1) loading rate, (2) fibre directions and volume
fractions (stereology replicates carried into a cut posterior; a free T2 fibre angle), (3) specimen
differences (a per-specimen stiffness scale). Writes figures/t1_vs_t2_*.png and figures/t1_vs_t2_summary.json.

    python studies/t1_vs_t2.py [--quick | --full] [--scheduler ADDR] [--n-workers N]
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from scipy.stats import chi2 as chi2_dist  # noqa: E402

import bayestissue.workflows.identifiability as ids  # noqa: E402
from bayestissue.identifiability import (  # noqa: E402
    analyse_sensitivities,
    bhattacharyya,
    coverage,
    gaussian_loglik,
    informed_directions,
    log_predictive_density,
    predictive_band,
    principal_angles,
    profile_all,
    psis_leave_out,
    scaled_sensitivities,
    tension,
)
from bayestissue.io.figures import save_figure  # noqa: E402
from bayestissue.mechanics import simulate  # noqa: E402
from bayestissue.paper import (
    MIRROR_TIES,
    PAPER_BOUNDS,  # noqa: E402
    PAPER_HALF_ANGLE_DEG,
)
from bayestissue.parallel import fan_out  # noqa: E402
from bayestissue.plotting.identifiability import (  # noqa: E402
    plot_corner_overlay,
    plot_cross_prediction,
    plot_marginals_overlay,
    plot_rate_study,
    plot_widths,
)
from bayestissue.workflows import (
    CalibrationTask,
    ExperimentResiduals,
    drop_stuck_draws,
    paper_parameter_set,  # noqa: E402
    run_task,
)
from bayestissue.workflows.calibration import mirror_coordinates  # noqa: E402
from bayestissue.workflows.propagate import (  # noqa: E402
    half_angles_deg,
    interval_width,
    pool_draws,
    replicate_tissues,
)
from bayestissue.workflows.scenarios import ramp_scenario, synthetic_replica  # noqa: E402

NAMES = ids.NAMES
VISC = ("gamma2", "beta2", "gamma3", "beta3")


def cross_predict(exp, draws, *, n, sd, rng):
    """Posterior predictive of ``exp`` from ``draws``: band, median, coverage, exact elpd."""
    idx = rng.choice(draws.shape[0], min(n, draws.shape[0]), replace=False)
    pred = simulate(exp, draws[idx])
    ok = np.all(np.isfinite(pred), axis=1)
    pred = pred[ok]
    noisy = pred + sd * rng.normal(size=pred.shape)
    lo, hi = predictive_band(noisy, level=0.9)
    cov = coverage(exp.displacement_mm, noisy, level=0.9)
    ll = gaussian_loglik(exp.displacement_mm, pred, sd)
    return {
        "band": (lo, hi),
        "median": np.median(noisy, axis=0),
        "coverage": cov,
        "elpd": log_predictive_density(ll),
        "n": int(pred.shape[0]),
        "n_failed": int((~ok).sum()),
    }


def rate_study(args, client, e2, truth):
    """Cause 1: T2-like ramps at several rates, data simulated from ``truth`` (a T1 posterior draw)."""
    m = args.mode
    se = {p: [] for p in VISC}
    scen = []
    for i, f in enumerate(m.rate_factors):
        exp = synthetic_replica(ramp_scenario(e2, f), truth, sd=0.02, rng=args.seed + 100 + i)
        scen.append(exp)
        th = ids.interior(truth)
        S = scaled_sensitivities(lambda t, e=exp: simulate(e, t), th, noise_sd=0.02)
        a = analyse_sensitivities(S, th, NAMES, max_size=2)
        for p in VISC:
            se[p].append(float(a.std_error_log[NAMES.index(p)]))
    opt = ids.profile_options(m, max_nfev=100)
    kw = dict(lower=PAPER_BOUNDS[:, 0], upper=PAPER_BOUNDS[:, 1], names=NAMES, batched=True, options=opt)
    cls = {}
    for f, exp in zip(m.rate_factors, scen, strict=True):
        if f not in m.rate_profile_factors:
            continue
        # profiles relative to the best optimum of the simulated data (restarts if a profile improves on it)
        ps = profile_all(
            ExperimentResiduals((exp,)),
            ids.interior(truth),
            [NAMES.index("beta2"), NAMES.index("beta3")],
            max_restarts=ids.MAX_RESTARTS,
            refit_nfev=max(m.ls_nfev, 100),
            map_fn=ids.cached_map(args, client),
            **kw,
        )
        b2, b3 = ps.profiles
        cls[f] = {
            b2.name: b2.classification,
            b3.name: b3.classification,
            "ci_beta2": b2.ci,
            "ci_beta3": b3.ci,
            "n_restarts": ps.n_restarts,
            "improvements": list(ps.improvements),
            "converged": ps.converged,
        }
    return {"factors": list(m.rate_factors), "se_log": se, "profiles": cls, "truth": truth}


def replicate_tasks(args, cal, e1, e2):
    """Cause 2: one calibration per stereology replicate and test (cut posterior), if the table exists; the
    mirror model with the calibration stage's sampler (its coordinates per test, fitted-mixture moves), one
    ensemble per replicate warm-started at the calibration's least-squares optimum.

    Measured on replicate 3 (2000 steps after 2 x 500 adaptation): T1 22 s, T2 29 s; the central 90 % widths
    match the calibration posterior's (T1 kappa 0.67 vs 0.65, T2 gamma2 0.87 vs 0.86 in the scaled box), where
    the former 250-step box-coordinate chains gave 0.02 for T1 kappa (they never left the start of the L).
    Reweighting the calibration posterior to each replicate instead (PSIS) is no way out: Pareto k < 0.7 for 3
    of 40 T1 replicates (the replicate posteriors sit elsewhere). The default setting runs 4 replicates x 1500
    steps: 6 x 2000 cost 197 s instead of 141 s for this stage and put `make study` at 20.3 min."""
    path = Path(args.data) / "stereology_replicates.csv"
    if not path.is_file():
        return None, None, []
    from bayestissue.io.stereology_files import read_replicates

    reps = read_replicates(path)
    tissues = replicate_tissues(reps, base=e1.tissue)
    rng = np.random.default_rng(args.seed + 7)
    pick = np.sort(rng.choice(len(tissues), min(args.mode.n_replicates, len(tissues)), replace=False))
    tasks = []
    for r in pick:
        for lab, e in (("T1", e1), ("T2", e2)):
            tasks.append(
                CalibrationTask(
                    (replace(e, tissue=tissues[r]),),
                    n_steps=args.mode.replicate_steps,
                    n_ensembles=1,
                    n_starts=0,
                    paper_start=False,
                    extra_starts=(tuple(cal[lab].ls_x),),
                    keep=1000,
                    seed=args.seed + 1000 + int(r),
                    label=f"{lab}_rep{r}",
                    tied=MIRROR_TIES,
                    coordinates=mirror_coordinates(lab),
                    moves="mixture",
                    adapt_rounds=args.mode.replicate_adapt[0],
                    adapt_steps=args.mode.replicate_adapt[1],
                )
            )
    return reps, pick, tasks


def main(argv=None) -> int:
    args = ids.parse_args(argv, __doc__, root=Path(__file__).resolve().parents[1])
    m = args.mode
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    T = ids.Timer("t1_vs_t2")
    rng = np.random.default_rng(args.seed)
    e1, e2 = ids.experiments(args)
    sd = 0.02
    S = {}
    client = ids.client_for(args)
    try:
        T.stage("calibrations (cached)")
        cal = ids.calibrations(args, client)
        T.stage("overlap, cross-prediction, tension")
        bc = bhattacharyya(cal["T1"].u, cal["T2"].u, n_bins=30)
        n_pp = 150 if m.name == "quick" else 600
        cp = {
            "T2|T1": cross_predict(e2, cal["T1"].draws, n=n_pp, sd=sd, rng=rng),
            "T1|T2": cross_predict(e1, cal["T2"].draws, n=n_pp, sd=sd, rng=rng),
            "T1|T1": cross_predict(e1, cal["T1"].draws, n=n_pp, sd=sd, rng=rng),
            "T2|T2": cross_predict(e2, cal["T2"].draws, n=n_pp, sd=sd, rng=rng),
        }
        res = ids.residuals_for(args)
        # best optima: the calibration's least squares improved by the profile restarts (cached profiles)
        pset = ids.profiles(args, client, res, cal)
        opt_x = {lab: pset[lab].theta_hat for lab in ids.LABELS}
        chi2 = {lab: pset[lab].chi2_min for lab in ids.LABELS}
        for lab in ids.LABELS:
            th = ids.interior(opt_x[lab])
            S[lab] = scaled_sensitivities(res[lab].predict, th, noise_sd=res[lab].sd)
        n_inf = int(np.sum(np.linalg.svd(S["joint"], compute_uv=False) > 1.0))
        ten = tension(chi2["joint"], [chi2["T1"], chi2["T2"]], 11)
        ten_eff = tension(chi2["joint"], [chi2["T1"], chi2["T2"]], max(n_inf, 1))
        loo = {}
        for k, lab in enumerate(("T1", "T2")):
            ll = cal["joint"].loglik[:, k]
            loo[lab] = psis_leave_out(ll)
        angles = principal_angles(informed_directions(S["T1"]), informed_directions(S["T2"]))

        T.stage("cause 1: loading rate")
        best = int(np.argmax(cal["T1"].loglik[:, 0]))
        rates = rate_study(args, client, e2, cal["T1"].draws[best])

        T.stage("causes 2+3: replicates, angle, scale")
        reps, pick, rtasks = replicate_tasks(args, cal, e1, e2)
        starts = (tuple(opt_x["joint"]), tuple(opt_x["T1"]), tuple(opt_x["T2"]))
        if m.name == "quick":
            starts = starts[:1]
        spec_tasks = [
            CalibrationTask(
                (e1, e2),
                specimen=("scale", "T2"),
                n_steps=0,
                n_starts=m.n_starts,
                extra_starts=starts,
                seed=args.seed + 11,
                label="joint+scale",
                max_nfev=m.ls_nfev,
                paper_start=m.name != "quick",
            ),
            CalibrationTask(
                (e1, e2),
                specimen=("angle", "T2"),
                n_steps=0,
                n_starts=0,
                paper_start=False,
                extra_starts=starts,
                seed=args.seed + 12,
                label="joint+angle",
                max_nfev=m.ls_nfev,
            ),
        ]
        outs = fan_out(run_task, spec_tasks + rtasks, cache_dir=args.cache_dir, client=client, salt=ids.SALT)
    finally:
        ids.close_client(client)
    T.stage("summaries + figures")
    scale, angle = outs[0], outs[1]
    rep_out = [drop_stuck_draws(o) for o in outs[2:]]
    n_tot = e1.time_s.size + e2.time_s.size
    specimen = {}
    for lab, o in (("scale", scale), ("angle", angle)):
        d = chi2["joint"] - o.ls_chi2
        specimen[lab] = {
            "estimate": float(o.ls_x[-1]),
            "chi2": o.ls_chi2,
            "chi2_parts": o.chi2_parts,
            "delta_chi2": float(d),
            "lr_p": float(chi2_dist.sf(max(d, 0), 1)),
            "delta_bic": float(d - np.log(n_tot)),
            "remaining_tension": tension(o.ls_chi2, [chi2["T1"], chi2["T2"]], 10),
            "ls_x": o.ls_x,
        }
    cut = None
    if rep_out:
        cut = {}
        for lab in ("T1", "T2"):
            rr = [o for o in rep_out if o.label.startswith(lab)]
            pooled = pool_draws([o.u for o in rr], rng=args.seed)
            ls_u = paper_parameter_set().to_unit(np.array([o.ls_x for o in rr]))
            cut[lab] = {
                "pooled": pooled,
                "base_width": interval_width(cal[lab].u),
                "cut_width": interval_width(pooled),
                "within_width": np.mean([interval_width(o.u) for o in rr], axis=0),
                "ls_u_spread": ls_u.max(0) - ls_u.min(0),
                "ls_chi2": [o.ls_chi2 for o in rr],
                "rhat": None,
                "acceptance": float(np.mean([o.acceptance for o in rr])),
                "coordinates": mirror_coordinates(lab),
            }
        cut["steps"] = m.replicate_steps
        cut["adapt"] = list(m.replicate_adapt)
        cut["bc_pooled"] = bhattacharyya(cut["T1"]["pooled"], cut["T2"]["pooled"], n_bins=30)
        ang = half_angles_deg(reps["directions"])
        cut["half_angle_mean"] = float(ang.mean())
        cut["half_angle_sd"] = float(ang.std(ddof=1))
        cut["half_angles_used"] = ang[pick].tolist()
        cut["phi_fibre_sd"] = np.std(reps["phi_fibres"], axis=0, ddof=1).tolist()
        cut["n_replicates_table"] = int(len(ang))
        cut["n_used"] = int(len(pick))
        specimen["angle"]["z_vs_stereology"] = float(
            (specimen["angle"]["estimate"] - PAPER_HALF_ANGLE_DEG) / max(cut["half_angle_sd"], 1e-9)
        )

    # ---- figures
    save_figure(plot_marginals_overlay({"T1": cal["T1"].u, "T2": cal["T2"].u}, NAMES), out / "t1_vs_t2_marginals.png")
    if m.corners:
        js = ids.distinct(cal["T1"])
        save_figure(
            plot_corner_overlay({"T1": cal["T1"].u[:, js], "T2": cal["T2"].u[:, js]}, [NAMES[j] for j in js]),
            out / "t1_vs_t2_corner.png",
        )
    fig, axes = plt.subplots(2, 2, figsize=(11, 7.5))
    for ax, key, exp in (
        (axes[0, 0], "T1|T1", e1),
        (axes[0, 1], "T2|T2", e2),
        (axes[1, 0], "T1|T2", e1),
        (axes[1, 1], "T2|T1", e2),
    ):
        c = cp[key]
        tgt, src = key.split("|")
        plot_cross_prediction(
            exp.time_s,
            exp.displacement_mm,
            c["band"],
            c["median"],
            ax=ax,
            coverage=c["coverage"],
            title=f"{tgt} data, predicted from the {src} posterior",
        )
    fig.tight_layout()
    save_figure(fig, out / "t1_vs_t2_cross_prediction.png")
    marks = {}
    for p in ("beta2", "beta3"):
        row = []
        for f in rates["factors"]:
            pr = rates["profiles"].get(f)
            row.append(-1 if pr is None else int(pr[p] == "identifiable"))
        marks[p] = np.array(row)
    save_figure(plot_rate_study(rates["factors"], rates["se_log"], marks=marks), out / "t1_vs_t2_rates.png")
    if cut:
        save_figure(
            plot_widths(
                {
                    "T1 one replicate (mean)": cut["T1"]["within_width"],
                    "T1 cut (pooled)": cut["T1"]["cut_width"],
                    "T2 one replicate (mean)": cut["T2"]["within_width"],
                    "T2 cut (pooled)": cut["T2"]["cut_width"],
                },
                NAMES,
            ),
            out / "t1_vs_t2_stereology_widths.png",
        )
        save_figure(
            plot_marginals_overlay(
                {"T1": cut["T1"]["pooled"], "T2": cut["T2"]["pooled"]},
                NAMES,
                title="Cut posteriors: pooled over stereology replicates (dotted: the prior)",
            ),
            out / "t1_vs_t2_cut_marginals.png",
        )

    summary = {
        "mode": m.name,
        "names": NAMES,
        "bhattacharyya": bc,
        "cross_prediction": {k: {kk: v[kk] for kk in ("coverage", "elpd", "n", "n_failed")} for k, v in cp.items()},
        "tension": ten,
        "tension_effective": ten_eff,
        "n_informed_joint": n_inf,
        "chi2": chi2,
        "chi2_calibration": {lab: cal[lab].ls_chi2 for lab in ids.LABELS},
        "chi2_joint_parts": [float(np.sum(res[lab](opt_x["joint"]) ** 2)) for lab in ("T1", "T2")],
        "chi2_joint_parts_calibration": cal["joint"].chi2_parts,
        "loo_psis": loo,
        "principal_angles_deg": angles,
        "n_informed": {lab: int(np.sum(np.linalg.svd(S[lab], compute_uv=False) > 1)) for lab in S},
        "rates": rates,
        "specimen": specimen,
        "cut": None
        if cut is None
        else {
            k: (v if not isinstance(v, dict) else {kk: vv for kk, vv in v.items() if kk != "pooled"})
            for k, v in cut.items()
        },
    }
    summary["timings_s"] = T.done()
    (out / "t1_vs_t2_summary.json").write_text(json.dumps(ids.json_safe(summary), indent=1))
    print(f"  wrote {out / 't1_vs_t2_summary.json'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
