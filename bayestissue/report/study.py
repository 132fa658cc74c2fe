"""The records a report is rendered from: read from a study's output folder, each checked against its schema."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from bayestissue.analyses.branch_count import BranchCountRecord, count_hash
from bayestissue.analyses.evidence_check import EvidenceCheckRecord, check_hash
from bayestissue.analyses.identifiability import LABELS
from bayestissue.analyses.model_choice import ModelChoiceRecord, current_hashes
from bayestissue.analyses.records import (
    FILES,
    CalibrationRecord,
    ControlsRecord,
    DiscrepancyRecord,
    HierarchyRecord,
    IdentifiabilityRecord,
    LawChoiceRecord,
    MeasuredRecord,
    TissueTermsRecord,
)
from bayestissue.io.records import read_record

__all__ = ["LABELS", "StudyRecords", "read_study_records"]

#: The bundled data the model-choice record's hash covers (a source checkout; without it the check is skipped).
DATA_DIR = Path(__file__).resolve().parents[2] / "data"


@dataclass(frozen=True)
class StudyRecords:
    """The study's records: identifiability and T1 vs T2 are needed; a stage that did not run leaves its None."""

    identifiability: IdentifiabilityRecord
    discrepancy: DiscrepancyRecord
    calibration: CalibrationRecord | None = None
    controls: ControlsRecord | None = None
    measured: MeasuredRecord | None = None
    laws: LawChoiceRecord | None = None
    tissue_terms: TissueTermsRecord | None = None
    hierarchy: HierarchyRecord | None = None
    model_choice: ModelChoiceRecord | None = None
    #: data set -> model -> the current code's and data's hash for the model-choice record's mode (None: not checked)
    model_choice_now: dict[str, dict[str, str]] | None = None
    branch_count: BranchCountRecord | None = None
    #: branch count -> the current code's, data's and configuration's hash (None: not checked)
    branch_count_now: dict[int, str] | None = None
    evidence_check: EvidenceCheckRecord | None = None
    #: data set -> model -> the current code's and data's hash for the evidence check's mode (None: not checked)
    evidence_check_now: dict[str, dict[str, str]] | None = None


def read_study_records(folder) -> StudyRecords:
    """Read every record in ``folder`` (:data:`bayestissue.analyses.records.FILES`); the calibration, controls,
    measured-data, laws, tissue-terms, hierarchy, model-choice, branch-count and evidence-check records are optional
    (their stages may not have run), the other two are not. The model-choice, branch-count and evidence-check records
    are checked against the current code (:func:`~bayestissue.analyses.model_choice.current_hashes`,
    :func:`~bayestissue.analyses.branch_count.count_hash`, :func:`~bayestissue.analyses.evidence_check.check_hash`)
    where the source checkout's data are at hand."""
    folder = Path(folder)

    def optional(cls):
        path = folder / FILES[cls]
        return read_record(path, cls) if path.is_file() else None

    choice = optional(ModelChoiceRecord)
    now = current_hashes(choice, DATA_DIR) if choice is not None and DATA_DIR.is_dir() else None
    branches = optional(BranchCountRecord)
    root = DATA_DIR.parent
    checkable = branches is not None and DATA_DIR.is_dir() and (root / "examples").is_dir()
    branches_now = {n: count_hash(branches.mode, root, n) for n in branches.counts} if checkable else None
    check = optional(EvidenceCheckRecord)
    check_now = None if check is None or not DATA_DIR.is_dir() else {
        d: {m: check_hash(check.mode, DATA_DIR, d, m) for m in c.checks} for d, c in check.cases.items()}  # fmt: skip
    return StudyRecords(
        identifiability=read_record(folder / FILES[IdentifiabilityRecord], IdentifiabilityRecord),
        discrepancy=read_record(folder / FILES[DiscrepancyRecord], DiscrepancyRecord),
        calibration=optional(CalibrationRecord),
        controls=optional(ControlsRecord),
        measured=optional(MeasuredRecord),
        laws=optional(LawChoiceRecord),
        tissue_terms=optional(TissueTermsRecord),
        hierarchy=optional(HierarchyRecord),
        model_choice=choice,
        model_choice_now=now,
        branch_count=branches,
        branch_count_now=branches_now,
        evidence_check=check,
        evidence_check_now=check_now,
    )
