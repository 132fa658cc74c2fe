"""The T1-vs-T2 study's workflow: cross-prediction, the loading-rate scenarios (cause 1), stereology replicates as a
cut posterior and a free fibre angle (cause 2), a specimen stiffness scale (cause 3).

Used by ``studies/t1_vs_t2.py``; builds on the identifiability study's calibrations and profiles
(:mod:`bayestissue.analyses.identifiability`).
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
from scipy.stats import chi2 as chi2_dist

from bayestissue.analyses.calibration_study import mirror_coordinates
from bayestissue.analyses.identifiability import (
    MAX_RESTARTS,
    NAMES,
    cached_map,
    interior,
    profile_interval,
    profile_options,
)
from bayestissue.analyses.propagate import half_angles_deg, interval_width, pool_draws, replicate_tissues
from bayestissue.analyses.records import (
    CutPosterior,
    CutTest,
    RateProfile,
    RateStudy,
    RateTruth,
    SpecimenModel,
    Tension,
)
from bayestissue.analyses.scenarios import ramp_scenario, synthetic_replica
from bayestissue.identifiability import (
    analyse_sensitivities,
    bhattacharyya,
    coverage,
    gaussian_loglik,
    log_predictive_density,
    predictive_band,
    scaled_sensitivities,
    tension,
)
from bayestissue.identifiability.restarts import profile_all
from bayestissue.mechanics import simulate
from bayestissue.paper import MIRROR_TIES, PAPER_BOUNDS, PAPER_HALF_ANGLE_DEG
from bayestissue.workflows.forward import MIRROR_NAMES, ExperimentResiduals, MirrorResiduals
from bayestissue.workflows.problem import paper_parameter_set
from bayestissue.workflows.tasks import CalibrationTask, drop_stuck_draws

__all__ = [
    "VISC",
    "MIRROR_NAMES",
    "cross_predict",
    "rate_record",
    "rate_study",
    "replicate_tasks",
    "specimen_and_cut",
    "specimen_tasks",
]

#: The fibre viscosity parameters whose identifiability cause 1 is about (mirror model: family 3 = family 2).
VISC = ("gamma2", "beta2")


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


def rate_study(args, client, e2, truth, draws):
    """Cause 1: T2-like ramps at several rates, data simulated from ``truth`` (a T1 mirror-model posterior draw:
    family 3 = family 2), analysed in the mirror model (8 parameters; the 11-parameter profiles of beta2 and beta3
    traded one family's viscosity for the other's, which made their classification jump between rates).
    Gauss-Newton sd of log gamma2, log beta2 at every rate; profiles of gamma2 and beta2 at the profiled rates,
    restarted from every improvement until none improves (cap
    :data:`~bayestissue.analyses.identifiability.MAX_RESTARTS`).

    One truth answers for one point of T1's posterior, and where a profile is borderline the answer moves with it
    (another machine's last bits once moved the best draw and flipped the beta2 answer at T2's rate). So the question
    at T2's rate (f = 1) is asked again of ``mode.rate_truths`` further draws of ``draws`` (T1's posterior, seeded
    choice): ``at_t2`` holds each draw's truth and profiles."""
    m = args.mode
    free = [NAMES.index(n) for n in MIRROR_NAMES]  # the mirror model's columns among the paper's 11
    lo, hi = PAPER_BOUNDS[free, 0], PAPER_BOUNDS[free, 1]
    t8 = interior(np.asarray(truth, dtype=float)[free], lo, hi)
    idx = [MIRROR_NAMES.index(p) for p in VISC]
    se = {p: [] for p in VISC}
    scen, ramp_s = [], []
    for i, f in enumerate(m.rate_factors):
        exp = synthetic_replica(ramp_scenario(e2, f), MirrorResiduals.expand(t8), sd=0.02, rng=args.seed + 100 + i)
        scen.append(exp)
        ramp_s.append(float(exp.time_s[-1] - exp.protocol.hold_s))
        S = scaled_sensitivities(lambda t, e=exp: simulate(e, MirrorResiduals.expand(t)), t8, noise_sd=0.02)
        a = analyse_sensitivities(S, t8, MIRROR_NAMES, max_size=2)
        for p, j in zip(VISC, idx, strict=True):
            se[p].append(float(a.std_error_log[j]))

    def profiles_at(exp, t):
        return profile_all(
            MirrorResiduals(ExperimentResiduals((exp,))),
            t,
            idx,
            lower=lo,
            upper=hi,
            names=MIRROR_NAMES,
            batched=True,
            options=profile_options(m, max_nfev=100),
            max_restarts=MAX_RESTARTS,
            refit_nfev=max(m.ls_nfev, 100),
            map_fn=cached_map(args, client),
        )

    cls = {}
    for f, exp in zip(m.rate_factors, scen, strict=True):
        if f not in m.rate_profile_factors:
            continue
        ps = profiles_at(exp, t8)
        cls[f] = {"n_restarts": ps.n_restarts, "improvements": list(ps.improvements), "converged": ps.converged}
        for p, pr in zip(VISC, ps.profiles, strict=True):
            cls[f][p] = pr.classification
            cls[f][f"ci_{p}"] = pr.ci
    at_t2 = []
    ok = np.flatnonzero(np.all(np.isfinite(draws), axis=1))
    pick = np.random.default_rng(args.seed + 300).choice(ok, min(m.rate_truths, ok.size), replace=False)
    for k, row in enumerate(pick):
        tk = interior(np.asarray(draws[row], dtype=float)[free], lo, hi)
        exp = synthetic_replica(ramp_scenario(e2, 1.0), MirrorResiduals.expand(tk), sd=0.02, rng=args.seed + 400 + k)
        ps = profiles_at(exp, tk)
        at_t2.append({"truth": {p: float(tk[j]) for p, j in zip(VISC, idx, strict=True)},
                      "classification": {p: pr.classification for p, pr in zip(VISC, ps.profiles, strict=True)},
                      "ci": {p: pr.ci for p, pr in zip(VISC, ps.profiles, strict=True)}})  # fmt: skip
    return {"factors": list(m.rate_factors), "ramp_s": ramp_s, "se_log": se, "profiles": cls, "truth": truth,
            "at_t2": at_t2}  # fmt: skip


