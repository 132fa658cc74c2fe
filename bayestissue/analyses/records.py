"""The study stages' result records: one typed, versioned dataclass per stage (:mod:`bayestissue.io.records`).

Each stage of ``make study`` that another stage reads writes one record into the output folder (:data:`FILES`):

==================  =================================  ===========================================================
stage               record                             what it holds
==================  =================================  ===========================================================
calibration         :class:`CalibrationRecord`         every calibration run: verdicts, posterior table, recovery
identifiability     :class:`IdentifiabilityRecord`     least squares, profiles, local analysis, posterior measures
T1 vs T2            :class:`DiscrepancyRecord`         tension, cross-prediction, rates, specimen models, cut
controls            :class:`ControlsRecord`            scenarios and every pair's least-squares fits
measured data       :class:`MeasuredRecord`            the real-data cases: fits, posteriors, verdicts
laws                :class:`LawChoiceRecord`           each law on each material: transfer, joint evidence
specimens           :class:`HierarchyRecord`           the hierarchical model's cases (analyses.hierarchy_record)
full model          :class:`ModelChoiceRecord`         mirror vs 11-parameter model by nested runs (model_choice)
branches            :class:`BranchCountRecord`         the tendon's Prony branch count by nested runs (branch_count)
evidence check      :class:`EvidenceCheckRecord`       the models' evidence by importance sampling (evidence_check)
==================  =================================  ===========================================================

Records hold measurements, not verdicts: the report applies the rules of :mod:`bayestissue.analyses.verdicts` to
them. Per-test tables are keyed by the test's label (``"T1"``, ``"T2"``, ``"joint"``); per-parameter lists follow
the record's ``names``. Raise ``VERSION`` when a field changes; a reader of an older file is then refused by name.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

# fmt: off
__all__ = [
    "FILES", "CalibrationRecord", "CalibrationRun", "ControlPair", "ControlsRecord", "CrossPrediction",
    "CutPosterior", "CutTest", "DiscrepancyRecord", "FitCheck", "Fibre1Check", "IdentifiabilityRecord",
    "LawChoiceRecord", "TissueTermsRecord", "LawFit", "LocalAnalysis", "MaterialLaws", "MeasuredResult",
    "MeasuredRecord", "PairFit", "ParameterRow", "PosteriorMeasures", "PosteriorSummary", "Profile",
    "ProfileReference", "RateProfile", "RateStudy", "RateTruth", "ScenarioInfo", "SpecimenModel", "Tension",
    "HierarchyCase", "HierarchyRecord",
]
# fmt: on


# ---------------------------------------------------------------------------------------------------- shared pieces
@dataclass(frozen=True)
class Tension:
    """:math:`Q = \\chi^2_{joint} - \\sum_k \\chi^2_k` against :math:`\\chi^2_{df}` (identifiability.tension)."""

    Q: float
    df: int
    p_value: float


@dataclass(frozen=True)
class FitCheck:
    """The posterior predictive check of one experiment (:mod:`bayestissue.inference.fit_check`)."""

    noise_ratio: float | None
    lag1: float
    coverage: float
    misfit: bool


# -------------------------------------------------------------------------------------------------------- calibration
@dataclass(frozen=True)
class ParameterRow:
    """One parameter of a calibration's summary table (natural units; ``generating`` None for a joint run)."""

    name: str
    unit: str
    generating: float | None
    q05: float
    median: float
    q95: float
    rhat: float
    contraction: float
    lower: float
    upper: float


@dataclass(frozen=True)
class CalibrationRun:
    """One run of the calibration stage (``studies/calibrate.py``)."""

    experiments: list[str]
    model: str
    engine: str
    converged: bool | None
    convergence: str
    misfit: bool | None
    fit_check: str
    parameters: list[ParameterRow]
    loglik_q05: float | None
    loglik_q95: float | None
    loglik_max: float | None
    seconds: float


@dataclass(frozen=True)
class CalibrationRecord:
    SCHEMA: ClassVar[str] = "bayestissue.calibration"
    VERSION: ClassVar[int] = 1

    mode: str
    runs: dict[str, CalibrationRun]


