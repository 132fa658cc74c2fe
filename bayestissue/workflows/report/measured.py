"""REPORT.md section: the matrix on real measured data (``measured_summary.json`` of studies/measured_data.py)."""

from __future__ import annotations

import json
from pathlib import Path

__all__ = ["measured_section"]


def _q(v) -> str:
    return f"{v[0]:.3g} [{v[1]:.3g}, {v[2]:.3g}]"


def measured_section(out: Path, w) -> None:
    """Write the section if ``out/measured_summary.json`` exists (the stage may not have run)."""
    path = Path(out) / "measured_summary.json"
    if not path.exists():
        return
    S = json.loads(path.read_text())
    cases = {c["name"]: c for c in S["cases"]}
    w("## Real measured data: the Mooney-Rivlin matrix on rubber and brain tissue\n")
    w(
        f"From `measured_summary.json` (`studies/measured_data.py`, mode `{S['mode']}`). The only measured curves in "
        "this report: Treloar's 1944 rubber and Budday et al.'s 2017 human brain tissue in uniaxial tension "
        "(data/measured/, sources and licence in data/README.md), as stretch-controlled, matrix-only experiments "
        "(nominal stress observed, kPa). The paper's slug tissue has no public measured curve.\n"
    )
    w("| case | stretch | engine | mu (kPa) | kappa (kPa) | noise sd (kPa) | closed form mu / kappa | verdict |")
    w("|---|---|---|---|---|---|---|---|")
    for c in S["cases"]:
        cf, p = c["closed_form"], c["posterior"]
        w(
            f"| {c['material']} | {c['stretch'][0]:.3g}-{c['stretch'][1]:.3g} ({c['n']}) | {c['engine']} | "
            f"{_q(p['mu'])} | {_q(p['kappa'])} | {_q(p['sd'])} | {cf['mu']:.3g} / {cf['kappa']:.3g} | "
            f"{'CONVERGED' if c['converged'] else 'NOT CONVERGED'} |"
        )
    w("")
    a, b = cases.get("treloar_to_3"), cases.get("treloar_all")
    if a and b:
        w(
            f"- **Where the model cannot follow the data.** Up to stretch {a['stretch'][1]:.3g} the Mooney-Rivlin "
            f"matrix fits Treloar's rubber with a noise sd of {a['posterior']['sd'][0]:.3g} kPa (least-squares rms "
            f"{a['least_squares']['rms']:.3g} kPa). Over the whole range to "
            f"{b['stretch'][1]:.3g} it cannot follow the upturn above a stretch of about 5-6 (finite chain "
            f"extensibility, which the law does not have): the noise sd absorbs the misfit, "
            f"{b['posterior']['sd'][0]:.3g} kPa, {b['posterior']['sd'][0] / a['posterior']['sd'][0]:.0f} times "
            "larger, and the residuals are systematic (figure `measured_treloar_all.png`), not noise. A posterior "
            "that is CONVERGED on a misspecified model is still a posterior of the wrong model: its intervals "
            "(mu, kappa) are conditional on the law, and here kappa sits at the lower end of its box, where the "
            f"unconstrained closed-form fit puts it below zero ({b['closed_form']['kappa']:.3g} kPa).\n"
        )
        fits = [a["closed_form"], a["least_squares"]]
        inside = all(a["posterior"][k][1] <= f[k] <= a["posterior"][k][2] for f in fits for k in ("mu", "kappa"))
        w(
            f"- **Independent check.** The closed-form incompressible least-squares fit over stretch <= "
            f"{a['stretch'][1]:.3g} gives mu {a['closed_form']['mu']:.4g}, kappa {a['closed_form']['kappa']:.4g} "
            f"kPa; our compressible model's least squares (K = 2 GPa) gives {a['least_squares']['mu']:.4g}, "
            f"{a['least_squares']['kappa']:.4g} kPa; "
            + ("both inside" if inside else "not both inside")
            + " the posterior's 90 % intervals.\n"
        )
    brains = [c for c in S["cases"] if c["name"].startswith("brain")]
    if brains:
        w(
            "- **Brain tissue.** At stretches up to 1.1 only the initial modulus (about 3(mu + kappa)) is informed: "
            "the posteriors spread along an L in (log mu, log kappa) to both ends of the box, which emcee's "
            "ensembles did not cross (NOT CONVERGED with stretch and mixture moves); the nested engine converged. "
            + "; ".join(
                f"{c['material']}: mu + kappa least squares "
                f"{c['least_squares']['mu'] + c['least_squares']['kappa']:.3g} kPa, noise sd "
                f"{c['posterior']['sd'][0]:.2g} kPa"
                for c in brains
            )
            + ". Both curves stiffen faster than the law can (residuals systematic, largest at the last points: "
            "figures `measured_brain_*.png`), so the noise sd again carries model error; the closed-form fit of the "
            "basal ganglia has kappa < 0, outside any box of a positive modulus.\n"
        )
