"""REPORT.md rendered from the study's records with a Jinja2 template (``templates/report.md.j2``).

The template holds the report's wording; the context built here holds its numbers and verdicts, all read from the
records (:mod:`bayestissue.report.study`) and judged by :mod:`bayestissue.analyses.verdicts`. Explanation that does not
change with the numbers lives in ``docs/report_guide.md``, which the report links to.
"""

from __future__ import annotations

from pathlib import Path

import jinja2

from bayestissue.analyses import verdicts
from bayestissue.analyses.records import MeasuredRecord
from bayestissue.inference.fit_check import MAX_LAG1, MAX_NOISE_RATIO
from bayestissue.report.branch_count import branch_count_context
from bayestissue.report.causes import (
    controls_context,
    difference_context,
    experiments_context,
    rates_context,
    specimens_context,
)
from bayestissue.report.format import FILTERS
from bayestissue.report.identify import estimates_context, identify_context
from bayestissue.report.laws import laws_context
from bayestissue.report.model_choice import model_choice_context
from bayestissue.report.population import population_context
from bayestissue.report.study import LABELS, StudyRecords, read_study_records

__all__ = ["GUIDE", "render_report", "write_report"]

#: Where the report's unchanging explanation lives, relative to the report (``figures/REPORT.md``).
GUIDE = "../docs/report_guide.md"


def _environment() -> jinja2.Environment:
    env = jinja2.Environment(
        loader=jinja2.PackageLoader("bayestissue.report", "templates"),
        undefined=jinja2.StrictUndefined,  # a misspelt field fails the render instead of printing nothing
        trim_blocks=True,
        lstrip_blocks=True,
        keep_trailing_newline=True,
        autoescape=False,
    )
    env.filters.update(FILTERS, verdict_text=verdicts.verdict_text)
    return env


def _measured(M: MeasuredRecord | None) -> dict | None:
    if M is None:
        return None
    cases = {c.name: c for c in M.cases}
    a, b = cases.get("treloar_to_3"), cases.get("treloar_all")
    inside = None
    if a is not None:
        fits = (a.closed_form, a.least_squares)
        inside = all(a.posterior[k][1] <= f[k] <= a.posterior[k][2] for f in fits for k in ("mu", "kappa"))
    return {"record": M, "to_3": a, "all": b, "inside": inside,
            "brains": [c for c in M.cases if c.name.startswith("brain")]}  # fmt: skip


def _terms(T) -> dict | None:
    """The tissue terms of the mirror-model posteriors; per quantity, whether T1's and T2's 90 % intervals overlap."""
    if T is None or not T.runs:
        return None
    runs = [r for r in ("T1_mirror", "T2_mirror", "joint_mirror") if r in T.runs]
    both = "T1_mirror" in T.runs and "T2_mirror" in T.runs
    overlap = {q: T.runs["T1_mirror"][q][1] <= T.runs["T2_mirror"][q][2] and T.runs["T2_mirror"][q][1]
               <= T.runs["T1_mirror"][q][2] for q in T.units} if both else {}  # fmt: skip
    return {"record": T, "runs": runs, "overlap": overlap}


def report_context(records: StudyRecords) -> dict:
    """Every value the template reads."""
    I, D = records.identifiability, records.discrepancy
    rates = rates_context(D, I)
    return {
        "labs": LABELS,
        "I": I,
        "D": D,
        "C": records.calibration,
        "K": records.controls,
        "guide": GUIDE,
        "fit_rule": {"noise_ratio": MAX_NOISE_RATIO, "lag1": MAX_LAG1},
        "identify": identify_context(I, records.calibration),
        "difference": difference_context(D),
        "controls": None if records.controls is None else controls_context(records.controls),
        "rates": rates,
        "specimens": specimens_context(D),
        "estimates": estimates_context(I),
        "experiments": experiments_context(D, rates),
        "measured": _measured(records.measured),
        "laws": laws_context(records.laws),
        "terms": _terms(records.tissue_terms),
        "population": population_context(records.hierarchy),
        "model_choice": model_choice_context(
            records.model_choice, I, records.model_choice_now, records.evidence_check, records.evidence_check_now
        ),  # fmt: skip
        "branches": branch_count_context(records.branch_count, records.branch_count_now),
    }


def render_report(records: StudyRecords) -> str:
    """The report's markdown."""
    return _environment().get_template("report.md.j2").render(**report_context(records))


def write_report(folder) -> Path:
    """Read the records in ``folder`` and write ``folder/REPORT.md`` from them."""
    folder = Path(folder)
    path = folder / "REPORT.md"
    path.write_text(render_report(read_study_records(folder)))
    return path
