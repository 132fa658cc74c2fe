"""The report's lines on the study's model: per data set, the log Bayes factor of the mirror model over the paper's 11
parameters (graded by :func:`~bayestissue.analyses.verdicts.evidence_strength`, a choice only by
:func:`~bayestissue.analyses.verdicts.evidence_decides`), and the 11-parameter posterior beside Table 1."""

from __future__ import annotations

from bayestissue.analyses.model_choice import DataChoice, ModelChoiceRecord
from bayestissue.analyses.records import IdentifiabilityRecord
from bayestissue.analyses.verdicts import evidence_decides, evidence_strength
from bayestissue.paper import MIRROR_TIES, PAPER_PARAMETERS

__all__ = ["model_choice_context"]


def _rows(case: DataChoice, I: IdentifiabilityRecord) -> list[dict]:
    """Per parameter of Table 1: the paper's value, our least squares, each model's nested posterior."""
    tied = dict(MIRROR_TIES)
    rows = []
    for j, n in enumerate(I.names):
        row = {"name": n, "paper": PAPER_PARAMETERS[case.data][j], "ls": I.profile_reference[case.data].theta_final[j]}
        for model, e in case.models.items():
            source = tied.get(n, n) if model == "mirror" else n
            row[model] = None if source not in e.names else {
                "q": e.quantile(source), "err": e.quantile_errors[e.names.index(source)][1], "tied_to": (
                    source if source != n else None)}  # fmt: skip
        rows.append(row)
    return rows


def _case(case: DataChoice, I: IdentifiabilityRecord, now: dict[str, str] | None) -> dict:
    m, f = case.models["mirror"], case.models["full"]
    log_b, err = case.log_bayes()
    converged = m.converged and f.converged
    return {
        "c": case,
        "mirror": m,
        "full": f,
        "log_b": log_b,
        "err": err,
        "favours": "mirror" if log_b > 0 else "full",
        "grade": evidence_strength(abs(log_b), err),
        "decides": evidence_decides(log_b, err, converged),
        "converged": converged,
        "stale": None if now is None else [k for k, e in case.models.items() if now.get(k) != e.numbers_hash],
        "rows": _rows(case, I),
    }


def model_choice_context(
    rec: ModelChoiceRecord | None, I: IdentifiabilityRecord, now: dict[str, dict[str, str]] | None
) -> dict | None:
    """Everything the model-choice lines read; None without the record. ``now``: data set -> model -> the current
    code's hash for the record's mode (:func:`~bayestissue.analyses.model_choice.current_hash`; None: not checked)."""
    if rec is None:
        return None
    now = now or {}
    return {"record": rec, "cases": [_case(c, I, now.get(d)) for d, c in rec.cases.items()]}