# ----------------------------------------------------------------------------------------------------- identifiability
@dataclass(frozen=True)
class PosteriorSummary:
    """A mirror-model posterior expanded to the paper's 11 parameters, with its least-squares optimum."""

    ls_x: list[float]
    ls_chi2: float
    chi2_parts: list[float]
    ls_active: list[bool]
    ls_start_chi2: list[float]
    n_obs: int
    median: list[float]
    q05: list[float]
    q95: list[float]
    rhat: list[float] | None
    acceptance: float
    n_draws: int
    n_failed: int
    n_dropped: int
    time_mcmc_s: float
    results_file: str
    converged: bool
    convergence: str
    fit: dict[str, FitCheck]
    tied: dict[str, str]
    u_mean: list[float]
    u_sd: list[float]
    skew: list[float]
    kurt: list[float]


@dataclass(frozen=True)
class ProfileReference:
    """The optimum the profiles are measured from, and the restarts that improved it."""

    chi2_calibration: float
    chi2_polished: float
    chi2_final: float
    n_restarts: int
    improvements: list[float]
    restart_from: list[str]
    converged: bool
    improvement_tol: float
    max_restarts: int
    theta_final: list[float]
    theta_calibration: list[float]
    at_bound_final: list[int]
    first_classifications: dict[str, str]


@dataclass(frozen=True)
class LocalAnalysis:
    """Scaled sensitivities at the best optimum: singular values, Brun et al. (2001) collinearity, directions."""

    theta: list[float]
    singular_values: list[float]
    se_log: list[float]
    delta_msqr: list[float]
    sloppiest: list[dict[str, float]]
    stiffest: list[dict[str, float]]
    largest_subsets: list[tuple[list[str], float]]
    pairs: list[tuple[list[str], float]]
    n_subsets_ok: int
    n_subsets: int
    n_informed: int


@dataclass(frozen=True)
class Profile:
    """One profile likelihood (Raue et al. 2009); ``ci`` sides are None where the profile stays open."""

    name: str
    classification: str
    ci: tuple[float | None, float | None]
    theta_hat: float
    open: tuple[bool, bool]
    improved: bool
    n_points: int
    max_delta: float
    min_delta: float


@dataclass(frozen=True)
class PosteriorMeasures:
    """What the posterior learnt in the scaled box: contraction, KL, mass at the bounds, strongest correlations."""

    contraction: list[float]
    kl: list[float]
    at_lower: list[bool]
    at_upper: list[bool]
    share_lower: list[float]
    share_upper: list[float]
    max_abs_corr: list[tuple[str, str, float]]


@dataclass(frozen=True)
class Fibre1Check:
    """The built-in sanity check: fibre family 1's parameters (ginf1, gamma1, beta1) stay uninformed."""

    contraction: list[float]
    kl: list[float]
    sensitivity: list[float]
    contraction_corrected: list[float]
    kl_corrected: list[float]
    se_contraction: list[float]
    se_kl: list[float]
    tol_contraction: list[float]
    tol_kl: list[float]
    uninformed: list[bool]
    t: float
    n_batches: int
    n_draws: int
    share_draws_fibre1_tension: float
    max_E22: dict[str, float]
    max_tau1_kpa: dict[str, float]


@dataclass(frozen=True)
class IdentifiabilityRecord:
    SCHEMA: ClassVar[str] = "bayestissue.identifiability"
    VERSION: ClassVar[int] = 1

    mode: str
    names: list[str]
    cache_salt: str
    calibration: dict[str, PosteriorSummary]
    profile_reference: dict[str, ProfileReference]
    local: dict[str, LocalAnalysis]
    profiles: dict[str, list[Profile]]
    posterior: dict[str, PosteriorMeasures]
    fibre1: dict[str, Fibre1Check]
    swap_symmetry_max_abs_mm: float
    figures: list[str]
    timings_s: dict[str, float]


