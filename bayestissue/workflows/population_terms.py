"""A population in a tissue's terms: the moduli, stresses and relaxation of a typical and of a new specimen of each
group, and the groups' differences in those terms, from the two-stage hierarchical model.

For a stage-2 draw :math:`k` and a group :math:`g`, a virtual specimen takes

* its population parameters from the population (:mod:`bayestissue.inference.hierarchy`): the **typical** specimen
  :math:`\\theta = e^{m + d_g}` (on a log scale; :math:`m + d_g` otherwise), a **new** specimen
  :math:`e^{m + d_g + s\\varepsilon}`;
* its other sampled parameters (each specimen's own in the model: a Prony branch's :math:`\\gamma`, say) from one
  stage-1 draw of one specimen of group :math:`g`, the specimen chosen at random with equal weights. The model does not
  describe how those parameters vary between specimens, so the group's specimens stand for it as observed; a specimen's
  correlation between its own and its population parameters is not kept;
* that specimen's fractions, directions and dimensions.

Each virtual specimen then goes through the tissue terms of one fit (:func:`bayestissue.workflows.tissue_terms.
tissue_terms`: instantaneous and equilibrium stress, secant and tangent modulus at one nominal strain, relaxation at
full hold, relaxation times), at one strain for every group so that they compare: by default the smallest of the
specimens' largest nominal strains (inside every test's range). A group's **effect** in a tissue's terms is, per draw,
the ratio of its typical specimen's value to the reference group's (a difference in percentage points for the
relaxation), with its 90 % interval and the probability that it exceeds 1 (0).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bayestissue.workflows.tissue_terms import peak_strain, tissue_terms

__all__ = ["PopulationTerms", "population_terms"]

#: the quantity reported as a difference (percentage points), not as a ratio
DIFFERENCE = "relaxation at full hold"


def _q(x, level=0.9):
    x = x[np.isfinite(x)]
    if x.size == 0:
        return (np.nan,) * 3
    lo, med, hi = np.quantile(x, [(1 - level) / 2, 0.5, (1 + level) / 2])
    return float(med), float(lo), float(hi)


@dataclass(frozen=True)
class PopulationTerms:
    """Per group: ``typical`` and ``new`` (quantity -> values over the draws), ``units`` (quantity -> unit), the
    nominal ``strain``; ``groups`` reference first; ``n_failed`` virtual tests that did not solve (left out)."""

    strain: float
    groups: tuple[str, ...]
    units: dict
    typical: dict  # group -> quantity -> (n,) values
    new: dict
    n_failed: int = 0

    def group_rows(self) -> list[dict]:
        """Per group and quantity: the typical specimen's median and 90 % interval and a new specimen's 90 % range."""
        rows = []
        for g in self.groups:
            for name, unit in self.units.items():
                t, n = _q(self.typical[g][name]), _q(self.new[g][name])
                rows.append({"group": g, "quantity": name, "unit": unit, "typical": t[0], "typical_lower": t[1],
                             "typical_upper": t[2], "new_lower": n[1], "new_upper": n[2]})  # fmt: skip
        return rows

    def effect_rows(self) -> list[dict]:
        """Per non-reference group and quantity: ratio of the typical specimens (difference for the relaxation) with
        its 90 % interval and P(> no effect)."""
        rows, ref = [], self.groups[0]
        for g in self.groups[1:]:
            for name in self.units:
                a, b = self.typical[g][name], self.typical[ref][name]
                with np.errstate(divide="ignore", invalid="ignore"):
                    x = a - b if name == DIFFERENCE else a / b
                ok = np.isfinite(x)
                null = 0.0 if name == DIFFERENCE else 1.0
                med, lo, hi = _q(x)
                p = float(np.mean(x[ok] > null)) if ok.any() else np.nan
                rows.append({"group": g, "reference": ref, "quantity": name,
                             "kind": "difference" if name == DIFFERENCE else "ratio",
                             "unit": "percentage points" if name == DIFFERENCE else "", "median": med, "lower": lo,
                             "upper": hi, "p_positive": p})  # fmt: skip
        return rows

    def markdown(self) -> str:
        n = len(next(iter(self.typical[self.groups[0]].values())))
        failed = f"; {self.n_failed} virtual tests did not solve and are left out" if self.n_failed else ""
        lines = [f"Virtual uniaxial stretch along x to nominal strain {self.strain:.4g}, {n} stage-2 draws per group; "
                 "a specimen's other parameters from its group's stage-1 draws (docs/hierarchy.md)" + failed + ".", "",
                 "| group | quantity | unit | typical specimen [90 %] | new specimen, 90 % range |",
                 "|---|---|---|---|---|"]  # fmt: skip
        for r in self.group_rows():
            lines.append(f"| {r['group']} | {r['quantity']} | {r['unit']} | {r['typical']:.4g} "
                         f"[{r['typical_lower']:.4g}, {r['typical_upper']:.4g}] | "
                         f"{r['new_lower']:.4g} - {r['new_upper']:.4g} |")  # fmt: skip
        eff = self.effect_rows()
        if eff:
            lines += ["", "| group vs reference | quantity | effect [90 %] | P(> no effect) |", "|---|---|---|---|"]
            for r in eff:
                unit = f" {r['unit']}" if r["unit"] else ""
                lines.append(f"| {r['group']} vs {r['reference']} | {r['quantity']} | {r['kind']} {r['median']:.3g}"
                             f"{unit} [{r['lower']:.3g}, {r['upper']:.3g}] | {r['p_positive']:.2f} |")  # fmt: skip
        return "\n".join(lines) + "\n"


def population_terms(post, stage1, columns, specimens, *, strain=None, n_draws=400, seed=0) -> PopulationTerms:
    """The population's tissue terms (module docstring).

    Parameters
    ----------
    post : the stage-2 :class:`~bayestissue.inference.hierarchy.HierarchyPosterior`.
    stage1 : per specimen (in ``post.specimens`` order), its (n_i, n_sampled) stage-1 draws of every sampled
        parameter, natural units.
    columns : the population parameters' columns in those draws (``post.scale.names`` order).
    specimens : per specimen, (experiment, expand): the experiment whose tissue and dimensions the virtual test uses
        and the function mapping sampled rows to the full material parameter rows.
    strain : the nominal strain (default: the smallest of the experiments' :func:`peak_strain`).
    """
    rng = np.random.default_rng(seed)
    eps = min(peak_strain(e) for e, _ in specimens) if strain is None else float(strain)
    n_total = post.m.shape[0] * post.m.shape[1]
    pick = np.unique(np.linspace(0, n_total - 1, min(n_draws, n_total)).astype(int))
    cols = np.asarray(columns)
    typical, new, units, failed = {}, {}, {}, 0
    for g, group in enumerate(post.groups):
        members = np.flatnonzero(post.specimen_group == g)
        who = members[rng.integers(members.size, size=pick.size)]
        z_pop = {"typical": post.group_mean(g)[pick], "new": post.new_specimen(g, rng=rng)[pick]}
        for label, z in z_pop.items():
            values = {}
            for i in np.unique(who):
                rows = np.flatnonzero(who == i)
                theta = stage1[i][rng.integers(stage1[i].shape[0], size=rows.size)].copy()
                theta[:, cols] = post.scale.to_theta(z[rows])
                experiment, expand = specimens[i]
                terms = tissue_terms(experiment, expand(theta), strain=eps)
                failed += terms.n_failed
                for name, (unit, v) in terms.values.items():
                    units.setdefault(name, unit)
                    values.setdefault(name, np.full(pick.size, np.nan))[rows] = v
            (typical if label == "typical" else new)[group] = values
    return PopulationTerms(eps, tuple(post.groups), units, typical, new, failed)
