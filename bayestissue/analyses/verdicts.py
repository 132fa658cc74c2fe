r"""Every verdict rule of the study, with its thresholds as named constants in this one place.

The study stages record measurements (:mod:`bayestissue.analyses.records`); these functions turn them into
verdicts, and the report only calls them. Each threshold below says why it has its value; the tests
(``tests/analyses/test_verdicts.py``) check every rule at, just below and just above its threshold.

Rules
-----
* **Is a difference between two tests real?** (:func:`difference_is_real`) the tension
  :math:`Q = \chi^2_{joint} - \chi^2_{T1} - \chi^2_{T2}` has :math:`p <` :data:`TENSION_P` and each posterior
  predicts less than :data:`CROSS_PREDICTION_MAX` of the other test's data inside its 90 % band.
* **Which cause?** (:func:`controls_verdict`) the controlled rules of the T1-vs-T2 controls: a difference if the
  tension has :math:`p <` :data:`TENSION_P` against :math:`\chi^2_{n_{shared}}`; a cause model *explains* it if BIC
  prefers it over the shared fit by more than :data:`CAUSE_DBIC` and its remaining tension has
  :math:`p \ge` :data:`TENSION_P`; single causes first, ties within :data:`CAUSE_TIE_DCHI2` of the best are
  *indistinguishable*; then pairs that beat each of their singles by BIC > :data:`CAUSE_DBIC` (*combination*);
  otherwise the causes BIC prefers (*partial*) or none (*unexplained*). The only cause verdicts of the report: the
  older per-cause rules (rate profile open on both sides; free angle within 3 stereological sd; one stiffness scale
  with BIC > 10) were never run on the controls and are retired; their analyses are reported as measurements.
* **Did a control find what was planted?** (:func:`planted_found`) in at least :data:`PLANTED_FOUND_SHARE` of the
  seeds (4 of 5).
* **Is a parameter informed by the data?** (:func:`informed`) contraction :math:`1 - \mathrm{var}_{post} /
  \mathrm{var}_{prior} \ge` :data:`INFORMED_CONTRACTION` in the scaled box.
* **Does a posterior read as a point estimate?** (:func:`posterior_flags`) B: bound active at the least-squares
  optimum, or more than :data:`BOUND_SHARE` of the draws in the outer :data:`BOUND_EDGE` of the box; F: profile
  not closed; S: :math:`|\mathrm{skewness}| >` :data:`SKEW_FLAG`; M: bimodality coefficient
  :math:`(g^2 + 1)/\kappa >` :data:`BIMODALITY_FLAG`.
* **Does an improvement of the optimum matter?** (:func:`improvement_matters`) :math:`\Delta\chi^2 >`
  :data:`~bayestissue.identifiability.CHI2_1_95` (one degree of freedom, 95 %).
* **Can the data tell a tied model from the untied one?** (:func:`ties_rejected`) likelihood-ratio
  :math:`p <` :data:`TIES_P`.
* **Which law do the data support?** (:func:`evidence_strength`) the log Bayes factor :math:`\ln B` of the better
  law over another, on the scale of Kass & Raftery (1995, J Am Stat Assoc 90:773, their section 3.2, halved from
  :math:`2\ln B`): below :data:`BAYES_POSITIVE` *not worth more than a mention*, then *positive*, from
  :data:`BAYES_STRONG` *strong*, from :data:`BAYES_VERY_STRONG` *very strong*; a factor within
  :data:`BAYES_ERROR_SIGMAS` of its own Monte Carlo error is *within error*, whatever its size.
* **Do a model's nested runs agree on its evidence?** (:func:`evidence_consistent`) at least
  :data:`EVIDENCE_MIN_RUNS` runs, each finished (not capped) and reaching the least-squares peak, and the scatter of
  their :math:`\log\hat Z_k` consistent with the errors each run estimates for itself: :math:`\chi^2 = \sum_k
  (\log\hat Z_k - \overline{\log Z})^2/\sigma_k^2` on :math:`n - 1` degrees of freedom with :math:`p \ge`
  :data:`EVIDENCE_P` (Higson et al. 2018, doi:10.1093/mnras/sty1185: run-to-run scatter against each run's own
  error). This is the engine's evidence criterion
  (:class:`~bayestissue.inference.evidence.NestedReport`) without its absolute range below 0.2 nats: a Bayes factor
  needs an error it can trust, not a small one, since the error enters its grade.
* **Does the evidence choose the study's model?** (:func:`evidence_decides`) only if both models' runs agree on
  their evidence (above) and the factor is graded at least *positive*: an evidence from runs that disagree has no
  trustworthy error, and a smaller or within-error factor is no choice. The runs' posteriors need not have
  converged for this (their R-hat and quantiles are reported beside the factor): the factor is a property of the
  two evidences alone.
* **Can the evidence reject a model whose runs disagree?** (:func:`evidence_rejects_scattered`) only against a
  model whose runs agree (the favoured one), and only if every run of the rejected model finished and reached the
  peak, and the factor over a generous upper estimate of the rejected evidence, its highest run plus
  :data:`SCATTER_MARGIN` standard deviations of its runs, :math:`\ln\hat Z_a - (\max_k \ln\hat Z_{b,k} + 2 s_b)`,
  is still graded at least *positive* against the favoured model's own error. Runs that scatter beyond their own
  errors share out a multimodal posterior differently, and a nested run that misses posterior mass estimates too
  small an evidence (an importance-sampling sum over a proposal that misses mass sums less), so the disagreement
  makes the rejected evidence uncertain upwards mostly; the margin covers a run's share of the scatter the other
  way. The rule never favours a model whose runs disagree. It was written after the synthetic tendon's three-branch
  runs disagreed (docs/verification.md), so it is reported beside the factor, never silently.
* **Which model does a data set's evidence choose, by two estimators?** (:func:`evidence_choice`) the factor from
  importance sampling (:mod:`~bayestissue.analyses.evidence_check`) rules where both its evidences are trusted
  (Pareto k-hat below 0.7, batches consistent): its error is checked by the weights' tail and by independent
  batches, where a nested runs' error is only checked by their scatter. It chooses by the grades above; a trusted
  factor within error overrules a nested factor that decides. Where both estimators decide for different models,
  nothing is chosen. Without a trusted importance-sampling factor, the nested runs' :func:`evidence_decides` rules.
  The two factors are *apart* (:func:`estimators_apart`) when they differ by more than :data:`ESTIMATORS_APART`
  of their combined errors: reported, since one of them has missed mass or misjudged its error.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.stats import chi2 as chi2_dist

from bayestissue.identifiability import CHI2_1_95, tension
from bayestissue.inference.evidence import NestedReport
from bayestissue.inference.summary import PRIOR_DOMINATED_CONTRACTION

__all__ = [
    "DECISIVE_GRADES",
    "EVIDENCE_MIN_RUNS",
    "EVIDENCE_P",
    "ESTIMATORS_APART",
    "estimators_apart",
    "evidence_choice",
    "evidence_consistent",
    "evidence_decides",
    "evidence_rejects_scattered",
    "scattered_upper",
    "SCATTER_MARGIN",
    "BAYES_ERROR_SIGMAS",
    "BAYES_POSITIVE",
    "BAYES_STRONG",
    "BAYES_VERY_STRONG",
    "BIMODALITY_FLAG",
    "BOUND_EDGE",
    "BOUND_SHARE",
    "CAUSES",
    "CAUSE_DBIC",
    "CAUSE_MODELS",
    "CAUSE_TIE_DCHI2",
    "CHI2_1_95",
    "CROSS_PREDICTION_MAX",
    "CauseTest",
    "ControlsVerdict",
    "INFORMED_CONTRACTION",
    "PLANTED_FOUND_SHARE",
    "SKEW_FLAG",
    "TENSION_P",
    "TIES_P",
    "acceptable_remainder",
    "confusion",
    "controls_verdict",
    "difference_is_real",
    "evidence_strength",
    "improvement_matters",
    "informed",
    "likelihood_ratio_p",
    "planted_found",
    "posterior_flags",
    "significant_tension",
    "tension_threshold",
    "ties_rejected",
    "verdict_key",
    "verdict_text",
]

#: A difference between two tests is real if the tension's p-value is below this: 1e-3 (about 3.3 sigma) keeps
#: the rate of false differences at 1 in 1000 pairs of one tissue; the controls measured 0 of 5.
TENSION_P = 1e-3
#: ... and each posterior predicts less than this share of the other test's data inside its 90 % band (a posterior
#: that described both tests would hold about 90 %).
CROSS_PREDICTION_MAX = 0.5
#: A cause model is preferred if its BIC is lower than the shared fit's by more than 10: "very strong" evidence on
#: Kass & Raftery's (1995) scale; also the margin a pair of causes must beat each single cause by.
CAUSE_DBIC = 10.0
#: Explaining cause models within this chi2 of the best are indistinguishable (the same scale as CAUSE_DBIC).
CAUSE_TIE_DCHI2 = 10.0
#: A planted cause counts as found if it is named in at least this share of the noise seeds (4 of 5).
PLANTED_FOUND_SHARE = 0.8
#: A parameter is informed if its posterior variance is at most 70 % of the prior's in the scaled box (the
#: complement of the summary table's prior_dominated flag).
INFORMED_CONTRACTION = PRIOR_DOMINATED_CONTRACTION
#: Mass piled against a bound: more than BOUND_SHARE of the draws in the outer BOUND_EDGE of the box (a flat
#: marginal puts BOUND_EDGE there, so this is 2.5 times that).
BOUND_EDGE = 0.02
BOUND_SHARE = 0.05
#: A skewed marginal: |skewness| above 1 (Bulmer 1979: "highly skewed").
SKEW_FLAG = 1.0
#: A possibly multimodal marginal: Sarle's bimodality coefficient above 5/9, its value for the uniform law.
BIMODALITY_FLAG = 0.555
#: Ties between parameters are rejected by the data if the likelihood ratio against the untied model has p below
#: this (the usual 5 % test level).
TIES_P = 0.05

#: The causes of the controlled rules: number -> short name.
#: Kass & Raftery's grades of a log Bayes factor (their 2 ln B of 2, 6 and 10): odds of e (2.7), e^3 (20), e^5 (150).
BAYES_POSITIVE = 1.0
BAYES_STRONG = 3.0
BAYES_VERY_STRONG = 5.0
#: ... and a factor smaller than this many of its own standard errors (the runs' scatter) is not a preference.
BAYES_ERROR_SIGMAS = 2.0
#: A model's runs agree on its evidence if their log Z scatter against their own errors has p at least this (the
#: engine's level, :attr:`~bayestissue.inference.evidence.NestedReport.p_min`, 0.01), from at least this many runs
#: (the engine's minimum, 4: fewer cannot show a scatter).
EVIDENCE_P = NestedReport.p_min
EVIDENCE_MIN_RUNS = NestedReport.min_runs
#: A model whose runs disagree is rejected only if its highest run plus this many standard deviations of its runs
#: still lies a positive grade below the favoured model (:func:`evidence_rejects_scattered`; 2: about 95 % one-sided
#: for one further run under a normal scatter).
SCATTER_MARGIN = 2.0
#: Two estimates of one log Bayes factor are apart if they differ by more than this many of their combined errors.
ESTIMATORS_APART = 2.0
CAUSES = {1: "fibre law", 2: "fibre angle", 3: "specimen stiffness"}
#: The cause models the controls fit, by key: the causes each one includes.
CAUSE_MODELS = {"1": (1,), "2": (2,), "3": (3,), "1+2": (1, 2), "1+3": (1, 3), "2+3": (2, 3)}


# ------------------------------------------------------------------------------------------------ difference and ties
def tension_threshold(df: int) -> float:
    """The tension Q above which :data:`TENSION_P` is passed against :math:`\\chi^2_{df}`."""
    return float(chi2_dist.isf(TENSION_P, df))


def significant_tension(p: float) -> bool:
    """A tension whose p-value is below :data:`TENSION_P`: the tests disagree beyond their noise."""
    return bool(p < TENSION_P)


def acceptable_remainder(p: float) -> bool:
    """A remaining tension whose p-value is at least :data:`TENSION_P`: what is left is noise."""
    return not significant_tension(p)


def difference_is_real(tension_p: float, coverages) -> bool:
    """A :func:`significant_tension`, and every cross-prediction coverage below :data:`CROSS_PREDICTION_MAX`."""
    return significant_tension(tension_p) and all(c < CROSS_PREDICTION_MAX for c in coverages)


def likelihood_ratio_p(delta_loglik: float, df: int) -> float:
    """p-value of the likelihood-ratio statistic :math:`2\\Delta\\ell` against :math:`\\chi^2_{df}`."""
    return float(chi2_dist.sf(max(2.0 * float(delta_loglik), 0.0), df))


def ties_rejected(lr_p: float) -> bool:
    """The data reject the tied model (likelihood-ratio p below :data:`TIES_P`)."""
    return bool(lr_p < TIES_P)


def improvement_matters(delta_chi2: float) -> bool:
    """An improvement of the least-squares optimum larger than the one-parameter 95 % profile threshold."""
    return bool(delta_chi2 > CHI2_1_95)


# ---------------------------------------------------------------------------------------------------- posteriors
def informed(contraction: float) -> bool:
    """The data inform the parameter: contraction at least :data:`INFORMED_CONTRACTION`."""
    return bool(contraction >= INFORMED_CONTRACTION)


def posterior_flags(
    *, ls_at_bound: bool, share_lower: float, share_upper: float, profile_closed: bool | None, skew: float, kurt: float
) -> str:
    """The reading flags of one parameter: ``B``, ``F``, ``S``, ``M`` (module docstring), space-separated."""
    flags = []
    if ls_at_bound or share_lower > BOUND_SHARE or share_upper > BOUND_SHARE:
        flags.append("B")
    if profile_closed is False:
        flags.append("F")
    if abs(skew) > SKEW_FLAG:
        flags.append("S")
    if kurt > 0 and (skew**2 + 1) / kurt > BIMODALITY_FLAG:
        flags.append("M")
    return " ".join(flags)


# ---------------------------------------------------------------------------------------------------------- causes
@dataclass(frozen=True)
class CauseTest:
    """One cause model against the shared fit."""

    delta_chi2: float
    delta_bic: float
    remaining_Q: float
    remaining_p: float
    preferred: bool
    explains: bool


@dataclass(frozen=True)
class ControlsVerdict:
    """The controlled rules' verdict on one pair: ``kind`` is "no difference", "named", "indistinguishable",
    "combination", "indistinguishable combinations", "partial" or "unexplained"; ``named`` the causes (ints)."""

    Q: float
    p: float
    different: bool
    causes: dict[str, CauseTest]
    named: tuple[int, ...] = ()
    kind: str = "no difference"
    models: tuple[str, ...] = field(default=())


def _ties(chi2: dict, keys) -> tuple[str, ...]:
    best = min(chi2[k] for k in keys)
    return tuple(sorted(k for k in keys if chi2[k] - best < CAUSE_TIE_DCHI2))


def controls_verdict(chi2: dict, extra: dict, specimen: dict, n: int, *, n_shared: int) -> ControlsVerdict:
    """The controlled rules (module docstring) on one pair's least-squares fits.

    Parameters
    ----------
    chi2 : chi-square of ``"T1"``, ``"T2"``, ``"joint"`` and of the fitted cause models (keys of
        :data:`CAUSE_MODELS`; a pair model may be absent when the rules never reach it).
    extra, specimen : per cause model, its parameters beyond the shared fit and how many of them are
        specimen-level (they lower the remaining tension's degrees of freedom).
    n : data points of the pair (the BIC's :math:`\\ln n`).
    n_shared : shared material parameters (the tension's degrees of freedom).
    """
    parts = [chi2["T1"], chi2["T2"]]
    t = tension(chi2["joint"], parts, n_shared)
    fitted = [k for k in CAUSE_MODELS if k in chi2]
    bic = {k: chi2[k] + extra[k] * np.log(n) for k in fitted}
    causes = {}
    for k in fitted:
        dbic = chi2["joint"] - bic[k]  # the shared fit has no extra parameters
        rem = tension(chi2[k], parts, n_shared - specimen[k])
        singles = CAUSE_MODELS[k]
        needed = all(bic[str(s)] - bic[k] > CAUSE_DBIC for s in singles) if len(singles) > 1 else True
        causes[k] = CauseTest(
            delta_chi2=float(chi2["joint"] - chi2[k]),
            delta_bic=float(dbic),
            remaining_Q=rem["Q"],
            remaining_p=rem["p_value"],
            preferred=bool(dbic > CAUSE_DBIC),
            explains=bool(dbic > CAUSE_DBIC and acceptable_remainder(rem["p_value"]) and needed),
        )
    base = {"Q": t["Q"], "p": t["p_value"], "different": significant_tension(t["p_value"]), "causes": causes}
    if not base["different"]:
        return ControlsVerdict(**base)
    singles = [k for k in fitted if len(CAUSE_MODELS[k]) == 1]
    pairs = [k for k in fitted if len(CAUSE_MODELS[k]) == 2]
    for keys, one, several in ((singles, "named", "indistinguishable"),
                               (pairs, "combination", "indistinguishable combinations")):  # fmt: skip
        explaining = [k for k in keys if causes[k].explains]
        if explaining:
            named = _ties(chi2, explaining)
            causes_named = tuple(sorted({c for k in named for c in CAUSE_MODELS[k]}))
            kind = one if len(named) == 1 else several
            return ControlsVerdict(**base, named=causes_named, kind=kind, models=named)
    preferred = tuple(int(k) for k in ("1", "2", "3") if k in causes and causes[k].preferred)
    return ControlsVerdict(**base, named=preferred, kind="partial" if preferred else "unexplained")


def verdict_key(v: ControlsVerdict) -> str:
    """A verdict as a short key: ``"none"``, ``"2+3 (indistinguishable)"``, ``"unexplained (unexplained)"``."""
    if not v.different:
        return "none"
    return ("+".join(map(str, v.named)) or "unexplained") + f" ({v.kind})"


def verdict_text(key: str, *, sep: str = " ") -> str:
    """A :func:`verdict_key` in words, e.g. ``"2+3 (indistinguishable)"`` -> ``"fibre angle + specimen stiffness
    (indistinguishable)"`` (``sep`` before the bracket)."""
    if key == "none":
        return "no difference"
    named, _, kind = key.partition(" (")
    if named == "unexplained":
        return "unexplained"
    return " + ".join(CAUSES[int(k)] for k in named.split("+")) + f"{sep}({kind.rstrip(')')})"


def planted_found(n_found: int, n: int) -> bool:
    """A control scenario finds its planted cause in at least :data:`PLANTED_FOUND_SHARE` of its seeds."""
    return bool(n_found >= PLANTED_FOUND_SHARE * n)


def confusion(rows) -> dict:
    """Per scenario: how often each verdict came out and in how many seeds the planted cause was named (alone or
    among indistinguishable ones; for the negative control: no difference called).

    ``rows``: ``(scenario name, planted causes, ControlsVerdict)`` triples. Returns, per scenario, ``planted``
    (tuple), ``n``, ``verdicts`` (key -> count, :func:`verdict_key`) and ``named`` (count)."""
    table = {}
    for name, planted, v in rows:
        row = table.setdefault(name, {"planted": tuple(planted), "n": 0, "verdicts": {}, "named": 0})
        key = verdict_key(v)
        row["n"] += 1
        row["verdicts"][key] = row["verdicts"].get(key, 0) + 1
        planted = set(planted)
        ok = (not v.different) if not planted else (v.different and planted <= set(v.named))
        row["named"] += int(ok)
    return table


def evidence_strength(log_bayes: float, error: float) -> str:
    """The grade of a log Bayes factor ``log_bayes`` >= 0 with standard error ``error`` (module docstring)."""
    if not np.isfinite(log_bayes) or not log_bayes > BAYES_ERROR_SIGMAS * error:
        return "within error"
    if log_bayes >= BAYES_VERY_STRONG:
        return "very strong"
    if log_bayes >= BAYES_STRONG:
        return "strong"
    if log_bayes >= BAYES_POSITIVE:
        return "positive"
    return "not worth more than a mention"


#: The grades of :func:`evidence_strength` that choose a model.
DECISIVE_GRADES = ("positive", "strong", "very strong")


def evidence_consistent(scatter_p: float, runs_ok) -> bool:
    """Whether one model's nested runs agree on its evidence (module docstring): ``scatter_p`` the p-value of their
    log Z scatter against their own errors, ``runs_ok`` per run whether it finished and reached the peak."""
    runs_ok = list(runs_ok)
    return bool(len(runs_ok) >= EVIDENCE_MIN_RUNS and all(runs_ok) and scatter_p >= EVIDENCE_P)


def evidence_decides(log_bayes: float, error: float, consistent: bool) -> bool:
    """Whether a log Bayes factor (either sign) with standard error ``error`` chooses between two models whose runs
    are ``consistent`` (both, :func:`evidence_consistent`; module docstring)."""
    return bool(consistent and evidence_strength(abs(log_bayes), error) in DECISIVE_GRADES)


def evidence_rejects_scattered(favoured: tuple[float, float], favoured_agree: bool, rejected_runs, runs_ok) -> bool:
    """Whether the evidence rejects a model whose runs disagree on its evidence (module docstring): ``favoured`` the
    favoured model's merged (log Z, error), whose runs must agree (``favoured_agree``, :func:`evidence_consistent`);
    ``rejected_runs`` the other model's per-run log Z, ``runs_ok`` per run whether it finished and reached the
    peak."""
    z = np.asarray(list(rejected_runs), dtype=float)
    runs_ok = list(runs_ok)
    if not (favoured_agree and len(runs_ok) == z.size >= EVIDENCE_MIN_RUNS and all(runs_ok)):
        return False
    return evidence_strength(favoured[0] - scattered_upper(z), favoured[1]) in DECISIVE_GRADES


def scattered_upper(runs) -> float:
    """The generous upper estimate of an evidence whose runs disagree (:func:`evidence_rejects_scattered`): the
    highest run's log Z plus :data:`SCATTER_MARGIN` sample standard deviations of the runs."""
    z = np.asarray(list(runs), dtype=float)
    return float(np.max(z) + SCATTER_MARGIN * np.std(z, ddof=1))


def evidence_choice(nested: dict | None, check: dict | None) -> tuple[str | None, str]:
    """The model a data set's evidence chooses and by what (module docstring): ``nested`` the nested runs' factor
    and ``check`` the importance-sampling factor, each a mapping with ``favours`` and ``decides`` (``check`` also
    ``trusted``), or None where it has not been computed. Returns ``(model or None, source)``, ``source`` one of
    ``"importance sampling"``, ``"nested runs"``, ``"the estimators disagree"``, ``"not decided"``."""
    if check is not None and check["trusted"]:
        if nested is not None and nested["decides"] and check["decides"] and nested["favours"] != check["favours"]:
            return None, "the estimators disagree"
        return (check["favours"], "importance sampling") if check["decides"] else (None, "not decided")
    if nested is not None and nested["decides"]:
        return nested["favours"], "nested runs"
    return None, "not decided"


def estimators_apart(a: tuple[float, float], b: tuple[float, float]) -> bool:
    """Whether two estimates ``(ln B, error)`` of one factor differ by more than :data:`ESTIMATORS_APART` of their
    combined errors."""
    return bool(abs(a[0] - b[0]) > ESTIMATORS_APART * float(np.hypot(a[1], b[1])))