# ------------------------------------------------------------------------------------------------------------ T1 vs T2
@dataclass(frozen=True)
class CrossPrediction:
    """Posterior predictive of one test from one posterior (``coverage`` of its 90 % band, exact elpd)."""

    coverage: float
    elpd: float
    n: int
    n_failed: int


@dataclass(frozen=True)
class RateProfile:
    """Profiles of the fibre viscosity at one rate factor (``classification``, ``ci`` by parameter)."""

    n_restarts: int
    improvements: list[float]
    converged: bool
    classification: dict[str, str]
    ci: dict[str, tuple[float | None, float | None]]


@dataclass(frozen=True)
class RateTruth:
    """The profiles at T2's rate when the truth is one draw of T1's mirror posterior (``truth`` by parameter)."""

    truth: dict[str, float]
    classification: dict[str, str]
    ci: dict[str, tuple[float | None, float | None]]


@dataclass(frozen=True)
class RateStudy:
    """T2-like ramps at rate factors f x the T2 rate, data from the T1 mirror posterior's best draw; ``at_t2`` the
    same question at T2's rate asked of further draws of that posterior as truths (does the answer hold across it?)."""

    factors: list[float]
    ramp_s: list[float]
    se_log: dict[str, list[float]]
    profiles: dict[str, RateProfile]
    truth: list[float]
    at_t2: list[RateTruth]


@dataclass(frozen=True)
class SpecimenModel:
    """A joint fit with one specimen-level parameter of T2 (a stiffness scale, or a fibre half-angle)."""

    estimate: float
    chi2: float
    delta_chi2: float
    lr_p: float
    delta_bic: float
    remaining: Tension
    z_vs_stereology: float | None


@dataclass(frozen=True)
class CutTest:
    """Central 90 % widths (scaled box) of one test's posteriors with and without the stereological uncertainty."""

    base_width: list[float]
    cut_width: list[float]
    within_width: list[float]
    ls_u_spread: list[float]
    acceptance: float
    coordinates: str


@dataclass(frozen=True)
class CutPosterior:
    """Posteriors per stereology replicate, pooled (cut posterior)."""

    tests: dict[str, CutTest]
    steps: int
    adapt: list[int]
    bc_pooled: list[float]
    half_angle_mean: float
    half_angle_sd: float
    phi_fibre_sd: list[float]
    n_replicates_table: int
    n_used: int


@dataclass(frozen=True)
class DiscrepancyRecord:
    SCHEMA: ClassVar[str] = "bayestissue.t1_vs_t2"
    VERSION: ClassVar[int] = 2

    mode: str
    names: list[str]
    bhattacharyya: list[float]
    cross_prediction: dict[str, CrossPrediction]
    tension: Tension
    tension_effective: Tension
    chi2: dict[str, float]
    chi2_joint_parts: list[float]
    loo_khat: dict[str, float]
    principal_angles_deg: list[float]
    n_informed: dict[str, int]
    rates: RateStudy
    scale: SpecimenModel
    angle: SpecimenModel
    cut: CutPosterior | None
    figures: list[str]
    timings_s: dict[str, float]


# ------------------------------------------------------------------------------------------------------------ controls
@dataclass(frozen=True)
class ScenarioInfo:
    name: str
    planted: list[int]
    strength: str


@dataclass(frozen=True)
class PairFit:
    """Least squares of one pair (:func:`bayestissue.analyses.controls.analyse_pair`): chi2 per model ("T1", "T2",
    "joint" and the cause models "1", "2", "3", "1+2", ...), their extra and specimen-level parameter counts."""

    chi2: dict[str, float]
    extra: dict[str, int]
    specimen: dict[str, int]
    n: int
    angle_deg: float | None
    scale: float | None


@dataclass(frozen=True)
class ControlPair:
    scenario: str
    planted: list[int]
    seed: int
    fit: PairFit


