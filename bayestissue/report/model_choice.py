"""The report's lines on the study's model: per data set, the log Bayes factor of the mirror model over the paper's 11
parameters (on the joint data set also of a T2 stiffness scale over shared parameters), graded by
:func:`~bayestissue.analyses.verdicts.evidence_strength`, a choice only by
:func:`~bayestissue.analyses.verdicts.evidence_decides` from runs that agree on each evidence
(:func:`~bayestissue.analyses.verdicts.evidence_consistent`), and the 11-parameter posterior beside Table 1."""

from __future__ import annotations

import numpy as np

from bayestissue.analyses.box_width import FACTOR
from bayestissue.analyses.evidence_check import PROPOSAL_ERROR
from bayestissue.analyses.model_choice import DataChoice, ModelChoiceRecord, rerun_command
from bayestissue.analyses.records import IdentifiabilityRecord
from bayestissue.analyses.verdicts import (
    EVIDENCE_MIN_RUNS,
    EVIDENCE_P,
    estimators_apart,
    evidence_choice,
    evidence_decides,
    evidence_strength,
)
from bayestissue.paper import MIRROR_TIES, PAPER_PARAMETERS
from bayestissue.parallel import projected_wall_time

__all__ = ["EDGE_SHARE", "PROJECTED_WORKERS", "model_choice_context"]

#: The worker counts the wall-time projection is given for (:func:`_projection`).
PROJECTED_WORKERS = (1, 4)
#: a bound is listed as holding posterior mass if its outermost decade holds at least this share (a flat marginal
#: over a 6-decade box holds 0.17)
EDGE_SHARE = 0.05


def _source(model: str, name: str) -> str:
    """The parameter model ``model`` samples for ``name``: a tied model's (mirror, scale) source of a tied one."""
    return name if model == "full" else dict(MIRROR_TIES).get(name, name)


def _rows(case: DataChoice, I: IdentifiabilityRecord) -> list[dict]:
    """Per parameter of Table 1: the paper's value, our least squares, each model's nested posterior."""
    rows = []
    for j, n in enumerate(I.names):
        row = {"name": n, "paper": PAPER_PARAMETERS[case.data][j], "ls": I.profile_reference[case.data].theta_final[j]}
        for model, e in case.models.items():
            source = _source(model, n)
            row[model] = None if source not in e.names else {
                "q": e.quantile(source), "err": e.quantile_errors[e.names.index(source)][1], "tied_to": (
                    source if source != n else None)}  # fmt: skip
        rows.append(row)
    return rows


def _check_rows(case, I: IdentifiabilityRecord) -> list[dict]:
    """Per parameter of the data set's checked models (``case``: a
    :class:`~bayestissue.analyses.evidence_check.CheckCase`): the paper's Table 1 value of each test the data set
    holds, our least squares on it, and each checked model's 5 / 50 / 95 % under the importance weights (a mirror
    model's tied parameter names its source). For a data set the nested runs leave without a posterior one can use."""
    tests = [case.data] if case.data in PAPER_PARAMETERS else ["T1", "T2"]
    ls = I.profile_reference.get(case.data)
    extra = [n for c in case.checks.values() for n in c.names if n not in I.names]
    rows = []
    for n in [*I.names, *dict.fromkeys(extra)]:
        j = I.names.index(n) if n in I.names else None
        row = {"name": n, "paper": [None if j is None else PAPER_PARAMETERS[t][j] for t in tests],
               "ls": None if j is None or ls is None else ls.theta_final[j], "models": {}}  # fmt: skip
        for model, c in case.checks.items():
            source = _source(model, n)
            row["models"][model] = None if source not in c.names else {
                "q": c.quantiles[c.names.index(source)], "tied_to": source if source != n else None}  # fmt: skip
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
    consistent = case.factor_decides(a, b)
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


def _scale_quantiles(scale, check) -> list[float] | None:
    """The stiffness scale's (5 %, median, 95 %): from the importance-sampling check where it is trusted, else from the
    nested runs (``scale``, or None where the scale model has not run)."""
    c = check.checks.get("scale") if check is not None else None
    if c is not None and c.trusted and "scale" in c.names:
        return c.quantiles[c.names.index("scale")]
    return None if scale is None else scale.quantile("scale")


