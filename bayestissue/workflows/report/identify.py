"""Report section 1: which parameters each test identifies (local analysis, profiles, posteriors, sanity check,
and what the mirror-model calibrations carry)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.stats import chi2 as chi2_dist

from bayestissue.workflows.report.text import ci_text, fl, likelihood_ratio, num, short

__all__ = ["identifiability_section"]


def _mirror_section(out: Path, w) -> None:
    """Section 1, last part: what a creep and a ramp test carry, from the mirror-model calibrations
    (studies/calibrate.py; skipped when their tables are absent)."""
    from bayestissue.io.tables import read_table

    tables = {}
    for lab in ("T1", "T2"):
        path = out / f"calibration_summary_{lab}_mirror.csv"
        if path.exists():
            tables[lab] = read_table(path)
    if not tables:
        return
    w("### What the tests carry: the mirror-symmetric model in creep-curve coordinates\n")
    w(
        "The displacement cannot tell fibre families 2 and 3 apart, so `studies/calibrate.py` also calibrates the "
        "mirror-symmetric model (family 3 tied to family 2's law: 8 material parameters) on T1, T2 and both "
        "together, and samples T1 in "
        "creep-curve coordinates (`bayestissue/inference/coordinates.py`: matrix split "
        "lambda mu / (lambda mu + kappa), matrix share of the long-time modulus, instantaneous modulus E0, creep "
        "compliance 1/E_inf - 1/E0 and creep rate of a spring in parallel with a Kelvin element; exact Jacobian; "
        "sheared along the two-dimensional least-squares profile over split and share), and T2 and the joint run in "
        "ramp coordinates (the box coordinates sheared along the least-squares profile over the fibre viscosity "
        "gamma, beta and then over mu, which straightens the valley in which ginf and kappa follow them), with "
        "half of the moves "
        "independence proposals from a Student-t mixture fitted during burn-in (`bayestissue/inference/proposals.py`). "
        "When these coordinates were designed, the T1 least-squares profile over the matrix split was flat to 0.13 "
        "in -2 log L from 0.0003 to 0.9997 (docstring of that module), and in `calibration_T1_mirror_corner.png` "
        "the posterior runs along the matrix share until mu and kappa reach their lower bounds: a creep test "
        "determines the instantaneous and the creep response of the composite, not how the matrix divides it "
        "between its two terms nor how much of the long-time stiffness is matrix rather than fibre.\n"
    )
    w("| parameter | generating T1 | T1 posterior 90 % | R-hat T1 | generating T2 | T2 posterior 90 % | R-hat T2 |")
    w("|---|---|---|---|---|---|---|")
    names = []
    for c, _ in tables.values():
        names += [n for n in c["parameter"] if n not in names]
    for n in names:
        cells = [n]
        for lab in ("T1", "T2"):
            c = tables[lab][0] if lab in tables else {"parameter": []}
            if n not in list(c["parameter"]):
                cells += ["", "", ""]
                continue
            j = list(c["parameter"]).index(n)
            cells += [num(c["generating"][j]), f"{num(c['q05'][j])} - {num(c['q95'][j])}", num(c["rhat"][j], ".3f")]
        w("| " + " | ".join(cells) + " |")
    w("")
    for lab, (c, meta) in tables.items():
        w(f"- {lab} mirror: {meta.get('convergence', 'n/a')}")
        missed = []
        for j, n in enumerate(c["parameter"]):
            g = float(c["generating"][j])
            if float(c["contraction"][j]) < 0.3 or c["q05"][j] <= g <= c["q95"][j]:
                continue
            on_bound = np.isclose(g, c["lower"][j]) or np.isclose(g, c["upper"][j])
            missed.append(f"{n} ({num(g)}{', on a box bound' if on_bound else ''})")
        w(
            f"- {lab} mirror, recovery: generating values of the informed parameters (contraction >= 0.3) outside "
            f"the 90 % interval: {', '.join(missed) or 'none'}. An equal-tailed interval cannot contain a value on "
            "a box bound."
        )
    full, mirror = (
        _loglik_range(out / "calibration_T1_posterior.nc"),
        _loglik_range(out / "calibration_T1_mirror_posterior.nc"),
    )
    if full and mirror:
        gap = full[2] - mirror[2]
        p_lr = float(chi2_dist.sf(max(2 * gap, 0.0), 3))
        w(
            "- The T1 replica has beta2 = 0.00056 != beta3 = 0.00043, which the mirror model cannot represent. By the "
            f"numbers: its draws reach a log-likelihood of {num(mirror[0], '.1f')} to {num(mirror[1], '.1f')} (5-95 %, "
            f"best {num(mirror[2], '.1f')}) against {num(full[0], '.1f')} to {num(full[1], '.1f')} (best "
            f"{num(full[2], '.1f')}) for the 11-parameter model's draws: the best draws differ by {num(gap, '.2f')} in "
            "log-likelihood, "
            + f"a likelihood-ratio statistic of {num(2 * gap, '.2f')} on the 3 parameters the tie removes (p = "
            f"{num(p_lr, '.2g')}): "
            + ("the data cannot tell the two models apart, so the misspecification is real but invisible here. "
               if p_lr > 0.05 else "the data detect it. ")
            + "Setting family 3 to family 2's generating values instead gives a far worse fit "
            "(`calibration_recovery.md`): the tie at the generating point is not the model's best approximation. "
            "T2's generating values are mirror-symmetric."
        )  # fmt: skip
    w("")


def _loglik_range(path: Path):
    """(5 %, 95 %, max) of the total log-likelihood of a results file's draws, or None if it is absent."""
    if not Path(path).exists():
        return None
    from bayestissue.inference.summary import draw_log_likelihood
    from bayestissue.io.results import read_inference_data

    ll = draw_log_likelihood(read_inference_data(path))
    return (*np.percentile(ll, [5, 95]), float(ll.max()))


