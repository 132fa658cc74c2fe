"""The specimens stage's record: each case of the hierarchical model (:mod:`bayestissue.inference.hierarchy`) as
numbers the report reads, and the function that builds one case from a stage-2 posterior.

Keys join a group or specimen and a parameter with ``":"`` (``"incubated:k1_1"``); every triple is (median, 5 %,
95 %) in natural units unless said otherwise. Effects and population sds are on the parameter's population scale
(log for a positive parameter: an effect's ratio is ``exp(d)``; s about the coefficient of variation).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

__all__ = ["HierarchyCase", "HierarchyRecord", "hierarchy_case"]


@dataclass(frozen=True)
class HierarchyCase:
    """One population of specimens.

    effects : "group:param" -> [ratio or difference median, 5 %, 95 %, P(d > 0)] for each non-reference group.
    typical : "group:param" -> [median, 5 %, 95 % of the typical specimen, 5 %, 95 % of a new specimen].
    pop_sd : param -> [median, 5 %, 95 %] of s. own_spread : param -> the range of the specimens' own posterior
    medians on the population scale (what s has to explain). specimens : "specimen:param" -> [own median, 5 %, 95 %,
    shrunken median, 5 %, 95 %]. generating : param -> each specimen's generating value (synthetic data), else empty.
    """

    name: str
    title: str
    groups: list[str]
    n_specimens: dict[str, int]
    parameters: list[str]
    log_scale: dict[str, bool]
    effects: dict[str, list[float]]
    typical: dict[str, list[float]]
    pop_sd: dict[str, list[float]]
    own_spread: dict[str, float]
    specimens: dict[str, list[float]]
    specimen_order: list[str]
    generating: dict[str, list[float]]
    stage1: dict[str, str]
    verdict: str
    converged: bool
    notes: list[str]
    figure: str
    seconds: float
    tissue_strain: float
    tissue_units: dict[str, str]
    tissue: dict[str, list[float]]
    tissue_effects: dict[str, list[float]]


@dataclass(frozen=True)
class HierarchyRecord:
    SCHEMA: ClassVar[str] = "bayestissue.hierarchy"
    VERSION: ClassVar[int] = 2

    mode: str
    cases: list[HierarchyCase]


def hierarchy_case(name: str, title: str, post, stage1, *, diagnostics: dict, notes, stage1_verdicts: dict,
                   figure: str, seconds: float, generating: dict | None = None,
                   terms=None) -> HierarchyCase:  # fmt: skip
    """The record of one case from its :class:`~bayestissue.inference.hierarchy.HierarchyPosterior` and stage-1
    draws (natural units, per specimen), through the tables of :mod:`bayestissue.workflows.hierarchy_summary`, with
    the population's tissue terms ``terms`` (:class:`~bayestissue.workflows.population_terms.PopulationTerms`) if
    given."""
    from bayestissue.workflows.hierarchy_summary import effect_rows, group_rows, specimen_rows

    sc = post.scale
    effects = {f"{r['group']}:{r['parameter']}": [r["median"], r["lower"], r["upper"], r["p_positive"]]
               for r in effect_rows(post)}  # fmt: skip
    typical, pop_sd = {}, {}
    for r in group_rows(post):
        typical[f"{r['group']}:{r['parameter']}"] = [r[k] for k in ("typical", "typical_lower", "typical_upper",
                                                                     "new_lower", "new_upper")]  # fmt: skip
        pop_sd[r["parameter"]] = [r["pop_sd"], r["pop_sd_lower"], r["pop_sd_upper"]]
    specimens = {f"{r['specimen']}:{r['parameter']}": [r[k] for k in ("own", "own_lower", "own_upper", "shrunk",
                                                                        "shrunk_lower", "shrunk_upper")]
                 for r in specimen_rows(post, stage1)}  # fmt: skip
    spread = {}
    for j, n in enumerate(sc.names):
        own = [float(np.median(np.log(st[:, j]) if sc.log[j] else st[:, j])) for st in stage1]
        spread[n] = float(np.max(own) - np.min(own))
    tissue, tissue_effects = {}, {}
    if terms is not None:
        for r in terms.group_rows():
            tissue[f"{r['group']}:{r['quantity']}"] = [r[k] for k in ("typical", "typical_lower", "typical_upper",
                                                                      "new_lower", "new_upper")]  # fmt: skip
        for r in terms.effect_rows():
            tissue_effects[f"{r['group']}:{r['quantity']}"] = [r["median"], r["lower"], r["upper"], r["p_positive"]]
    return HierarchyCase(
        name=name,
        title=title,
        groups=list(post.groups),
        n_specimens={g: post.n_in_group(k) for k, g in enumerate(post.groups)},
        parameters=list(sc.names),
        log_scale={n: bool(lg) for n, lg in zip(sc.names, sc.log, strict=True)},
        effects=effects,
        typical=typical,
        pop_sd=pop_sd,
        own_spread=spread,
        specimens=specimens,
        specimen_order=list(post.specimens),
        generating={k: [float(x) for x in v] for k, v in (generating or {}).items()},
        stage1=dict(stage1_verdicts),
        verdict=diagnostics["verdict"],
        converged=bool(diagnostics["converged"]),
        notes=list(notes),
        figure=figure,
        seconds=float(seconds),
        tissue_strain=float(terms.strain) if terms is not None else 0.0,
        tissue_units=dict(terms.units) if terms is not None else {},
        tissue=tissue,
        tissue_effects=tissue_effects,
    )