def _checked(nested: dict | None, check, a: str, b: str) -> dict:
    """Factor ``(a, b)`` by both estimators: the nested runs' (``nested``, :func:`_factor`; None where a model has not
    run), the importance sampling's (None without the check; with how it moves with the boxes), the model the two
    choose
    (:func:`~bayestissue.analyses.verdicts.evidence_choice`) and whether they are apart."""
    checked = check.factor(a, b) if check is not None and {a, b} <= check.checks.keys() else None
    if checked is not None:  # how it moves with the boxes, from the checks' weighted draws
        moves = check.box_moves(a, b)
        checked = {**checked, "moves": moves, "narrowed_ok": bool(np.isfinite(moves["narrowed"][0])),
                   "edges": [_edges(check.checks[m]) for m in (a, b)]}  # fmt: skip
    chosen, source = evidence_choice(nested, checked)
    apart = None if nested is None or checked is None else estimators_apart(
        (nested["log_b"], nested["err"]), (checked["log_b"], checked["err"]))  # fmt: skip
    return {"a": a, "b": b, "nested": nested, "check": checked, "chosen": chosen, "source": source, "apart": apart}


def _case(case: DataChoice, I: IdentifiabilityRecord, now: dict[str, str] | None, check=None) -> dict:
    """The first of the data set's factors (:data:`~bayestissue.analyses.model_choice.FACTORS`: mirror over full)
    chooses the model; the others (the joint data set's stiffness scale over shared parameters) are reported beside
    it. A factor whose models have not both run yet (a data set's models may run in separate sessions) is listed in
    ``pending`` with the models it still needs. ``check``: the data set's importance-sampling check
    (:class:`~bayestissue.analyses.evidence_check.CheckCase`) or None; ``choices`` holds every factor by both
    estimators and the model they choose."""
    first, *rest = case.factors
    run = {f: _factor(case, *f) for f in case.factors_run}
    choice = run.get(first, {"decides": False})
    scale = case.models.get("scale")
    stale = None if now is None else [k for k, e in case.models.items() if now.get(k) != e.numbers_hash]
    choices = [_checked(run.get((a, b)), check, a, b) for a, b in case.factors]
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
        "scale_q": _scale_quantiles(scale, check),
        "stale": stale,
        "rerun_stale": rerun_command(case.data, stale or []),
        # Table 1 and our least squares exist per test, not for the joint data set
        "rows": _rows(case, I) if case.data in PAPER_PARAMETERS else [],
        "check": check,
        "choices": choices,
        # the data set's parameters by importance sampling where Table 1's block above has no nested posterior
        "check_rows": _check_rows(check, I) if check is not None and case.data not in PAPER_PARAMETERS else [],
        "check_tests": [case.data] if case.data in PAPER_PARAMETERS else ["T1", "T2"],
        "chosen": choices[0]["chosen"],
        "chosen_by": choices[0]["source"],
    }


def model_choice_context(
    rec: ModelChoiceRecord | None,
    I: IdentifiabilityRecord,
    now: dict[str, dict[str, str]] | None,
    check=None,
    check_now: dict[str, dict[str, str]] | None = None,
) -> dict | None:
    """Everything the model-choice lines read; None without the record. ``now``: data set -> model -> the current
    code's hash for the record's mode (:func:`~bayestissue.analyses.model_choice.current_hash`; None: not checked).
    ``check``: the importance-sampling record (:class:`~bayestissue.analyses.evidence_check.EvidenceCheckRecord`) or
    None, ``check_now`` its current hashes likewise (:func:`~bayestissue.analyses.evidence_check.check_hash`);
    ``quadrature`` lists the checks made with a parameter integrated out by quadrature and their quadrature's
    counts (:attr:`~bayestissue.analyses.evidence_check.EvidenceCheck.quadrature`)."""
    if rec is None:
        return None
    now = now or {}
    cases = [_case(c, I, now.get(d), check.cases.get(d) if check is not None else None) for d, c in rec.cases.items()]
    stale = [] if check is None or check_now is None else [
        f"{d} {m}" for d, c in check.cases.items() for m, e in c.checks.items()
        if check_now.get(d, {}).get(m) != e.numbers_hash]  # fmt: skip
    quadrature = [] if check is None else [
        {"data": d, "model": m, "param": e.quadrature.param, "one_labelling": e.quadrature.one_labelling,
         "text": e.quadrature.summary()}
        for d, c in check.cases.items() for m, e in c.checks.items() if e.quadrature is not None]  # fmt: skip
    return {"record": rec, "cases": cases, "min_runs": EVIDENCE_MIN_RUNS, "p_min": EVIDENCE_P, "factor": FACTOR,
            "check": check, "check_stale": stale, "proposal_error": PROPOSAL_ERROR,
            "quadrature": quadrature}  # fmt: skip
