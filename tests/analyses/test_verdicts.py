"""Every verdict rule at, just below and just above its threshold (bayestissue.analyses.verdicts)."""

import numpy as np
import pytest

from bayestissue.analyses import verdicts as V

EPS = 1e-9


def _around(x):
    """(just below, at, just above) ``x``."""
    return x * (1 - EPS) if x else -EPS, x, x * (1 + EPS) if x else EPS


def test_difference_is_real_at_its_two_thresholds():
    below, at, above = _around(V.TENSION_P)
    assert V.difference_is_real(below, [0.1, 0.1])
    assert not V.difference_is_real(at, [0.1, 0.1])  # strictly below
    assert not V.difference_is_real(above, [0.1, 0.1])
    below, at, above = _around(V.CROSS_PREDICTION_MAX)
    assert V.difference_is_real(0.0, [below, 0.0])
    assert not V.difference_is_real(0.0, [at, 0.0])
    assert not V.difference_is_real(0.0, [0.0, above])


def test_tension_threshold_is_the_chi2_quantile():
    assert V.tension_threshold(8) == pytest.approx(26.1245, abs=1e-4)
    assert V.tension_threshold(11) == pytest.approx(31.2641, abs=1e-4)


def test_improvement_and_ties_at_their_thresholds():
    below, at, above = _around(V.CHI2_1_95)
    assert not V.improvement_matters(below) and not V.improvement_matters(at) and V.improvement_matters(above)
    below, at, above = _around(V.TIES_P)
    assert V.ties_rejected(below) and not V.ties_rejected(at) and not V.ties_rejected(above)
    # the likelihood-ratio p of 2 x 1.5 on 3 df, and of a model the data fit worse (statistic clipped at 0)
    assert V.likelihood_ratio_p(1.5, 3) == pytest.approx(0.3916, abs=1e-4)
    assert V.likelihood_ratio_p(-1.0, 3) == 1.0


def test_informed_at_its_threshold():
    below, at, above = _around(V.INFORMED_CONTRACTION)
    assert not V.informed(below) and V.informed(at) and V.informed(above)


def test_posterior_flags_at_their_thresholds():
    base = dict(ls_at_bound=False, share_lower=0.0, share_upper=0.0, profile_closed=True, skew=0.0, kurt=3.0)
    assert V.posterior_flags(**base) == ""
    below, at, above = _around(V.BOUND_SHARE)
    assert V.posterior_flags(**{**base, "share_lower": below}) == ""
    assert V.posterior_flags(**{**base, "share_lower": at}) == ""
    assert V.posterior_flags(**{**base, "share_upper": above}) == "B"
    assert V.posterior_flags(**{**base, "ls_at_bound": True}) == "B"
    assert V.posterior_flags(**{**base, "profile_closed": False}) == "F"
    assert V.posterior_flags(**{**base, "profile_closed": None}) == ""  # not profiled: no F
    below, at, above = _around(V.SKEW_FLAG)
    kurt = 10.0  # large: the bimodality coefficient stays far below its threshold
    assert V.posterior_flags(**{**base, "skew": below, "kurt": kurt}) == ""
    assert V.posterior_flags(**{**base, "skew": -at, "kurt": kurt}) == ""
    assert V.posterior_flags(**{**base, "skew": -above, "kurt": kurt}) == "S"
    # bimodality coefficient (skew^2 + 1) / kurt around 5/9: kurt just above the threshold's kurt reads below it
    k_at = 1.0 / V.BIMODALITY_FLAG
    assert V.posterior_flags(**{**base, "kurt": k_at * (1 + EPS)}) == ""
    assert V.posterior_flags(**{**base, "kurt": k_at * (1 - EPS)}) == "M"
    assert V.posterior_flags(**{**base, "kurt": 0.0}) == ""  # undefined: no flag
    assert V.posterior_flags(ls_at_bound=True, share_lower=1, share_upper=0, profile_closed=False, skew=3,
                             kurt=1) == "B F S M"  # fmt: skip


