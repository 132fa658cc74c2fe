"""The report's lines on the study's model: per data set, the log Bayes factor of the mirror model over the paper's 11
parameters (on the joint data set also of a T2 stiffness scale over shared parameters), graded by
:func:`~bayestissue.analyses.verdicts.evidence_strength`, a choice only by
:func:`~bayestissue.analyses.verdicts.evidence_decides` from runs that agree on each evidence
(:func:`~bayestissue.analyses.verdicts.evidence_consistent`), and the 11-parameter posterior beside Table 1."""

from __future__ import annotations

import numpy as np

from bayestissue.analyses.box_width import FACTOR
from bayestissue.analyses.model_choice import DataChoice, ModelChoiceRecord, rerun_command
from bayestissue.analyses.records import IdentifiabilityRecord
from bayestissue.analyses.verdicts import EVIDENCE_MIN_RUNS, EVIDENCE_P, evidence_decides, evidence_strength
from bayestissue.paper import MIRROR_TIES, PAPER_PARAMETERS
from bayestissue.parallel import projected_wall_time

__all__ = ["EDGE_SHARE", "PROJECTED_WORKERS", "model_choice_context"]

#: The worker counts the wall-time projection is given for (:func:`_projection`).
PROJECTED_WORKERS = (1, 4)
#: a bound is listed as holding posterior mass if its outermost decade holds at least this share (a flat marginal
#: over a 6-decade box holds 0.17)
EDGE_SHARE = 0.05


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


def _edges(e) -> list[str]:
    """The bounds of ``e``'s log boxes holding at least :data:`EDGE_SHARE` of its posterior in their outermost
    ``ln factor`` (where widening can add evidence the volume term does not count)."""
    if e.box is None:
        return []
    return [f"{n} {side} {v:.2f}" for n, sh in zip(e.box.names, e.box.edge_share, strict=True)
            for side, v in zip(("low", "high"), sh, strict=True) if v >= EDGE_SHARE]  # fmt: skip


def _projection(e) -> dict[int, float]:
    r"""Wall time (s) of ``e``'s runs on W workers (:func:`~bayestissue.parallel.projected_wall_time`) for W in
    :data:`PROJECTED_WORKERS`: the runs are independent tasks and none is split (docs/cluster.md), and
    :math:`\bar t_{run}` is their mean time as measured here, beside the other runs of the record (a little above a
    run's time alone, so W = 1 is an upper estimate). Empty unless every run's time was recorded."""
    t = np.asarray(e.time_s, dtype=float)
    if not np.all(np.isfinite(t)):
        return {}
    return {w: projected_wall_time(t.size, float(np.mean(t)), w) for w in PROJECTED_WORKERS}


def _factor(case: DataChoice, a: str, b: str) -> dict:
    """ln B of model ``a`` over ``b`` with its grade, whether it decides, and how it moves with the boxes."""
    log_b, err = case.log_bayes(a, b)
    pair = (case.models[a], case.models[b])
    moves = case.log_bayes_moves(a, b)
    consistent = all(e.runs_agree for e in pair)
    return {
        "a": a,
        "b": b,
        "pair": pair,
        "log_b": log_b,
        "err": err,
        "favours": a if log_b > 0 else b,
        "grade": evidence_strength(abs(log_b), err),
        "decides": evidence_decides(log_b, err, consistent),
        "consistent": consistent,
        "disagree": [e.model for e in pair if not e.runs_agree],
        "moves": moves,
        "narrowed_ok": moves is not None and bool(np.isfinite(moves["narrowed"][0])),
        "edges": [_edges(e) for e in pair],
    }


def _pending(case: DataChoice, a: str, b: str) -> dict:
    """A factor whose models have not both run: the models it still needs and the command that runs them."""
    missing = [m for m in (a, b) if m not in case.models]
    return {"a": a, "b": b, "missing": missing, "rerun": rerun_command(case.data, missing)}


def _case(case: DataChoice, I: IdentifiabilityRecord, now: dict[str, str] | None) -> dict:
    """The first of the data set's factors (:data:`~bayestissue.analyses.model_choice.FACTORS`: mirror over full)
    chooses the model; the others (the joint data set's stiffness scale over shared parameters) are reported beside
    it. A factor whose models have not both run yet (a data set's models may run in separate sessions) is listed in
    ``pending`` with the models it still needs, and the choice is then not made (``ran`` False)."""
    first, *rest = case.factors
    run = {f: _factor(case, *f) for f in case.factors_run}
    choice = run.get(first, {"decides": False})
    scale = case.models.get("scale")
    stale = None if now is None else [k for k, e in case.models.items() if now.get(k) != e.numbers_hash]
    return {
        **choice,
        "ran": first in run,
        "c": case,
        "models": list(case.models.values()),
        "projected": {k: _projection(e) for k, e in case.models.items()},
        "wall": {k: e.wall_text for k, e in case.models.items()},
        "mirror": case.models.get("mirror"),
        "full": case.models.get("full"),
        "others": [run[f] for f in rest if f in run],
        "factors": list(run.values()),
        "pending": [_pending(case, a, b) for a, b in case.factors if (a, b) not in run],
        "scale_q": None if scale is None else scale.quantile("scale"),
        "stale": stale,
        "rerun_stale": rerun_command(case.data, stale or []),
        # Table 1 and our least squares exist per test, not for the joint data set
        "rows": _rows(case, I) if case.data in PAPER_PARAMETERS else [],
    }


def model_choice_context(
    rec: ModelChoiceRecord | None, I: IdentifiabilityRecord, now: dict[str, dict[str, str]] | None
) -> dict | None:
    """Everything the model-choice lines read; None without the record. ``now``: data set -> model -> the current
    code's hash for the record's mode (:func:`~bayestissue.analyses.model_choice.current_hash`; None: not checked)."""
    if rec is None:
        return None
    now = now or {}
    return {"record": rec, "cases": [_case(c, I, now.get(d)) for d, c in rec.cases.items()],
            "min_runs": EVIDENCE_MIN_RUNS, "p_min": EVIDENCE_P, "factor": FACTOR}  # fmt: skip
