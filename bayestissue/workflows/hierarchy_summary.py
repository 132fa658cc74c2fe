"""What the hierarchical model says, as tables: group effects, population sds, each specimen shrunken beside its own
fit, the predictive range of a new specimen; written as ``hierarchy_summary.md`` / ``.csv`` and ``hierarchy.nc``.

On a log scale (a positive parameter) a group effect is reported as the ratio :math:`e^{d}` of a typical specimen
of the group to one of the reference group, and the population sd :math:`s` as it is (for small :math:`s` about the
coefficient of variation between specimens); otherwise as the difference :math:`d` in the parameter's unit.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

__all__ = ["effect_rows", "specimen_rows", "group_rows", "hierarchy_markdown", "write_hierarchy"]

#: the central interval reported for every population quantity
INTERVAL = 0.9


def _q(x, level=INTERVAL):
    lo, med, hi = np.quantile(x, [(1 - level) / 2, 0.5, (1 + level) / 2])
    return float(med), float(lo), float(hi)


def effect_rows(post) -> list[dict]:
    """Per non-reference group and parameter: the effect (ratio on a log scale, else difference) with its 90 %
    interval and the probability that it is positive (d > 0)."""
    rows = []
    d = post.flat("d")
    for g in range(1, len(post.groups)):
        for j, n in enumerate(post.scale.names):
            x = d[:, g - 1, j]
            v = np.exp(x) if post.scale.log[j] else x
            med, lo, hi = _q(v)
            rows.append({"group": post.groups[g], "reference": post.groups[0], "parameter": n,
                         "kind": "ratio" if post.scale.log[j] else "difference", "median": med, "lower": lo,
                         "upper": hi, "p_positive": float(np.mean(x > 0)),
                         "n_group": post.n_in_group(g), "n_reference": post.n_in_group(0)})  # fmt: skip
    return rows


def group_rows(post, seed: int = 0) -> list[dict]:
    """Per group and parameter: the typical specimen (exp(m + d_g) on a log scale) and the 90 % predictive range of
    a new specimen, in natural units; and the population sd (shared by the groups)."""
    rows = []
    s = post.flat("s")
    for g, name in enumerate(post.groups):
        typ = post.scale.to_theta(post.group_mean(g))
        new = post.scale.to_theta(post.new_specimen(g, rng=seed + g))
        for j, n in enumerate(post.scale.names):
            t, n_ = _q(typ[:, j]), _q(new[:, j])
            sd = _q(s[:, j])
            rows.append({"group": name, "parameter": n, "n_specimens": post.n_in_group(g), "typical": t[0],
                         "typical_lower": t[1], "typical_upper": t[2], "new_lower": n_[1], "new_upper": n_[2],
                         "pop_sd": sd[0], "pop_sd_lower": sd[1], "pop_sd_upper": sd[2],
                         "sd_scale": "log" if post.scale.log[j] else "linear"})  # fmt: skip
    return rows


def specimen_rows(post, stage1) -> list[dict]:
    """Per specimen and parameter: its own fit (stage 1) and its shrunken estimate (stage 2), medians and 90 %
    intervals in natural units."""
    rows = []
    z = post.flat("z")
    for i, name in enumerate(post.specimens):
        for j, n in enumerate(post.scale.names):
            own = _q(stage1[i][:, j])
            shr = _q(post.scale.to_theta(z[:, i, j : j + 1])[:, 0])
            rows.append({"specimen": name, "group": post.groups[post.specimen_group[i]], "parameter": n,
                         "own": own[0], "own_lower": own[1], "own_upper": own[2], "shrunk": shr[0],
                         "shrunk_lower": shr[1], "shrunk_upper": shr[2],
                         "acceptance": float(post.acceptance[i])})  # fmt: skip
    return rows


def hierarchy_markdown(outcome) -> str:
    post = outcome.posterior
    lines = [f"# Population of {len(post.specimens)} specimens in {len(post.groups)} groups (two-stage model)", ""]
    lines.append(f"Stage 2: {outcome.diagnostics['verdict']}. Reference group: {post.groups[0]}.")
    for n in outcome.notes:
        lines.append(f"- design: {n}")
    lines.append(f"- priors: {post.prior_text()}")
    lines += ["", "## Group effects (90 % intervals)", ""]
    eff = effect_rows(post)
    if eff:
        lines += ["| group vs reference | parameter | effect | 90 % interval | P(> no effect) | specimens |",
                  "|---|---|---|---|---|---|"]  # fmt: skip
        for r in eff:
            what = "ratio" if r["kind"] == "ratio" else "difference"
            lines.append(f"| {r['group']} vs {r['reference']} | {r['parameter']} | {what} {r['median']:.3g} | "
                         f"[{r['lower']:.3g}, {r['upper']:.3g}] | {r['p_positive']:.2f} | "
                         f"{r['n_group']} vs {r['n_reference']} |")  # fmt: skip
    else:
        lines.append("One group: no effects to estimate.")
    lines += ["", "## Groups: typical specimen, a new specimen's range, population sd", "",
              "| group | parameter | typical specimen [90 %] | new specimen, 90 % range | population sd [90 %] |",
              "|---|---|---|---|---|"]  # fmt: skip
    for r in group_rows(post):
        unit = " (log scale)" if r["sd_scale"] == "log" else ""
        lines.append(f"| {r['group']} ({r['n_specimens']}) | {r['parameter']} | {r['typical']:.4g} "
                     f"[{r['typical_lower']:.4g}, {r['typical_upper']:.4g}] | "
                     f"{r['new_lower']:.4g} - {r['new_upper']:.4g} | {r['pop_sd']:.3g} "
                     f"[{r['pop_sd_lower']:.3g}, {r['pop_sd_upper']:.3g}]{unit} |")  # fmt: skip
    if getattr(outcome, "tissue_terms", None) is not None:
        lines += ["", "## Groups in a tissue's terms", "", outcome.tissue_terms.markdown().rstrip()]
    lines += ["", "## Specimens: own fit and shrunken estimate", "",
              "| specimen | group | parameter | own fit [90 %] | shrunken [90 %] | stage-2 acceptance |",
              "|---|---|---|---|---|---|"]  # fmt: skip
    for r in specimen_rows(post, outcome.stage1):
        lines.append(f"| {r['specimen']} | {r['group']} | {r['parameter']} | {r['own']:.4g} "
                     f"[{r['own_lower']:.4g}, {r['own_upper']:.4g}] | {r['shrunk']:.4g} "
                     f"[{r['shrunk_lower']:.4g}, {r['shrunk_upper']:.4g}] | {r['acceptance']:.2f} |")  # fmt: skip
    lines += ["", "## Stage 1 (each specimen alone)", "", "| specimen | verdict | predictive check |", "|---|---|---|"]
    for name, v, c in zip(post.specimens, outcome.verdicts, outcome.fit_checks, strict=True):
        lines.append(f"| {name} | {v.split(':')[0]} | {c.split(' (')[0]} |")
    if all(s.experiments for s in outcome.spec.specimens):
        lines += ["", "Each specimen's own run (its verdict in full, figures): specimens/<name>/summary.md."]
    return "\n".join(lines) + "\n"


def write_hierarchy(outcome, out_dir, *, figures: bool = True, stem: str = "hierarchy", draws: bool = True) -> str:
    """``<stem>_summary.md``, ``<stem>_summary.csv`` (the effects and groups rows), with ``draws`` ``<stem>.nc``
    (the stage-2 draws as arviz InferenceData) and, with ``figures``, ``<stem>.png``; returns the markdown."""
    from bayestissue.io.tables import write_table

    out = Path(out_dir)
    post = outcome.posterior
    text = hierarchy_markdown(outcome)
    (out / f"{stem}_summary.md").write_text(text)
    rows = [
        {
            "quantity": "effect",
            "group": r["group"],
            "parameter": r["parameter"],
            "median": r["median"],
            "lower": r["lower"],
            "upper": r["upper"],
            "p_positive": r["p_positive"],
        }
        for r in effect_rows(post)
    ]
    groups = group_rows(post)
    for r in groups:
        rows.append(
            {
                "quantity": "typical",
                "group": r["group"],
                "parameter": r["parameter"],
                "median": r["typical"],
                "lower": r["typical_lower"],
                "upper": r["typical_upper"],
                "p_positive": np.nan,
            }
        )
        rows.append(
            {
                "quantity": "new_specimen",
                "group": r["group"],
                "parameter": r["parameter"],
                "median": np.nan,
                "lower": r["new_lower"],
                "upper": r["new_upper"],
                "p_positive": np.nan,
            }
        )
    for r in groups[: len(post.scale.names)]:  # the population sd, shared by the groups: the reference group's rows
        rows.append({"quantity": "population_sd", "group": "all", "parameter": r["parameter"], "median": r["pop_sd"],
                     "lower": r["pop_sd_lower"], "upper": r["pop_sd_upper"], "p_positive": np.nan})  # fmt: skip
    terms = getattr(outcome, "tissue_terms", None)
    if terms is not None:
        for r in terms.group_rows():
            for what, med, lo, hi in (
                ("tissue_typical", r["typical"], r["typical_lower"], r["typical_upper"]),
                ("tissue_new_specimen", np.nan, r["new_lower"], r["new_upper"]),
            ):
                rows.append({"quantity": what, "group": r["group"], "parameter": f"{r['quantity']} ({r['unit']})",
                             "median": med, "lower": lo, "upper": hi, "p_positive": np.nan})  # fmt: skip
        for r in terms.effect_rows():
            rows.append({"quantity": f"tissue_effect_{r['kind']}", "group": r["group"], "parameter": r["quantity"],
                         "median": r["median"], "lower": r["lower"], "upper": r["upper"],
                         "p_positive": r["p_positive"]})  # fmt: skip
    cols = {k: np.array([r[k] for r in rows]) for k in rows[0]}
    write_table(out / f"{stem}_summary.csv", cols, meta={"model": "two-stage hierarchical (Lunn et al. 2013)",
                                                           "reference_group": post.groups[0],
                                                           "level": str(INTERVAL), "priors": post.prior_text(),
                                                           **({"tissue_strain": f"{terms.strain:.6g}"}
                                                              if terms is not None else {})})  # fmt: skip
    if draws:
        _write_draws(post, outcome.diagnostics["verdict"], out / f"{stem}.nc")
    if figures:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        from bayestissue.plotting.hierarchy import hierarchy_figure

        fig = hierarchy_figure(post, outcome.stage1, truth=outcome.generating)
        fig.savefig(out / f"{stem}.png", dpi=110)
        plt.close(fig)
    return text


def _write_draws(post, verdict: str, path) -> None:
    import arviz as az

    dims = {"d": ["group", "parameter"], "m": ["parameter"], "s": ["parameter"], "z": ["specimen", "parameter"]}
    coords = {"parameter": list(post.scale.names), "group": list(post.groups[1:]), "specimen": list(post.specimens)}
    scales = ", ".join(
        f"{n}: {'log' if lg else 'linear'}" for n, lg in zip(post.scale.names, post.scale.log, strict=True)
    )
    attrs = {"scale": scales, "reference_group": post.groups[0], "verdict": verdict, "priors": post.prior_text()}
    idata = az.from_dict(posterior={"m": post.m, "d": post.d, "s": post.s, "z": post.z}, dims=dims, coords=coords,
                         attrs=attrs)  # fmt: skip
    idata.to_netcdf(path)