@dataclass(frozen=True)
class ControlsRecord:
    SCHEMA: ClassVar[str] = "bayestissue.controls"
    VERSION: ClassVar[int] = 1

    mode: str
    n_seeds: int
    n_shared: int
    noise_sd_mm: float
    base_parameters: list[float]
    scenarios: list[ScenarioInfo]
    pairs: list[ControlPair]
    data: PairFit
    timings_s: dict[str, float]


# ------------------------------------------------------------------------------------------------------- measured data
@dataclass(frozen=True)
class MeasuredResult:
    """One real-data case: the matrix law on a measured curve (kPa)."""

    name: str
    material: str
    engine: str
    stretch: tuple[float, float]
    n: int
    closed_form: dict[str, float]
    least_squares: dict[str, float]
    posterior: dict[str, tuple[float, float, float]]
    converged: bool
    verdict: str
    seconds: float


@dataclass(frozen=True)
class MeasuredRecord:
    SCHEMA: ClassVar[str] = "bayestissue.measured"
    VERSION: ClassVar[int] = 1

    mode: str
    cases: list[MeasuredResult]


# ------------------------------------------------------------------------------------------------------------ laws
@dataclass(frozen=True)
class LawFit:
    """One law calibrated on some modes of a material (:mod:`bayestissue.analyses.law_choice`). Per-mode entries are
    keyed by the mode's label, for every mode of the material (fitted or predicted); quantiles are (median, 5 %,
    95 %); ``peak_log_likelihood`` is at the least-squares optimum with each mode's plug-in noise sd."""

    law: str
    fitted_on: list[str]
    names: list[str]
    posterior: dict[str, tuple[float, float, float]]
    noise_sd: dict[str, tuple[float, float, float]]
    log_z: float
    log_z_err: float
    peak_log_likelihood: float
    converged: bool
    verdict: str
    band_share: dict[str, float]
    relative_rms: dict[str, float]
    n_evaluations: int
    seconds: float


@dataclass(frozen=True)
class MaterialLaws:
    """Every law on one material: calibrated on its first mode alone (``transfer``) and on all (``joint``)."""

    name: str
    title: str
    modes: list[str]
    points: dict[str, int]
    units: dict[str, str]
    transfer: list[LawFit]
    joint: list[LawFit]
    figure: str
    #: a published one-term Ogden exponent range to compare with (Budday et al. 2017 for brain), or None
    alpha_published: tuple[float, float] | None


@dataclass(frozen=True)
class LawChoiceRecord:
    SCHEMA: ClassVar[str] = "bayestissue.laws"
    VERSION: ClassVar[int] = 1
    mode: str
    materials: list[MaterialLaws]
    seconds: float


@dataclass(frozen=True)
class TissueTermsRecord:
    """Calibration posteriors in a tissue's terms (workflows.tissue_terms): run -> quantity -> [median, q05, q95]."""

    SCHEMA: ClassVar[str] = "bayestissue.tissue_terms"
    VERSION: ClassVar[int] = 1
    mode: str
    strain: float
    units: dict[str, str]
    runs: dict[str, dict[str, list[float]]]


from bayestissue.analyses.branch_count import BranchCountRecord  # noqa: E402
from bayestissue.analyses.evidence_check import EvidenceCheckRecord  # noqa: E402
from bayestissue.analyses.hierarchy_record import HierarchyCase, HierarchyRecord  # noqa: E402
from bayestissue.analyses.model_choice import ModelChoiceRecord  # noqa: E402

#: Each record's file name in the study's output folder.
FILES = {
    CalibrationRecord: "calibration_record.json",
    IdentifiabilityRecord: "identifiability_record.json",
    DiscrepancyRecord: "t1_vs_t2_record.json",
    ControlsRecord: "controls_record.json",
    MeasuredRecord: "measured_record.json",
    LawChoiceRecord: "laws_record.json",
    TissueTermsRecord: "tissue_terms_record.json",
    HierarchyRecord: "hierarchy_record.json",
    ModelChoiceRecord: "model_choice_record.json",
    BranchCountRecord: "branch_count_record.json",
    EvidenceCheckRecord: "evidence_check_record.json",
}
