"""Report section 3: the paper's three candidate causes, each tested, and which the evidence supports."""

from __future__ import annotations

import numpy as np

from bayestissue.workflows.discrepancy import VISC
from bayestissue.workflows.report.text import fl, num, short

__all__ = ["causes_section"]


def causes_section(B: dict, names, t: dict, bc, w) -> dict:
    """Write section 3 with ``w``; returns what sections 5 and the limitations read (rates, best rate, cut)."""
    w("## 3. The paper's three candidate causes\n")
    R = B["rates"]
    w("### Cause 1: the faster loading in T2 hid the fibre viscosity\n")
    w(
        "T2-like ramps (same 240 s pre-stress hold, same peak stress, same number of data points) at rate "
        "factors f times the T2 rate, data simulated from the T1 posterior (its highest-likelihood draw) plus "
        "noise of 0.02 mm. Gauss-Newton sd of the log viscosity parameters, and profile classifications of "
        "beta2, beta3 at selected rates:\n"
    )
    w(
        "| rate factor f | ramp time (s) | sd log gamma2 | sd log beta2 | sd log gamma3 | sd log beta3 | "
        "beta2 profile (95 % CI, 1/s) | beta3 profile (95 % CI, 1/s) | optimum restarts (improvements) |"
    )
    w("|---|---|---|---|---|---|---|---|---|")
    ident_rates, open_fast = [], []
    for i, f in enumerate(R["factors"]):
        pr = R["profiles"].get(str(float(f))) or R["profiles"].get(str(f)) or {}
        cells = [num(R["se_log"][p][i], ".2g") for p in VISC]
        b2, b3 = pr.get("beta2", ""), pr.get("beta3", "")
        if pr and b2 == "identifiable" and b3 == "identifiable":
            ident_rates.append(f)
        if pr and f >= 1 and b2 != "identifiable" and b3 != "identifiable":
            open_fast.append(f)

        def ci(key, pr=pr):
            c = pr.get(key)
            if not c:
                return ""
            return f" [{num(c[0]) if c[0] is not None else 'open'}, {num(c[1]) if c[1] is not None else 'open'}]"

        w(
            f"| {num(f, 'g')} | {num(612 / f, '.0f')} | " + " | ".join(cells) + f" | {short(b2) or '-'}"
            f"{ci('ci_beta2')} | {short(b3) or '-'}{ci('ci_beta3')} | "
            + (
                f"{pr['n_restarts']} ({', '.join(num(d, '.3g') for d in pr['improvements']) or '-'})"
                + ("" if pr.get("converged", True) else " **cap reached**")
                if "n_restarts" in pr
                else "-"
            )
            + " |"
        )
    w(
        "\nProfiles relative to the best optimum of each simulated data set (restart rule of section 1; the "
        "improvements are in chi2). Where the cap was reached a profile still found a lower chi2 in the last "
        "round, so that row's intervals are relative to the best optimum found, not a verified global one.\n"
    )
    se_b = np.array([min(fl(R["se_log"]["beta2"][i]), fl(R["se_log"]["beta3"][i])) for i in range(len(R["factors"]))])
    f_best = R["factors"][int(np.nanargmin(se_b))]
    p1 = R["profiles"].get("1.0", {})
    c1 = bool(p1) and all(p1.get(p) != "identifiable" for p in ("beta2", "beta3"))
    w("")
    tr = R["truth"]
    w(
        f"Truth of the simulated designs (T1 posterior draw): beta2 = {num(tr[7])} 1/s, beta3 = {num(tr[10])} 1/s "
        f"(relaxation times {num(1 / tr[7], '.0f')} s and {num(1 / tr[10], '.0f')} s), gamma2 = {num(tr[6])}, "
        f"gamma3 = {num(tr[9])}. Both relaxation rates have profiles closed on both sides at f = "
        f"{', '.join(num(f, 'g') for f in ident_rates) or 'none of the profiled rates'}; open (not identifiable) "
        f"at the faster rates f = {', '.join(num(f, 'g') for f in open_fast) or 'none'}. The linearised sd is "
        f"smallest at f = {num(f_best, 'g')}; where it disagrees with the profiles (e.g. huge at f = 1 while the "
        "profile closes), the near-symmetry of fibre families 2 and 3 makes the Gauss-Newton picture unreliable "
        "and the profiles are the ones to believe."
    )
    cis1 = [p1.get(k) for k in ("ci_beta2", "ci_beta3")]
    w1 = (
        num(max(np.log10(c[1] / c[0]) for c in cis1), ".1f")
        if all(c and c[0] is not None and c[1] is not None for c in cis1)
        else "n/a"
    )
    if c1:
        w(
            "\n**Cause 1 verdict: supported** for the viscosity parameters: a ramp at T2's rate cannot identify "
            "the fibre relaxation rates even when the tissue has T1's slow viscosity, so T2's estimates of beta "
            "and gamma (at their bounds) say nothing about the viscosity. It does not explain the elastic "
            "parameters: a joint fit would then reconcile both tests, which the tension above rules out.\n"
        )
    else:
        w(
            "\n**Cause 1 verdict: not supported.** Data simulated with T1's slow fibre viscosity at T2's rate "
            f"still give closed profiles for beta2 and beta3 (95 % intervals spanning {w1} decades, containing both "
            "true rates): a T2 test on tissue with T1's viscosity would have seen a slow relaxation. The T2 "
            "posterior instead puts beta at the upper bound and gamma at the lower bound (fast, "
            "weak relaxation), which the T1 posterior predicts badly (cross-prediction above): the T2 data show "
            "less viscous fibres, not hidden viscosity. Faster loading does hide the viscosity, but only from "
            f"f = {num(min(open_fast), 'g') if open_fast else 'n/a'} x the T2 rate on.\n"
        )
    w("![rates](t1_vs_t2_rates.png)\n")

    w("### Cause 2: fibre directions and volume fractions from a small microscopy sample\n")
    C = B.get("cut")
    sp = B["specimen"]
    if C:
        w(
            f"The stereology bootstrap table has {C['n_replicates_table']} replicates (fibre 2/3 half-angle "
            f"{num(C['half_angle_mean'], '.1f')} +- {num(C['half_angle_sd'], '.2f')} degrees, sd of the fibre "
            f"volume fractions {', '.join(num(x, '.3f') for x in C['phi_fibre_sd'])}). A posterior was run per "
            f"replicate ({C['n_used']} replicates, mirror model, the calibration stage's sampler: one ensemble "
            f"of {C.get('steps', '?')} steps after {' x '.join(map(str, C.get('adapt', ['?'])))} mixture "
            f"adaptation steps, {C['T1'].get('coordinates', '?')} coordinates for T1 and "
            f"{C['T2'].get('coordinates', '?')} for T2, warm-started at the calibration's least-squares optimum; "
            f"mean acceptance T1 {num(C['T1'].get('acceptance'), '.3f')}, T2 {num(C['T2'].get('acceptance'), '.3f')}) "
            "and pooled (cut posterior). 'One replicate' is the mean width of the per-replicate posteriors, 'cut' "
            "the width of their pool, 'calibration' the calibration stage's posterior (nominal stereology, four "
            "ensembles, convergence verdict above). One ensemble per replicate gives no R-hat: the replicate "
            "widths are checked against the calibration widths instead.\n"
        )
        w(
            "| parameter | T1 calibration | T1 one replicate | T1 cut | T2 calibration | T2 one replicate | T2 cut | "
            "BC(T1, T2) calibration | BC cut |"
        )
        w("|---|---|---|---|---|---|---|---|---|")
        for j, n in enumerate(names):
            w(
                f"| {n} | {num(C['T1']['base_width'][j], '.2f')} | {num(C['T1']['within_width'][j], '.2f')} | "
                f"{num(C['T1']['cut_width'][j], '.2f')} | {num(C['T2']['base_width'][j], '.2f')} | "
                f"{num(C['T2']['within_width'][j], '.2f')} | {num(C['T2']['cut_width'][j], '.2f')} | "
                f"{num(bc[j], '.2f')} | {num(C['bc_pooled'][j], '.2f')} |"
            )
        w(
            "\n(widths: central 90 % intervals in the scaled box; family 3 repeats family 2 in the mirror model.) "
            "Least-squares optimum spread across "
            "replicates (scaled box): T1 "
            + ", ".join(f"{n} {num(x, '.2f')}" for n, x in zip(names, C["T1"]["ls_u_spread"], strict=True))
            + ".\n"
        )
        gain = np.nanmean(np.array([fl(x) for x in C["bc_pooled"]]) - np.array([fl(x) for x in bc]))
        w(f"Mean change of the T1/T2 overlap when the stereological uncertainty is carried: {num(gain, '+.2f')}.")
    else:
        gain = float("nan")
        w("No stereology replicate table (`data/stereology_replicates.csv`) was found: the cut posterior was skipped.")
    a = sp["angle"]
    w(
        f"\nHow far would the directions have to differ? A joint model with T2's fibre 2/3 half-angle free "
        f"(T1 keeps 20.05 degrees): alpha_T2 = **{num(a['estimate'], '.1f')} degrees**, chi2 drops by "
        f"{num(a['delta_chi2'], '.1f')} (likelihood ratio p = {num(a['lr_p'], '.2g')}, delta BIC "
        f"{num(a['delta_bic'], '.1f')}), remaining tension Q = {num(a['remaining_tension']['Q'], '.1f')} "
        f"(p = {num(a['remaining_tension']['p_value'], '.2g')})"
        + (
            f"; that is {num(a['z_vs_stereology'], '.1f')} stereological sd from the measured angle"
            if "z_vs_stereology" in a
            else ""
        )
        + "."
    )
    c2 = (a["remaining_tension"]["p_value"] > 0.05 and abs(fl(a.get("z_vs_stereology", 0))) < 3) or (
        np.isfinite(gain) and gain > 0.3
    )
    w(
        f"\n**Cause 2 verdict:** {'supported' if c2 else 'not supported'} (rule: the free angle removes the "
        "tension with an angle within 3 stereological sd, or carrying the replicates raises the mean overlap by "
        "more than 0.3).\n"
    )
    if C:
        w("![stereology widths](t1_vs_t2_stereology_widths.png)\n")
        w("![cut marginals](t1_vs_t2_cut_marginals.png)\n")

    w("### Cause 3: the specimens came from different parts of the body\n")
    s = sp["scale"]
    w(
        f"A joint model with a stiffness scale s on every modulus (mu, kappa, ginf_k) of the T2 specimen: "
        f"s = **{num(s['estimate'], '.3g')}**, chi2 drops by {num(s['delta_chi2'], '.1f')} (likelihood ratio "
        f"p = {num(s['lr_p'], '.2g')}, delta BIC = {num(s['delta_bic'], '.1f')}: positive favours the scale), "
        f"remaining tension against the separate fits Q = {num(s['remaining_tension']['Q'], '.1f')} on "
        f"{s['remaining_tension']['df']} df (p = {num(s['remaining_tension']['p_value'], '.2g')})."
    )
    frac = s["delta_chi2"] / max(t["Q"], 1e-9)
    c3_pref = s["delta_bic"] > 10
    c3_full = s["remaining_tension"]["p_value"] > 0.05
    w(
        f"\n**Cause 3 verdict:** the data {'prefer' if c3_pref else 'do not prefer'} a specimen-level "
        f"stiffness (delta BIC > 10); it removes {100 * frac:.0f} % of the tension"
        + (" and leaves none." if c3_full else ", so a single scale factor is not the whole difference.")
        + "\n"
    )

    w("### Which cause does the evidence support?\n")
    w(
        f"- cause 1 (rate): {'yes for the viscosity parameters' if c1 else 'no'}; "
        f"cause 2 (directions/fractions): {'yes' if c2 else 'no'}; cause 3 (specimen, one stiffness scale): "
        f"{'preferred' if c3_pref else 'not preferred'}, {'complete' if c3_full else 'partial'}."
    )
    w(
        "- The tension is far beyond what the noise allows and survives every single-mechanism model tested "
        "here unless stated otherwise above: the two curves need different material behaviour (different "
        "relative stiffness of matrix and fibres and different fibre viscosity), i.e. the specimens differ "
        "by more than a common stiffness factor or a fibre angle within the stereological uncertainty. In these "
        "synthetic data that is exactly how they were generated (two different parameter sets).\n"
    )
    return {"R": R, "f_best": f_best, "C": C}
