"""Report sections 4 and 5: the deterministic result against the posteriors; what experiment would resolve it."""

from __future__ import annotations

import numpy as np

from bayestissue.paper import PAPER_PARAMETERS as PAPER
from bayestissue.workflows.report.text import fl, num

__all__ = ["resolution_sections"]


def resolution_sections(A: dict, names, prof: dict, post: dict, R: dict, f_best, w) -> None:
    """Write sections 4 and 5 with ``w``."""
    labs = ("T1", "T2", "joint")
    w("## 4. Deterministic result against the posteriors\n")
    w(
        "Paper Table 1, our least-squares optima (paper's method, multi-start incl. the Table 1 values as "
        "starts, then improved by the profile restarts: the best optimum found) and posterior medians with "
        "90 % intervals. Flags: **B** bound active at the LS optimum or "
        "posterior piled at a bound; **F** profile not closed (practically or structurally non-identifiable); "
        "**S** skewed posterior (|skewness| > 1 in the scaled box); **M** possibly multimodal "
        "(bimodality coefficient (skew^2 + 1)/kurtosis > 0.555).\n"
    )
    for lab in ("T1", "T2"):
        c = dict(A["calibration"][lab])
        c["ls_x"] = A["profile_reference"][lab]["theta_final"]
        c["ls_active"] = A["profile_reference"][lab]["at_bound_final"]
        w(f"#### {lab}\n")
        w("| parameter | paper | least squares | posterior median [90 %] | flags |")
        w("|---|---|---|---|---|")
        for j, n in enumerate(names):
            flags = []
            if c["ls_active"][j] != 0 or post[lab]["at_lower"][j] or post[lab]["at_upper"][j]:
                flags.append("B")
            p = prof[lab].get(n)
            if p is not None and p["classification"] != "identifiable":
                flags.append("F")
            sk, ku = fl(c["skew"][j]), fl(c["kurt"][j])
            if abs(sk) > 1:
                flags.append("S")
            if ku > 0 and (sk**2 + 1) / ku > 0.555:
                flags.append("M")
            w(
                f"| {n} | {num(PAPER[lab][j])} | {num(c['ls_x'][j])} | {num(c['median'][j])} "
                f"[{num(c['q05'][j])}, {num(c['q95'][j])}] | {' '.join(flags)} |"
            )
        nmis = sum(
            1
            for j in range(len(names))
            if c["ls_active"][j] != 0
            or (prof[lab].get(names[j]) or {}).get("classification", "identifiable") != "identifiable"
        )
        w(
            f"\n{lab}: the point estimate misleads (bound active or profile not closed) for {nmis} of "
            f"{len(names)} parameters"
            + (
                " (for fibre families 2 and 3 the open profiles are the exchange symmetry: the swapped labelling "
                "fits equally well)"
                if lab == "T1"
                else ""
            )
            + ".\n"
        )
    w(
        "The least-squares chi2 of each start (paper initial guess, Latin hypercube, Table 1 T1 and T2 values): "
        + "; ".join(
            f"{lab}: " + ", ".join(num(x, ".4g") for x in A["calibration"][lab]["ls_start_chi2"]) for lab in labs
        )
        + ". Distinct optima with different chi2 are the multimodality the paper's "
        "single start could not see.\n"
    )

    # ---------------------------------------------------------------- 5
    w("## 5. What experiment would resolve it\n")
    w(
        "1. **Both protocols on the same specimen** (a creep hold followed by a ramp, or T1 then T2 after "
        "recovery): it removes cause 3 by design; any remaining tension is model error."
    )
    widths = {}
    for f, pr in R["profiles"].items():
        c = pr.get("ci_beta2")
        if c and c[0] is not None and c[1] is not None:
            widths[float(f)] = float(np.log10(c[1] / c[0]))
    if widths:
        fw = min(widths, key=widths.get)
        txt = (
            f"the relaxation rate of the simulated T1-like tissue is pinned best at f = {num(fw, 'g')} x the T2 "
            f"rate (ramp of {num(612 / fw, '.0f')} s; 95 % profile interval of beta2 spanning "
            f"{num(widths[fw], '.2f')} decades"
            + (f", against {num(widths[1.0], '.2f')} decades at T2's own rate" if 1.0 in widths else "")
            + f"); the linearised analysis favours f = {num(f_best, 'g')}. Ramps much faster than T2's lose them."
        )
    else:
        txt = f"the linearised analysis favours f = {num(f_best, 'g')} x the T2 rate."
    w("2. **A ramp (or creep) whose time scale matches the fibre relaxation time** (1/beta of 20-60 min in T1): " + txt)
    w(
        "3. **Stereology of the tested specimens themselves** (directions and fractions measured on each piece): "
        "removes cause 2, and the cut posterior shows how much that uncertainty widens each parameter."
    )
    w(
        "4. **Load the specimen along a second axis** (y): fibre family 1 is compressed in (almost) every x "
        "test, so ginf1, gamma1, beta1 cannot be learnt from these tests (sanity check above).\n"
    )