def identifiability_section(A: dict, out: Path, w) -> dict:
    """Write section 1 with ``w``; returns the profiles and posterior summaries section 4 reads."""
    names = A["names"]
    labs = ("T1", "T2", "joint")
    w("## 1. Which parameters each test identifies\n")
    w("### Local analysis at the least-squares optimum\n")
    w(
        "Scaled sensitivities S = (1/sd) du/dlog(theta) (noise sd 0.02 mm), their singular values "
        "(a singular value above 1 pins a combination of log-parameters to better than a factor e) and "
        "Brun et al. (2001) collinearity indices of all 2036 parameter subsets (critical value 10).\n"
    )
    ref = A["profile_reference"]
    w(
        "All local and profile analyses are at the *best* least-squares optimum found: the calibration's "
        "multi-start optimum, improved where a profile found a lower chi2 (see the profile section).\n"
    )
    w("| | T1 | T2 | joint |\n|---|---|---|---|")
    sv = {lab: A["local"][lab]["singular_values"] for lab in labs}
    w(
        "| chi2 at the best optimum (n data) | "
        + " | ".join(f"{num(ref[lab]['chi2_final'], '.1f')} ({A['calibration'][lab]['n_obs']})" for lab in labs)
        + " |"
    )
    w("| singular values | " + " | ".join(", ".join(num(s, ".2g") for s in sv[lab]) for lab in labs) + " |")
    w("| directions with s > 1 | " + " | ".join(str(A["local"][lab]["n_informed"]) for lab in labs) + " |")
    w(
        "| subsets with gamma < 10 | "
        + " | ".join(f"{A['local'][lab]['n_subsets_ok']} of {A['local'][lab]['n_subsets']}" for lab in labs)
        + " |"
    )
    w(
        "| largest identifiable subsets (gamma) | "
        + " | ".join(
            "; ".join(f"{{{', '.join(s)}}} ({num(g, '.3g')})" for s, g in A["local"][lab]["largest_subsets"][:3])
            for lab in labs
        )
        + " |"
    )
    w(
        "| best-determined combination | "
        + " | ".join(
            ", ".join(f"{num(v, '+.2f')} {k}" for k, v in A["local"][lab]["stiffest"][0].items()) for lab in labs
        )
        + " |"
    )
    w(
        "| sloppiest combinations (null space) | "
        + " | ".join(" / ".join("+".join(sorted(d)) for d in A["local"][lab]["sloppiest"]) for lab in labs)
        + " |\n"
    )
    w("Most collinear pairs (gamma of the pair):\n")
    for lab in labs:
        pairs = sorted(A["local"][lab]["pairs"], key=lambda t: -fl(t[1]))
        finite = [p for p in pairs if fl(p[1]) < float("inf")][:4]
        w(f"- {lab}: " + "; ".join(f"{a}-{b} {num(g)}" for (a, b), g in finite))
    w("")
    w("![singular values](identifiability_singular_values.png)\n")
    w("![collinearity](identifiability_collinearity.png)\n")

    w("### Profile likelihoods (Raue et al. 2009, threshold 3.84)\n")
    prof = {lab: {p["name"]: p for p in A["profiles"][lab]} for lab in labs}
    tol = ref["T1"]["improvement_tol"]
    w(
        "A profile is measured from the global optimum: a profile point below it would be a better fit the "
        "least-squares optimiser had missed. Rule (`bayestissue.identifiability.profile_all`): if any profile "
        f"point lies more than {num(tol, 'g')} below the reference chi2 (= -2 log L up to a constant; "
        f"{num(tol, 'g')} is 1/3800 of the 3.84 threshold, so smaller dips cannot move a CI or a "
        "classification noticeably), all 11 parameters are re-optimised from the lowest such point (TRF least "
        "squares, as the paper), that optimum becomes the reference and every profile of the test is "
        f"recomputed; repeated until no profile improves (cap {ref['T1']['max_restarts']} restarts).\n"
    )
    w(
        "| | chi2 calibration LS | chi2 polished start | chi2 final | restarts | improvement per restart "
        "(from profile of) | converged |"
    )
    w("|---|---|---|---|---|---|---|")
    for lab in labs:
        r = ref[lab]
        imp = ", ".join(f"{num(d, '.3f')} ({src})" for d, src in zip(r["improvements"], r["restart_from"], strict=True))
        w(
            f"| {lab} | {num(r['chi2_calibration'], '.3f')} | {num(r['chi2_polished'], '.3f')} | "
            f"{num(r['chi2_final'], '.3f')} | {r['n_restarts']} | {imp or '-'} | "
            f"{'yes' if r['converged'] else 'NO (cap reached)'} |"
        )
    w("")
    for lab in labs:
        r = ref[lab]
        if not r["n_restarts"]:
            continue
        x0, x1 = np.asarray(r["theta_calibration"], float), np.asarray(r["theta_final"], float)
        moved = [
            f"{n} {num(a)} -> {num(b)}"
            for n, a, b in zip(names, x0, x1, strict=True)
            if abs(np.log10(b / a)) > np.log10(2)
        ]
        c = A["calibration"][lab]
        outside = [n for j, n in enumerate(names) if not fl(c["q05"][j]) <= x1[j] <= fl(c["q95"][j])]
        w(
            f"- {lab}: chi2 lower by {num(r['chi2_calibration'] - r['chi2_final'], '.3f')} (likelihood ratio "
            f"{likelihood_ratio(r['chi2_calibration'] - r['chi2_final'])}); parameters that moved by more "
            f"than a factor 2: {'; '.join(moved) or 'none'}. Best optimum outside the posterior's 90 % interval "
            f"for: {', '.join(outside) or 'none'}"
            + (
                f". The improvement exceeds the 1-df threshold 3.84 (though not chi2_11(0.95) = 19.7). The best "
                f"optimum puts families 2 and 3 on different laws (ginf2 {num(x1[5])}, ginf3 {num(x1[8])}; beta2 "
                f"{num(x1[7])}, beta3 {num(x1[10])}), which the mirror-model posterior below cannot represent (it "
                "ties them); that posterior describes the best tied fit, and the 11-parameter model has a mode "
                f"whose peak likelihood is {likelihood_ratio(r['chi2_calibration'] - r['chi2_final'])} "
                "times higher."
                if r["chi2_calibration"] - r["chi2_final"] > 3.84 and c.get("tied")
                else f". The improvement exceeds the 1-df threshold 3.84 (though not chi2_11(0.95) = 19.7): the {lab} "
                "chains, started at the calibration optimum, never reached the best optimum (posterior kappa "
                f"{num(c['q05'][1])}-{num(c['q95'][1])} at 90 %, best optimum {num(x1[1])}), so the {lab} posterior "
                f"below describes one mode and misses one whose peak likelihood is "
                f"{likelihood_ratio(r['chi2_calibration'] - r['chi2_final'])} times higher."
                if r["chi2_calibration"] - r["chi2_final"] > 3.84
                else " (improvement below the 1-df threshold 3.84; the moves are along flat directions or onto bounds)."
            )
        )
    w("")
    changed = [
        f"{lab} {n}: {short(c0)} -> {short(prof[lab][n]['classification'])}"
        for lab in labs
        for n, c0 in ref[lab].get("first_classifications", {}).items()
        if n in prof[lab] and c0 != prof[lab][n]["classification"]
    ]
    w(
        "Classifications that the restarts changed (first round, relative to the polished start -> final): "
        + ("; ".join(changed) if changed else "none")
        + ". Every profile below has min delta chi2 >= "
        + num(min(fl(p["min_delta"]) for lab in labs for p in A["profiles"][lab]), ".2g")
        + ".\n"
    )
    post = A["posterior"]
    fits = {lab: str(A["calibration"][lab].get("fit_check", "")) for lab in labs}
    tag = {lab: (" (MISFIT)" if fits[lab].startswith("MISFIT") else "") for lab in labs}
    w(
        "| parameter | T1 profile (95 % CI) | T2 profile | joint profile | contraction T1 / T2 / joint"
        f"{tag['joint']} | KL T1 / T2 / joint{tag['joint']} (nats) |"
    )
    w("|---|---|---|---|---|---|")
    for j, n in enumerate(names):
        cells = []
        for lab in labs:
            p = prof[lab].get(n)
            cells.append("-" if p is None else f"{short(p['classification'])} {ci_text(p)}")
        con = " / ".join(num(post[lab]["contraction"][j], ".2f") for lab in labs)
        kl = " / ".join(num(post[lab]["kl"][j], ".2f") for lab in labs)
        w(f"| {n} | " + " | ".join(cells) + f" | {con} | {kl} |")
    w("")
    w(
        "Posterior predictive check of each run (`bayestissue/inference/fit_check.py`: the posterior noise sd "
        "against a noise estimate from the data alone, the residuals' lag-1 autocorrelation, the share of data in "
        "the 90 % predictive band):\n"
    )
    for lab in labs:
        w(f"- {lab}: {fits[lab] or 'not recorded'}")
    misfit = [lab for lab in labs if tag[lab]]
    if misfit:
        w(
            f"\n**{', '.join(misfit)} fits by inflating its noise (MISFIT)**: the chains converged, but on a model "
            "that cannot follow the data, so its contraction and KL above measure how tightly that wrong model is "
            "constrained, not what the data say about the tissue. Its numbers are shown for completeness and are "
            "not used as information anywhere in this report."
        )
    w("")
    counts = {
        lab: {
            c: sum(p["classification"] == c for p in A["profiles"][lab])
            for c in ("identifiable", "practically non-identifiable", "structurally non-identifiable")
        }
        for lab in labs
    }
    for lab in labs:
        ident = [p["name"] for p in A["profiles"][lab] if p["classification"] == "identifiable"]
        w(
            f"- **{lab}** identifies {len(ident)} of {len(A['profiles'][lab])} profiled parameters"
            f" ({', '.join(ident) or 'none'}); practically NI: {counts[lab]['practically non-identifiable']}, "
            f"structurally NI: {counts[lab]['structurally non-identifiable']}."
        )
    w("")
    sw = A.get("swap_symmetry_max_abs_mm")
    if sw is not None:
        w(
            "**Exchange symmetry of fibre families 2 and 3.** Their directions are mirror images about the "
            "x-z plane, so swapping (ginf2, gamma2, beta2) with (ginf3, gamma3, beta3) leaves the observed "
            f"displacement unchanged (largest difference at the T1 optimum, both tests: {num(sw, '.1e')} mm). "
            "Every likelihood here is therefore exactly bimodal in the family-2/3 parameters: a profile of beta2 "
            "(or ginf2, gamma2) can drop back towards 0 where the swapped optimum lies, which is why several "
            "T1 profiles stay open. Only the symmetric combinations are identifiable; a least-squares table that "
            "lists ginf2 and ginf3 separately reports one of two equivalent labellings. The posteriors below tie "
            "family 3 to family 2 (the mirror model), which removes the duplicate mode.\n"
        )
    w("![profiles](identifiability_profiles.png)\n")
    w("![contraction](identifiability_contraction.png)\n")
    w("![KL](identifiability_kl.png)\n")

    w("### Built-in sanity check: fibre family 1 is compressed and must stay uninformed\n")
    c0 = A["fibre1_check"][labs[0]]
    w(
        "Rule, fixed before looking at the numbers (`bayestissue.identifiability.uninformed_mc`): the draws, in "
        f"sampling order, are cut into B = {c0['n_batches']} contiguous batches; batch means give the Monte "
        "Carlo standard error se and a first-order bias of contraction c and KL (the bias of the plug-in KL, "
        "(n_bins - 1)/(2 n_eff), is removed this way). A parameter passes if |c_corrected| <= t se(c) and "
        f"KL_corrected <= t se(KL) with t = t_(B-1)(0.995) = {num(c0['t'], '.2f')} (two-sided 99 %), i.e. the "
        "draws cannot tell its marginal from the prior. The old fixed thresholds (|c| < 0.3, KL < 0.1) were "
        "chosen after seeing the results and are dropped.\n"
    )
    w(
        "| test | parameter | sensitivity at the best LS optimum (Brun delta_msqr) | contraction (tolerance) | "
        "KL nats (tolerance) | |"
    )
    w("|---|---|---|---|---|---|")
    for lab in labs:
        c = A["fibre1_check"][lab]
        for k, n in enumerate(("ginf1", "gamma1", "beta1")):
            w(
                f"| {lab} | {n} | {num(c['sensitivity'][k], '.1e')} | {num(c['contraction_corrected'][k], '+.3f')} "
                f"(+-{num(c['tol_contraction'][k], '.3f')}) | {num(c['kl_corrected'][k], '.3f')} "
                f"(<= {num(c['tol_kl'][k], '.3f')}) | {'pass' if c['uninformed'][k] else '**fail**'} |"
            )
    w("")
    for lab in labs:
        c = A["fibre1_check"][lab]
        w(
            f"- {lab} ({c['n_draws']} draws): **{'PASS' if c['pass'] else 'FAIL'}**; fibre 1 carries tension in "
            f"the calibrated test(s) for {num(100 * c['share_draws_fibre1_tension'], '.1f')} % of 200 posterior "
            "draws"
        )
    w("")
    ft = A.get("fibre1_tension", {})
    if ft:
        w(
            "Why the check can fail for physical reasons: fibre 1 is only *mostly* compressed. Largest lateral "
            "strain E22 and fibre-1 tension along each test at each best least-squares optimum (after the "
            "profile restarts):\n"
        )
        for lab in labs:
            w(
                f"- {lab} optimum: "
                + "; ".join(
                    f"{k} test max E22 = {num(v['max_E22'], '.3g')}, max tau1 = {num(v['max_tau1_kpa'], '.3g')} kPa"
                    for k, v in ft[lab].items()
                )
            )
        w(
            "\nWhere E22 > 0 (families 2 and 3 scissor towards x under the ramp and stretch the specimen "
            "laterally), fibre 1 carries load and its parameters can be informed: a physical FAIL, the "
            "assumption 'fibre 1 is compressed' is then only approximately true. Where fibre 1 carries no "
            "tension in any posterior draw the likelihood does not depend on its parameters there, so a FAIL "
            "is a sampling failure, not information: the chains have not filled a flat direction (walkers "
            "start near the least-squares point), and batch means, which see only the spread within these "
            "chains, cannot reveal that. (The local sensitivity in the table is at the best least-squares "
            "optimum, which for T1 lies in a different mode from the posterior draws, see the profile "
            "section.)\n"
        )
        for lab in labs:
            c = A["fibre1_check"][lab]
            bad = [n for k, n in enumerate(("ginf1", "gamma1", "beta1")) if not c["uninformed"][k]]
            if not bad:
                continue
            if c["share_draws_fibre1_tension"] > 0:
                why = (
                    "physical: fibre 1 is stretched (E22 > 0) in "
                    f"{num(100 * c['share_draws_fibre1_tension'], '.1f')} % of the posterior draws, so the "
                    "likelihood does depend on its parameters"
                )
            else:
                why = (
                    "a sampling failure: fibre 1 is compressed in every checked posterior draw, the likelihood is "
                    "exactly flat in its parameters there, and the deviation from the prior is the chains not "
                    "having filled the flat direction (see the calibration stage's verdict below)"
                )
            w(f"- {lab} fails on {', '.join(bad)}: {why}.")
        w("")
    w("Posterior mass piled against a bound (more than 5 % of the draws in the outer 2 % of the box):\n")
    for lab in labs:
        lo = [n for n, f in zip(names, post[lab]["at_lower"], strict=True) if f]
        hi = [n for n, f in zip(names, post[lab]["at_upper"], strict=True) if f]
        w(f"- {lab}: lower bound: {', '.join(lo) or 'none'}; upper bound: {', '.join(hi) or 'none'}")
    w("")
    w("Strongest posterior correlations (scaled box):\n")
    for lab in labs:
        w(f"- {lab}: " + "; ".join(f"{a}-{b} {num(r, '+.2f')}" for a, b, r in post[lab]["max_abs_corr"][:4]))
    w("\n![posterior marginals](posterior_marginals.png)\n")
    if (out / "posterior_corner_T1.png").is_file():
        w(
            "Corner plots: [T1](posterior_corner_T1.png), [T2](posterior_corner_T2.png), "
            "[joint](posterior_corner_joint.png); [correlations](posterior_correlation.png).\n"
        )
    w(
        "The posteriors in this report are the calibration stage's mirror-model runs (section 'Mirror-symmetric "
        "model' below: family 3's law tied to family 2's, noise sd sampled, creep-curve coordinates for T1, ramp "
        "coordinates for T2 and the joint run, "
        "fitted-mixture moves, 4 independent ensembles, automatic length up to a step cap); ginf3, gamma3 and beta3 "
        "repeat family 2's "
        "draws, so their rows above duplicate family 2's. Least squares, profiles and sensitivities use the "
        "paper's 11 free parameters. Sampler diagnostics (R-hat over independent ensembles) and verdicts:\n"
    )
    for lab in labs:
        c = A["calibration"][lab]
        rh = c["rhat"]
        w(
            f"- {lab}: {c['n_draws']} draws kept ({c.get('n_dropped', 0)} draws of stuck walkers dropped: "
            "log-likelihood more than chi2_d(1 - 1e-6)/2 below the best, d the sampled material parameters), "
            f"mean acceptance {num(c['acceptance'], '.3f')}, max R-hat "
            f"{num(max(fl(r) for r in rh), '.3f') if rh else 'n/a'}, failed solves {c['n_failed']}, "
            f"{num(c['time_mcmc_s'], '.0f')} s; {c.get('sampler', '')}."
        )
    w("")

    _mirror_section(out, w)
    return {"prof": prof, "post": post}
