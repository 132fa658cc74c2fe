"""The report's section 9 (relaxation branches): per branch count its evidence, fit and verdict from the branch-count
stage's record (:mod:`bayestissue.analyses.branch_count`), the count the evidence picks and by which rule, and
whether each count's runs belong to the current code."""

from __future__ import annotations

__all__ = ["branch_count_context"]


def _row(rec, n: int, now: dict[int, str] | None) -> dict:
    f = rec.fits[str(n)]
    e = f.evidence
    row = {"n": n, "f": f, "e": e, "k": len(e.names), "best": n == rec.best,
           "current": None if now is None else now.get(n) == e.numbers_hash}  # fmt: skip
    if n != rec.best:
        log_b, err, grade = rec.grades()[n]
        decides, rule = rec.decides(n)
        row.update(log_b=log_b, err=err, grade=grade, decides=decides, rule=rule,
                   bound=rec.scatter_bound(n) if rule == "highest run + 2 sd" else None)  # fmt: skip
    return row


def branch_count_context(record, now: dict[int, str] | None) -> dict | None:
    """The section's values; None without the record. ``now``: per count the current code's and data's hash
    (:func:`~bayestissue.analyses.branch_count.count_hash`; None: not checked)."""
    if record is None or not record.fits:
        return None
    rows = [_row(record, n, now) for n in record.counts]
    stale = [r["n"] for r in rows if r["current"] is False]
    return {"record": record, "rows": rows, "chosen": record.chosen, "best": record.best,
            "true": record.true_branches, "stale": stale, "scattered": [r for r in rows if r.get("bound") is not None],
            "others": [r for r in rows if not r["best"]]}  # fmt: skip
