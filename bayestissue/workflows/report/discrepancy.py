"""Report section 2: is the T1/T2 difference statistically real (tension, overlap, cross-prediction)?"""

from __future__ import annotations

from pathlib import Path

from bayestissue.workflows.report.text import num

__all__ = ["discrepancy_section"]


def discrepancy_section(B: dict, names, out: Path, w) -> dict:
    """Write section 2 with ``w``; returns the tension and overlap summaries section 3 reads."""
    w("## 2. Is the T1/T2 difference statistically real?\n")
    t = B["tension"]
    te = B["tension_effective"]
    cp = B["cross_prediction"]
    w(
        f"- **Tension**: chi2_joint - chi2_T1 - chi2_T2 = {num(B['chi2']['joint'], '.1f')} - "
        f"{num(B['chi2']['T1'], '.1f')} - {num(B['chi2']['T2'], '.1f')} = **Q = {num(t['Q'], '.1f')}** against "
        f"chi-square({t['df']}): p = {num(t['p_value'], '.2g')} (with the {te['df']} jointly informed "
        f"directions as df: p = {num(te['p_value'], '.2g')}). Of the joint chi2, T1 contributes "
        f"{num(B['chi2_joint_parts'][0], '.1f')} and T2 {num(B['chi2_joint_parts'][1], '.1f')}."
    )
    w(
        f"- **Cross-prediction** (share of data inside the 90 % posterior-predictive band): T2 data from the T1 "
        f"posterior {100 * cp['T2|T1']['coverage']:.0f} %, T1 data from the T2 posterior "
        f"{100 * cp['T1|T2']['coverage']:.0f} % (in-sample reference: T1 {100 * cp['T1|T1']['coverage']:.0f} %, "
        f"T2 {100 * cp['T2|T2']['coverage']:.0f} %). Exact out-of-sample log predictive density: "
        f"elpd(T2 | T1) = {num(cp['T2|T1']['elpd'], '.4g')}, elpd(T1 | T2) = {num(cp['T1|T2']['elpd'], '.4g')}, "
        f"against in-sample {num(cp['T2|T2']['elpd'], '.4g')} and {num(cp['T1|T1']['elpd'], '.4g')}."
    )
    lo = B["loo_psis"]
    w(
        f"- **Leave-one-experiment-out by PSIS** from the joint posterior: Pareto k-hat = "
        f"{num(lo['T1']['khat'], '.3g')} (leave T1 out) and {num(lo['T2']['khat'], '.3g')} (leave T2 out), far "
        "above 0.7: importance sampling cannot turn the joint posterior into a single-test posterior because "
        "the two are nearly disjoint. PSIS-LOO is therefore *not valid* here; the exact refits (the separate "
        "posteriors, cross-prediction above) replace it."
    )
    ang = B["principal_angles_deg"]
    w(
        f"- **Principal angles** between the log-parameter directions T1 informs ({B['n_informed']['T1']} with "
        f"s > 1) and those T2 informs ({B['n_informed']['T2']}): {', '.join(num(a, '.0f') for a in ang)} degrees. "
        "An angle near 0 is a combination both tests measure (there they can contradict each other); angles "
        "near 90 are combinations only one test sees."
    )
    bc = B["bhattacharyya"]
    w(
        "- **Overlap** of the separate marginals (Bhattacharyya coefficient, 1 = identical, 0 = disjoint): "
        + ", ".join(f"{n} {num(b, '.2f')}" for n, b in zip(names, bc, strict=True))
        + "."
    )
    real = t["p_value"] < 1e-3 and cp["T2|T1"]["coverage"] < 0.5 and cp["T1|T2"]["coverage"] < 0.5
    w(
        f"\n**Verdict:** the difference is {'statistically real' if real else 'not established'} "
        f"(rule: tension p < 0.001 and both cross-prediction coverages below 50 %). "
        + (
            "One parameter set cannot describe both curves within the noise; it is not an artefact of "
            "non-identifiability (which would let a joint fit reproduce both)."
            if real
            else ""
        )
        + "\n"
    )
    w("![marginals T1 vs T2](t1_vs_t2_marginals.png)\n")
    if (out / "t1_vs_t2_corner.png").is_file():
        w("![corner T1 vs T2](t1_vs_t2_corner.png)\n")
    w("![cross-prediction](t1_vs_t2_cross_prediction.png)\n")
    return {"t": t, "bc": bc}