def rate_record(rates: dict) -> RateStudy:
    """The rate study of :func:`rate_study` as its record."""
    profiles = {
        f"{f:g}": RateProfile(
            n_restarts=pr["n_restarts"], improvements=pr["improvements"], converged=pr["converged"],
            classification={p: pr[p] for p in VISC}, ci={p: profile_interval(pr[f"ci_{p}"]) for p in VISC},
        )
        for f, pr in rates["profiles"].items()
    }  # fmt: skip
    at_t2 = [
        RateTruth(truth=t["truth"], classification=t["classification"],
                  ci={p: profile_interval(t["ci"][p]) for p in VISC})
        for t in rates["at_t2"]
    ]  # fmt: skip
    return RateStudy(factors=rates["factors"], ramp_s=rates["ramp_s"], se_log=rates["se_log"], profiles=profiles,
                     truth=list(rates["truth"]), at_t2=at_t2)  # fmt: skip


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


def specimen_tasks(args, opt_x: dict, e1, e2) -> list:
    """Causes 2 and 3 as specimen-level parameters of the joint fit: a T2 stiffness scale and a free T2 fibre
    half-angle (least squares only), started from the best optima of the joint fit, T1 and T2."""
    m = args.mode
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
    return spec_tasks


def specimen_and_cut(args, outs, cal, chi2: dict, e1, e2, reps, pick) -> tuple[dict, CutPosterior | None, dict]:
    """The specimen-level fits (``outs[0]`` scale, ``outs[1]`` angle: likelihood ratio, BIC, remaining tension) as
    :class:`SpecimenModel` by name, and the cut posterior over the stereology replicates (``outs[2:]``: widths
    with and without the stereological uncertainty, overlap of the pooled posteriors), with its pooled draws by
    test for the figures (empty without replicates)."""
    m = args.mode
    scale, angle = outs[0], outs[1]
    rep_out = [drop_stuck_draws(o) for o in outs[2:]]
    n_tot = e1.time_s.size + e2.time_s.size
    cut, pooled, z = None, {}, None
    if rep_out:
        tests = {}
        for lab in ("T1", "T2"):
            rr = [o for o in rep_out if o.label.startswith(lab)]
            pooled[lab] = pool_draws([o.u for o in rr], rng=args.seed)
            ls_u = paper_parameter_set().to_unit(np.array([o.ls_x for o in rr]))
            tests[lab] = CutTest(
                base_width=interval_width(cal[lab].u), cut_width=interval_width(pooled[lab]),
                within_width=np.mean([interval_width(o.u) for o in rr], axis=0),
                ls_u_spread=ls_u.max(0) - ls_u.min(0), acceptance=float(np.mean([o.acceptance for o in rr])),
                coordinates=mirror_coordinates(lab),
            )  # fmt: skip
        ang = half_angles_deg(reps["directions"])
        cut = CutPosterior(
            tests=tests, steps=m.replicate_steps, adapt=list(m.replicate_adapt),
            bc_pooled=bhattacharyya(pooled["T1"], pooled["T2"], n_bins=30), half_angle_mean=float(ang.mean()),
            half_angle_sd=float(ang.std(ddof=1)), phi_fibre_sd=np.std(reps["phi_fibres"], axis=0, ddof=1),
            n_replicates_table=int(len(ang)), n_used=int(len(pick)),
        )  # fmt: skip
        z = float((float(angle.ls_x[-1]) - PAPER_HALF_ANGLE_DEG) / max(cut.half_angle_sd, 1e-9))
    specimen = {}
    for lab, o, zz in (("scale", scale, None), ("angle", angle, z)):
        d = chi2["joint"] - o.ls_chi2
        rem = tension(o.ls_chi2, [chi2["T1"], chi2["T2"]], 10)
        specimen[lab] = SpecimenModel(
            estimate=float(o.ls_x[-1]), chi2=o.ls_chi2, delta_chi2=float(d), lr_p=float(chi2_dist.sf(max(d, 0), 1)),
            delta_bic=float(d - np.log(n_tot)), remaining=Tension(rem["Q"], rem["df"], rem["p_value"]),
            z_vs_stereology=zz,
        )  # fmt: skip
    return specimen, cut, pooled
