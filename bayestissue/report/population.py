"""The report's section 8 (specimens and groups): the hierarchical model's cases from the specimens stage's record."""

from __future__ import annotations

__all__ = ["TISSUE_SHOWN", "population_context", "shown_term"]


def _recovered(case) -> dict | None:
    """How many specimens' generating values lie inside their own and their shrunken 90 % intervals (synthetic
    data only)."""
    if not case.generating:
        return None
    own = shrunk = total = 0
    for n, values in case.generating.items():
        for spec, v in zip(case.specimen_order, values, strict=True):
            row = case.specimens[f"{spec}:{n}"]
            own += row[1] <= v <= row[2]
            shrunk += row[4] <= v <= row[5]
            total += 1
    return {"own": own, "shrunk": shrunk, "total": total}


#: the tissue terms the report shows (the summary file has them all)
TISSUE_SHOWN = ("secant modulus (instantaneous)", "secant modulus (equilibrium)", "relaxation at full hold")


def shown_term(name: str) -> bool:
    """Whether the report shows tissue term ``name``: one of :data:`TISSUE_SHOWN` or a relaxation time."""
    return name in TISSUE_SHOWN or name.startswith("relaxation time")


def _tissue(case) -> list[dict]:
    """Per shown quantity (and every relaxation time): each group's typical specimen and new-specimen range, and
    each non-reference group's effect."""
    rows = []
    for name, unit in case.tissue_units.items():
        if not shown_term(name):
            continue
        groups = [{"group": g, "q": case.tissue[f"{g}:{name}"][:3], "new": case.tissue[f"{g}:{name}"][3:]}
                  for g in case.groups]  # fmt: skip
        effects = [{"group": g, "q": case.tissue_effects[f"{g}:{name}"][:3], "p": case.tissue_effects[f"{g}:{name}"][3]}
                   for g in case.groups[1:]]  # fmt: skip
        rows.append({"quantity": name, "unit": unit, "groups": groups, "effects": effects,
                     "kind": "difference" if unit == "%" else "ratio"})  # fmt: skip
    return rows


def _case(case) -> dict:
    effects = []
    for key, v in case.effects.items():
        group, n = key.split(":")
        log = case.log_scale[n]
        effects.append({"group": group, "parameter": n, "kind": "ratio" if log else "difference", "q": v[:3],
                        "p": v[3], "null": 1.0 if log else 0.0, "excludes_null": not (v[1] <= (1.0 if log else 0.0)
                                                                                      <= v[2])})  # fmt: skip
    typical = []
    for key, v in case.typical.items():
        group, n = key.split(":")
        typical.append({"group": group, "parameter": n, "q": v[:3], "new": v[3:], "n": case.n_specimens[group]})
    return {"c": case, "effects": effects, "typical": typical, "recovered": _recovered(case), "tissue": _tissue(case),
            "unconverged": [s for s, v in case.stage1.items() if not v.startswith("CONVERGED")]}  # fmt: skip


def population_context(record) -> dict | None:
    """Per case (tendon groups, T1/T2 as specimens) its effects, typical specimens and recovery; None without the
    record."""
    if record is None or not record.cases:
        return None
    cases = {c.name: _case(c) for c in record.cases}
    return {"record": record, "groups": cases.get("tendon_groups"), "slug": cases.get("T1_T2")}