def test_planted_found_at_four_of_five():
    assert V.planted_found(4, 5) and not V.planted_found(3, 5) and V.planted_found(5, 5)
    assert V.planted_found(8, 10) and not V.planted_found(7, 10)


N = 544  # ln(544) = 6.30: BIC needs a chi2 drop > 10 + 6.30 k


def _chi2(joint, law, angle, scale, pairs=None, t1=400.0, t2=140.0):
    """Chosen chi-square values; the pair models default to no better than their best single."""
    chi2 = {"T1": t1, "T2": t2, "joint": joint, "1": law, "2": angle, "3": scale}
    for key, (a, b) in (("1+2", ("1", "2")), ("1+3", ("1", "3")), ("2+3", ("2", "3"))):
        chi2[key] = (pairs or {}).get(key, min(chi2[a], chi2[b]))
    return chi2


EXTRA = {k: 3 * (1 in c) + (2 in c) + (3 in c) for k, c in V.CAUSE_MODELS.items()}
SPECIMEN = {k: (2 in c) + (3 in c) for k, c in V.CAUSE_MODELS.items()}


def _verdict(*args, **kw):
    return V.controls_verdict(_chi2(*args, **kw), EXTRA, SPECIMEN, N, n_shared=8)


def test_controls_rules_on_chosen_numbers():
    """Each branch once; chi2_8 at p = 0.001 is 26.1, chi2_7 24.3."""
    v = _verdict(565.0, 560.0, 560.0, 560.0)  # Q = 25 < 26.1
    assert not v.different and v.kind == "no difference" and v.named == ()
    v = _verdict(640.0, 640.0, 550.0, 600.0)  # only the angle removes the tension
    assert v.different and v.kind == "named" and v.named == (2,)
    v = _verdict(640.0, 640.0, 550.0, 555.0)  # angle and scale within 10 of each other
    assert v.kind == "indistinguishable" and v.named == (2, 3)
    v = _verdict(9000.0, 8990.0, 600.0, 590.0)  # both help a lot, neither removes the tension
    assert v.kind == "partial" and v.named == (2, 3)
    v = _verdict(640.0, 640.0, 635.0, 635.0)  # nothing helps
    assert v.kind == "unexplained" and v.named == ()
    v = _verdict(600.0, 560.0, 600.0, 600.0)  # the richer law: drop 40 > 10 + 3 x 6.3 = 28.9
    assert v.named == (1,) and v.causes["1"].delta_bic == pytest.approx(40 - 3 * np.log(N))
    v = _verdict(9000.0, 8990.0, 9000.0, 600.0, pairs={"1+3": 545.0})  # the pair removes it, beats each single
    assert v.kind == "combination" and v.named == (1, 3) and v.models == ("1+3",)
    v = _verdict(9000.0, 8990.0, 9000.0, 600.0, pairs={"1+3": 590.0})  # no better than its best single: partial
    assert v.kind == "partial" and v.named == (3,)


def test_tension_rules_at_the_p_threshold():
    below, at, above = _around(V.TENSION_P)
    assert V.significant_tension(below) and not V.significant_tension(at) and not V.significant_tension(above)
    assert not V.acceptable_remainder(below) and V.acceptable_remainder(at) and V.acceptable_remainder(above)


def test_controls_difference_either_side_of_the_tension_threshold():
    """Q just below / above chi2_8's 0.999 quantile (at the quantile itself p is 1e-3 only to rounding: the rule's
    boundary is tested in p above)."""
    q = V.tension_threshold(8)
    for dq, different in ((-1e-6, False), (1e-6, True)):
        v = _verdict(540.0 + q + dq, 540.0 + q + dq, 540.0 + q + dq, 540.0 + q + dq)
        assert v.different is different


def test_controls_bic_margin_at_its_threshold():
    """The angle model (1 extra parameter): preferred iff the chi2 drop exceeds 10 + ln n."""
    joint = 640.0
    margin = V.CAUSE_DBIC + np.log(N)
    for d, preferred in ((margin - 1e-6, False), (margin, False), (margin + 1e-6, True)):
        v = _verdict(joint, joint, joint - d, joint)
        assert v.causes["2"].preferred is preferred


