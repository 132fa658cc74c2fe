"""REPORT.md's opening summary: the answers in a few lines, each read from the same summaries as its section."""

from __future__ import annotations

from bayestissue.workflows.report.text import num

__all__ = ["summary_lines"]


def _identified(A: dict, lab: str) -> list[str]:
    return [p["name"] for p in A["profiles"][lab] if p["classification"] == "identifiable"]


def summary_lines(A: dict, B: dict, s3: dict, controls: dict | None) -> list[str]:
    """Bullets for the top of the report (``s3``: what the causes section returned; ``controls``: the controls
    summary or None)."""
    t, cp = B["tension"], B["cross_prediction"]
    labs = ("T1", "T2", "joint")
    runs = []
    for lab in labs:
        c = A["calibration"][lab]
        verdict = str(c.get("sampler", "")).split(": ", 1)[-1].split(":")[0] or "no verdict"
        fit = str(c.get("fit_check", "")).split(" ")[0].rstrip(":") or "not checked"
        runs.append(f"{lab} {verdict}, {fit}")
    L = ["## Summary\n"]
    L.append(
        "- **Posteriors** (mirror model, section 1): "
        + "; ".join(runs)
        + ". A MISFIT run fits by inflating its noise: its widths are not information about the tissue. The "
        "paper's 11-parameter posteriors do not meet the convergence verdict (`calibration_recovery.md`)."
    )
    L.append(
        "- **What each test identifies** (profile likelihoods, 95 %): "
        + "; ".join(f"{lab}: {', '.join(_identified(A, lab)) or 'nothing'}" for lab in labs)
        + "."
    )
    L.append(
        f"- **Is the T1/T2 difference real?** Yes by the rule of section 2: tension Q = {num(t['Q'], '.0f')} "
        f"(p = {num(t['p_value'], '.2g')}); the T1 posterior predicts {100 * cp['T2|T1']['coverage']:.0f} % of "
        f"the T2 data inside its 90 % band, the T2 posterior {100 * cp['T1|T2']['coverage']:.0f} % of T1's."
        if t["p_value"] < 1e-3
        else "- **Is the T1/T2 difference real?** Not by the rule of section 2 (tension p = "
        f"{num(t['p_value'], '.2g')})."
    )
    L.append(
        f"- **The paper's causes on the replicas** (section 3): rate {'supported' if s3['c1'] else 'not supported'}; "
        f"fibre angle {'supported' if s3['c2'] else 'not supported'}; specimen stiffness "
        f"{'preferred' if s3['c3_pref'] else 'not preferred'} ({'complete' if s3['c3_full'] else 'partial'})."
    )
    if controls:
        tab = controls["table"]
        neg = [r for r in tab.values() if not r["planted"]]
        planted = [r for r in tab.values() if r["planted"]]
        L.append(
            f"- **Controls** (one tissue, each cause planted, {controls['n_seeds']} noise seeds): negative control "
            f"called a difference in {sum(r['n'] - r['named'] for r in neg)} of {sum(r['n'] for r in neg)}; the "
            f"planted cause named in {sum(r['named'] for r in planted)} of {sum(r['n'] for r in planted)} planted "
            f"runs; on the data files the same rules say *{controls['data']['verdict']['kind']}*. The replicas "
            "are two different parameter sets, a difference no single planted cause reproduces."
        )
    L.append(
        "- **The data are synthetic replicas** of the paper's tests (next paragraph); the only measured curves "
        "(rubber, brain tissue) are in the last section.\n"
    )
    return L
