"""The report's section 9 (relaxation branches): per branch count its evidence, fit and verdict from the branch-count
stage's record (:mod:`bayestissue.analyses.branch_count`), the count the evidence picks and by which rule, and
whether each count's runs belong to the current code."""

from __future__ import annotations

from bayestissue.analyses.branch_count import SCATTER_RULE
from bayestissue.report.population import shown_term

__all__ = ["branch_count_context"]


def _terms(rec) -> list[dict]:
    """Per shown tissue term (:func:`~bayestissue.report.population.shown_term`): its unit, the generating value and
    each count's (5 %, median, 95 %) or None."""
    return [{"quantity": q, "unit": rec.unit(q), "truth": rec.truth_terms.get(q),
             "counts": [rec.fits[str(n)].terms.get(q) for n in rec.counts]}
            for q in rec.term_names if shown_term(q)]  # fmt: skip


def _row(rec, n: int, now: dict[int, str] | None) -> dict:
    f = rec.fits[str(n)]
    e = f.evidence
    row = {"n": n, "f": f, "e": e, "k": len(e.names), "best": n == rec.best,
           "current": None if now is None else now.get(n) == e.numbers_hash}  # fmt: skip
    if n != rec.best:
        log_b, err, grade = rec.grades()[n]
        decides, rule = rec.decides(n)
        row.update(log_b=log_b, err=err, grade=grade, decides=decides, rule=rule,
                   bound=rec.scatter_bound(n) if rule == SCATTER_RULE else None)  # fmt: skip
    return row


def branch_count_context(record, now: dict[int, str] | None) -> dict | None:
    """The section's values; None without the record. ``now``: per count the current code's and data's hash
    (:func:`~bayestissue.analyses.branch_count.count_hash`; None: not checked)."""
    if record is None or not record.fits:
        return None
    rows = [_row(record, n, now) for n in record.counts]
    stale = [r["n"] for r in rows if r["current"] is False]
    inside = record.recovered(record.true_branches) if str(record.true_branches) in record.fits else {}
    return {"record": record, "rows": rows, "chosen": record.chosen, "best": record.best,
            "true": record.true_branches, "stale": stale, "scattered": [r for r in rows if r.get("bound") is not None],
            "others": [r for r in rows if not r["best"]], "terms": _terms(record),
            "recovered": {"inside": sum(inside.values()), "total": len(inside),
                          "missed": [q for q, ok in inside.items() if not ok]}}  # fmt: skip