def test_controls_remaining_tension_at_its_threshold():
    """The angle model explains iff its remaining tension (7 df) has p >= 0.001."""
    q7 = V.tension_threshold(7)
    for dq, explains in ((-1e-6, True), (1e-6, False)):
        v = _verdict(2000.0, 2000.0, 540.0 + q7 + dq, 2000.0)
        assert v.causes["2"].explains is explains


def test_controls_tie_at_its_threshold():
    for d, tie in ((V.CAUSE_TIE_DCHI2 - 1e-6, True), (V.CAUSE_TIE_DCHI2, False), (V.CAUSE_TIE_DCHI2 + 1e-6, False)):
        v = _verdict(2000.0, 2000.0, 545.0, 545.0 + d)
        assert (v.kind == "indistinguishable") is tie and v.named == ((2, 3) if tie else (2,))


def test_confusion_and_verdict_text():
    rows = [
        ("none", (), _verdict(565.0, 560.0, 560.0, 560.0)),
        ("none", (), _verdict(640.0, 640.0, 550.0, 600.0)),  # a false difference
        ("angle", (2,), _verdict(640.0, 640.0, 550.0, 555.0)),  # named among indistinguishable ones
        ("angle", (2,), _verdict(640.0, 640.0, 635.0, 635.0)),
    ]
    table = V.confusion(rows)
    assert table["none"] == {"planted": (), "n": 2, "verdicts": {"none": 1, "2 (named)": 1}, "named": 1}
    assert table["angle"]["named"] == 1 and table["angle"]["verdicts"]["unexplained (unexplained)"] == 1
    assert V.verdict_text("2+3 (indistinguishable)") == "fibre angle + specimen stiffness (indistinguishable)"
    assert V.verdict_text("none") == "no difference" and V.verdict_text("unexplained (unexplained)") == "unexplained"


@pytest.mark.parametrize(
    ("threshold", "below", "at_or_above"),
    [
        (V.BAYES_POSITIVE, "not worth more than a mention", "positive"),
        (V.BAYES_STRONG, "positive", "strong"),
        (V.BAYES_VERY_STRONG, "strong", "very strong"),
    ],
)
def test_evidence_strength_at_its_thresholds(threshold, below, at_or_above):
    err = 0.01
    assert V.evidence_strength(threshold - 1e-9, err) == below
    assert V.evidence_strength(threshold, err) == at_or_above
    assert V.evidence_strength(threshold + 1e-9, err) == at_or_above


def test_runs_agree_on_the_evidence_from_enough_finished_runs_at_the_peak_with_a_consistent_scatter():
    """At the scatter's p threshold they agree, just below it not; nor with fewer runs than the minimum, a capped
    run, or a run that missed the peak."""
    ok = [True] * V.EVIDENCE_MIN_RUNS
    assert V.evidence_consistent(V.EVIDENCE_P, ok)
    assert not V.evidence_consistent(V.EVIDENCE_P * (1 - 1e-9), ok)
    assert not V.evidence_consistent(0.9, ok[1:])
    assert not V.evidence_consistent(0.9, [False] + ok[1:])
    assert V.evidence_consistent(0.9, ok + [True])
    assert not V.evidence_consistent(float("nan"), ok)


def test_the_evidence_decides_only_from_consistent_runs_and_a_positive_grade():
    """1 nat (positive) with a small error decides either way round; just below 1 nat, within two errors, or from
    runs that disagree on the evidence, it does not."""
    assert V.evidence_decides(V.BAYES_POSITIVE, 0.01, True)
    assert V.evidence_decides(-V.BAYES_POSITIVE, 0.01, True)
    assert not V.evidence_decides(V.BAYES_POSITIVE - 1e-9, 0.01, True)
    assert not V.evidence_decides(V.BAYES_POSITIVE, 0.01, False)
    assert not V.evidence_decides(6.0, 3.0, True)  # within two errors
    assert V.evidence_decides(6.0 + 1e-9, 3.0, True)


