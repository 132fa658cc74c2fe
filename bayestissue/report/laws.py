"""The report's section on constitutive laws: per material the joint evidence table (Bayes factors graded by
:func:`~bayestissue.analyses.verdicts.evidence_strength`), the transfer table, and the brain's Ogden exponent against
the published one."""

from __future__ import annotations

from bayestissue.analyses.law_choice import bayes_factors
from bayestissue.analyses.records import LawChoiceRecord, LawFit, MaterialLaws
from bayestissue.analyses.verdicts import evidence_strength

__all__ = ["laws_context"]


def _joint_rows(m: MaterialLaws) -> tuple[str, list[dict]]:
    best, factors = bayes_factors({f.law: f.log_z for f in m.joint}, {f.law: f.log_z_err for f in m.joint})
    rows = []
    for f in sorted(m.joint, key=lambda f: -f.log_z):
        b, e = factors[f.law]
        rows.append({"fit": f, "k": len(f.names), "log_b": b, "err": e,
                     "grade": "best" if f.law == best else evidence_strength(b, e)})  # fmt: skip
    return best, rows


def _exponent(fits: list[LawFit]) -> tuple[float, float, float] | None:
    for f in fits:
        if f.law == "Ogden 1":
            return f.posterior["alpha1"]
    return None


def _material(m: MaterialLaws) -> dict:
    best, rows = _joint_rows(m)
    runner = rows[1] if len(rows) > 1 else None
    reference = m.alpha_published
    alpha = _exponent(m.joint) if reference else None
    return {
        "m": m,
        "best": best,
        "rows": rows,
        "runner": runner,
        "predicted": m.modes[1:],
        "alpha_joint": alpha,
        "alpha_transfer": _exponent(m.transfer) if reference else None,
        "alpha_inside": None if alpha is None else bool(reference[0] <= alpha[0] <= reference[1]),
        "unconverged": [f"{f.law} ({', '.join(f.fitted_on)})" for f in m.transfer + m.joint if not f.converged],
    }


def laws_context(record: LawChoiceRecord | None) -> dict | None:
    """Everything the laws section and its line of the answers read; None without the record."""
    if record is None:
        return None
    materials = [_material(m) for m in record.materials if m.joint]
    return {"record": record, "materials": materials}
