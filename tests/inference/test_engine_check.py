"""The emcee verdict's independent check (bayestissue.inference.engine_check): two samples of one posterior agree,
a sample that missed an arm is caught and named, each of the two guards (share of the width, Monte Carlo errors)
keeps its false alarm away, and a disagreement makes the verdict NOT CONVERGED."""

from dataclasses import replace

import numpy as np

from bayestissue.inference.diagnostics import ConvergenceReport, quantile_mcse
from bayestissue.inference.engine_check import compare_samples

NAMES = ("x0", "x1")


def _unit(x):  # a box [-10, 10] per coordinate, uniform
    return (np.asarray(x) + 10.0) / 20.0


def _normal(n, seed):
    rng = np.random.default_rng(seed)
    z = rng.standard_normal((n, 2))
    return np.column_stack([z[:, 0], 0.8 * z[:, 0] + 0.6 * z[:, 1]])


def _errors(x):
    return quantile_mcse(x, np.full(x.shape[1], x.shape[0]), np.full(x.shape[1], x.shape[0]))


def _check(a, b, **kw):
    return compare_samples(NAMES, a, _errors(a), b, _errors(b), _unit, **kw)


def test_two_samples_of_one_posterior_agree():
    for seed in range(5):
        a, b = _normal(4000, seed), _normal(4000, 100 + seed)
        check = _check(a, b)
        assert check.agree, check.text()
        assert np.max(check.rel) < 0.1 and np.max(check.z) < 4.0
        assert check.text().startswith("cross-checked by a nested run")


def test_a_sample_that_missed_an_arm_is_caught_and_named():
    rng = np.random.default_rng(7)
    a = _normal(4000, 1)  # the ensembles' sample: the main arm only
    b = _normal(4000, 2)
    arm = rng.random(4000) < 0.25  # the nested sample: a quarter of the mass in a second arm along x0
    b[arm, 0] += 4.0
    check = _check(a, b)
    assert not check.agree
    assert check.differs[0, 2] and not check.differs[1].any(), check.text()
    text = check.text()
    assert "disagrees" in text and "x0 95 %" in text and "x1" not in text
    assert "the nested 90 % ranges are the wider (the ensembles' likelier to have missed a region)" in text
    # the other way round: the nested sample is the one that cut the arm
    assert "the nested 90 % ranges are the narrower" in _check(b, a).text()


def test_the_two_guards():
    a = _normal(4000, 3)
    shifted = a + np.array([0.5, 0.0])  # 0.5 sd: 0.15 of the 90 % width of x0
    # large Monte Carlo errors (an ESS of 20): the shift is within 4 errors, no alarm
    few = quantile_mcse(a, np.full(2, 20.0), np.full(2, 20.0))
    assert compare_samples(NAMES, a, few, shifted, few, _unit).agree
    # tiny errors, but the difference is below a tenth of the width: no alarm
    tiny = np.full((2, 3), 1e-6)
    small = a + np.array([0.2, 0.0])  # 0.06 of the width
    check = compare_samples(NAMES, a, tiny, small, tiny, _unit)
    assert check.agree and np.max(check.z) > 4.0
    # both exceeded: an alarm
    assert not compare_samples(NAMES, a, tiny, shifted, tiny, _unit).agree


def _report(check):
    ok = np.ones(2)
    return ConvergenceReport(
        names=NAMES, rhat=ok, ess_bulk=ok * 1000, ess_tail=ok * 1000, tau=np.full((2, 2), 10.0),
        n_steps=np.array([1000, 1000]), length_ok=np.array([True, True]), acceptance=np.full((2, 8), 0.3),
        stuck=np.zeros((2, 8), bool), n_draws=8000, rhat_max=1.01, ess_min=400.0, tau_factor=50.0, time_s=1.0,
        engine_check=check,
    )  # fmt: skip


def test_a_disagreeing_engine_makes_the_verdict_not_converged():
    a, b = _normal(4000, 1), _normal(4000, 2)
    assert _report(None).converged and "cross-checked" not in _report(None).verdict()
    agree = _report(_check(a, b))
    assert agree.converged and "cross-checked by a nested run" in agree.verdict()
    b[:1000, 0] += 4.0
    bad = _report(_check(a, b))
    assert not bad.converged
    assert bad.verdict().startswith("NOT CONVERGED: a nested run of the same posterior disagrees")
    assert replace(bad, engine_check=None).converged


def test_the_verdict_says_what_to_do():
    a, b = _normal(4000, 1), _normal(4000, 2)
    assert _report(_check(a, b)).advice() == []
    b[:1000, 0] += 4.0
    (line,) = _report(_check(a, b)).advice()
    assert 'engine = "nested"' in line and "cross_check.md" in line
    short = replace(_report(None), length_ok=np.array([True, False]), tau=np.array([[10.0, 10.0], [30.0, 80.0]]))
    (line,) = short.advice()
    assert "--resume and [sampler] max_steps = 6000" in line  # 1.5 x 50 x 80 = 6000
    apart = replace(_report(None), rhat=np.array([1.0, 1.2]), apart=((1, [1], 0.5),))
    assert any('proposal = "shared"' in line for line in apart.advice())


def test_markdown_has_a_row_per_parameter():
    a, b = _normal(2000, 1), _normal(2000, 2)
    b[:500, 0] += 4.0
    md = _check(a, b).markdown()
    rows = [line for line in md.splitlines() if line.startswith("| x")]
    assert len(rows) == 2 and rows[0].endswith("DIFFERS |") and not rows[1].endswith("DIFFERS |")


def test_the_line_names_the_largest_differences_and_counts_the_rest():
    a = _normal(4000, 1)
    b = a + np.array([2.0, 1.0])  # every quantile of both parameters moved; x0 the more
    check = _check(a, b)
    assert int(check.differs.sum()) == 6
    text = check.text()
    assert text.count(" vs ") == 4 and "2 more (cross_check.md)" in text
    assert text.index("x0") < text.index("x1")  # largest first