def test_evidence_strength_within_its_error():
    """A factor of 10 nats with an error of 5 is no preference; just above two errors it is graded."""
    assert V.evidence_strength(10.0, 5.0) == "within error"
    assert V.evidence_strength(10.0 + 1e-9, 5.0) == "very strong"
    assert V.evidence_strength(10.0 - 1e-9, 5.0) == "within error"
    assert V.evidence_strength(float("nan"), 0.1) == "within error"


def test_a_model_whose_runs_disagree_is_rejected_only_below_its_highest_run_plus_two_of_their_sds():
    """Four scattered runs (sd 0.2 nats, highest -10): rejected where the favoured model is 1 nat (positive) above
    -10 + 2 x 0.2, not 1e-6 nat less; never by a favoured model whose own runs disagree, never with a run capped or
    short of the peak, never from fewer runs than the minimum. The tendon's three-branch runs (docs/verification.md)
    are rejected by two branches: bound -537.402 + 2 x 0.170, 1.43 nats below -535.633."""
    runs = -10.0 + 0.2 * np.array([0.0, -1.0, -2.0, -1.0]) / np.std([0.0, -1.0, -2.0, -1.0], ddof=1)
    runs += -10.0 - runs.max()
    bound = -10.0 + V.SCATTER_MARGIN * 0.2
    ok = [True] * 4
    assert V.evidence_rejects_scattered((bound + V.BAYES_POSITIVE, 0.01), True, runs, ok)
    assert not V.evidence_rejects_scattered((bound + V.BAYES_POSITIVE - 1e-6, 0.01), True, runs, ok)
    assert not V.evidence_rejects_scattered((bound + 3.0, 0.01), False, runs, ok)
    assert not V.evidence_rejects_scattered((bound + 3.0, 0.01), True, runs, [True, True, False, True])
    assert not V.evidence_rejects_scattered((bound + 3.0, 0.01), True, runs[:3], ok[:3])
    assert not V.evidence_rejects_scattered((bound + 3.0, 2.0), True, runs, ok)  # within the favoured model's error
    tendon = [-537.7866732089002, -537.4017466999592, -537.70419378969, -537.5553267919369]
    assert V.evidence_rejects_scattered((-535.6329357295343, 0.013935758778963697), True, tendon, ok)
    assert V.evidence_rejects_scattered((-537.402 + 0.34 + 1.01, 0.01), True, tendon, ok)
    assert not V.evidence_rejects_scattered((-537.402 + 0.34 + 0.99, 0.01), True, tendon, ok)


def _f(favours, decides, trusted=True):
    return {"favours": favours, "decides": decides, "trusted": trusted}


def test_the_choice_by_two_estimators():
    """The trusted importance-sampling factor rules (a decision or a within-error factor that overrules the nested
    runs); two decisions for different models choose nothing; without a trusted check the nested runs rule."""
    assert V.evidence_choice(_f("mirror", True), _f("mirror", True)) == ("mirror", "importance sampling")
    assert V.evidence_choice(None, _f("full", True)) == ("full", "importance sampling")
    assert V.evidence_choice(_f("mirror", True), _f("mirror", False)) == (None, "not decided")
    assert V.evidence_choice(_f("mirror", True), _f("full", True)) == (None, "the estimators disagree")
    assert V.evidence_choice(_f("mirror", False), _f("full", True)) == ("full", "importance sampling")
    assert V.evidence_choice(_f("mirror", True), _f("full", True, trusted=False)) == ("mirror", "nested runs")
    assert V.evidence_choice(_f("mirror", True), None) == ("mirror", "nested runs")
    assert V.evidence_choice(_f("mirror", False), _f("full", True, trusted=False)) == (None, "not decided")
    assert V.evidence_choice(None, None) == (None, "not decided")


def test_two_estimates_are_apart_beyond_two_combined_errors():
    err = np.hypot(0.3, 0.4)  # 0.5
    assert not V.estimators_apart((1.0, 0.3), (1.0 + 2 * err - 1e-9, 0.4))
    assert V.estimators_apart((1.0, 0.3), (1.0 + 2 * err + 1e-9, 0.4))
    assert V.estimators_apart((1.0, 0.3), (1.0 - 2 * err - 1e-9, 0.4))
