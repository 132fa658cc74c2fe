"""Ordered label groups (inference.ordering.OrderedGroup): the prior restricted to one labelling of terms the data
cannot tell apart, its normalisation, the nested sampler's bijective transform onto it, relabelling, and when a group
applies."""

import math

import numpy as np
import pytest
from scipy import stats

from bayestissue._validation import ValidationError
from bayestissue.inference import CalibrationProblem, ExperimentTerm, GaussianNoise, ParameterSet, ParameterSpec
from bayestissue.inference.ordering import OrderedGroup, folded, swapped


def _terms(n: int, box=(-5.0, 5.0)):
    """``n`` exchangeable terms (key ``a<t>`` uniform on ``box``, companion ``m<t>`` log-uniform) and a bystander."""
    specs = []
    for t in range(1, n + 1):
        specs += [ParameterSpec(f"m{t}", "kPa", 0.1, 10.0, prior="loguniform"),
                  ParameterSpec(f"a{t}", "1", *box, prior="uniform")]  # fmt: skip
    specs.append(ParameterSpec("z", "1", 0.0, 1.0))
    group = OrderedGroup(tuple((f"a{t}", f"m{t}") for t in range(1, n + 1)))
    return ParameterSet(tuple(specs), ordered=(group,))


@pytest.mark.parametrize("n", [2, 3])
def test_prior_transform_gives_the_order_statistics(n):
    """Uniform quantiles through the transform: keys strictly decreasing in every draw, the k-th largest key in unit
    coordinates distributed as Beta(n - k + 1, k) (order statistics of n uniforms; KS, 20 000 draws, p > 0.01), the
    companions and the bystander still their box priors."""
    pars = _terms(n)
    q = np.random.default_rng(n).random((20000, pars.n_sampled))
    x = pars.from_prior_quantiles(q)
    keys = [pars.index(f"a{t}") for t in range(1, n + 1)]
    assert np.all(np.diff(x[:, keys], axis=1) < 0)
    assert np.all(np.isfinite(pars.log_prior(x)))
    for k, j in enumerate(keys, start=1):
        u = (x[:, j] + 5.0) / 10.0
        assert stats.kstest(u, stats.beta(n - k + 1, k).cdf).pvalue > 0.01, k
    for name in [f"m{t}" for t in range(1, n + 1)] + ["z"]:
        s = pars.sampled[pars.index(name)]
        assert stats.kstest(x[:, pars.index(name)], s.prior_dist.cdf).pvalue > 0.01, name


@pytest.mark.parametrize("n", [2, 3])
def test_restricted_prior_is_normalised(n):
    """The log prior is the box prior's plus log n! inside the ordered region and -inf outside; importance weights
    of box-prior draws integrate it to 1 (200 000 draws: the ordered share is 1/n!, within 4 binomial sd)."""
    pars = _terms(n)
    plain = ParameterSet(pars.specs)
    x = plain.sample_prior(200_000, rng=7)
    lp, lp0 = pars.log_prior(x), plain.log_prior(x)
    inside = np.isfinite(lp)
    np.testing.assert_allclose(lp[inside] - lp0[inside], math.log(math.factorial(n)))
    share = inside.mean()
    p = 1.0 / math.factorial(n)
    assert abs(share - p) < 4 * math.sqrt(p * (1 - p) / x.shape[0])
    mass = np.mean(np.exp(lp - lp0))  # E_box[p_ordered / p_box]
    assert mass == pytest.approx(1.0, abs=4 * math.sqrt((math.factorial(n) - 1) / x.shape[0]))
    draws = pars.sample_prior(1000, rng=8)
    assert np.all(np.isfinite(pars.log_prior(draws)))


def test_evidence_of_a_symmetric_likelihood_is_unchanged():
    """A likelihood symmetric in two terms (two bumps, one per labelling): the evidence through the ordered
    transform, E_q[L(T(q))], equals that of the box prior, E[L(x)], within 4 Monte Carlo standard errors (400 000
    draws each); the ordered draws see one bump."""
    pars = _terms(2)
    plain = ParameterSet(pars.specs)
    ia, ib = pars.index("a1"), pars.index("a2")

    def like(x):
        g = stats.norm(0.0, 0.5).pdf
        return g(x[:, ia] - 2.0) * g(x[:, ib] + 1.0) + g(x[:, ia] + 1.0) * g(x[:, ib] - 2.0)

    rng = np.random.default_rng(3)
    l_plain = like(plain.from_prior_quantiles(rng.random((400_000, pars.n_sampled))))
    x_ord = pars.from_prior_quantiles(rng.random((400_000, pars.n_sampled)))
    l_ord = like(x_ord)
    se = math.hypot(l_plain.std() / math.sqrt(l_plain.size), l_ord.std() / math.sqrt(l_ord.size))
    assert abs(l_plain.mean() - l_ord.mean()) < 4 * se
    heavy = l_ord > 0.1 * l_ord.max()
    assert np.all(x_ord[heavy, ia] > 0.5)  # only the labelling a1 ~ 2, a2 ~ -1


def test_canonical_permutes_whole_terms():
    """Relabelling: every permutation of the three terms of a point maps to the same ordered point, the companions
    travelling with their keys; the bystander is untouched; a point already in order is unchanged."""
    pars = _terms(3)
    point = {"a1": 3.0, "m1": 0.2, "a2": 1.0, "m2": 5.0, "a3": -2.0, "m3": 1.5, "z": 0.3}
    names = pars.sampled_names
    ordered = np.array([point[n] for n in names])
    rows = []
    for perm in [(0, 1, 2), (0, 2, 1), (1, 0, 2), (1, 2, 0), (2, 0, 1), (2, 1, 0)]:
        p = dict(point)
        for t, src in enumerate(perm, start=1):
            p[f"a{t}"], p[f"m{t}"] = point[f"a{src + 1}"], point[f"m{src + 1}"]
        rows.append([p[n] for n in names])
    out = pars.canonical(np.array(rows))
    np.testing.assert_array_equal(out, np.tile(ordered, (6, 1)))
    assert np.all(pars.in_order(out))
    assert not np.all(pars.in_order(np.array(rows)))


def test_group_applies_only_to_identical_sampled_terms():
    """A fixed or tied term leaves the group (two of three terms stay ordered; one of two: no group); a box given to
    one term only drops the group (its keys no longer share a prior); a non-exchangeable group needs only the keys'
    boxes to agree and is never relabelled."""
    pars = _terms(3)
    assert pars.ordered_text == "a1 > a2 > a3"
    assert pars.updated(fixed={"a2": 0.0}).ordered_text == "a1 > a3"
    assert _terms(2).updated(fixed={"m1": 1.0}).ordered_text == "none"
    assert pars.updated(tied={"a3": "a1"}).ordered_text == "a1 > a2"
    assert pars.updated(bounds={"a2": (-4.0, 5.0)}).ordered_text == "none"
    assert pars.updated(bounds={"m2": (0.1, 20.0)}).ordered_text == "none"
    loose = ParameterSet(pars.specs, ordered=(OrderedGroup((("a1",), ("a2", "m2")), exchangeable=False),))
    assert loose.updated(bounds={"m2": (0.1, 20.0)}).ordered_text == "a1 > a2"
    x = np.array([[1.0, -1.0, 1.0, 2.0, 1.0, 0.0, 0.5]])  # a1 < a2
    np.testing.assert_array_equal(loose.canonical(x), x)
    assert not np.isfinite(loose.log_prior(x)[0])


def test_bad_groups_are_refused():
    specs = _terms(2).specs
    with pytest.raises(ValidationError, match="ordered group parameter names"):
        ParameterSet(specs, ordered=(OrderedGroup((("a1",), ("b2",))),))
    with pytest.raises(ValidationError, match="two or more terms"):
        OrderedGroup((("a1", "m1"),))
    with pytest.raises(ValidationError, match="two or more terms"):
        OrderedGroup((("a1", "m1"), ("a2",)))


class _Sum:
    """Forward ``a1 + a2`` and ``a1 * a2`` (picklable): symmetric in the two keys."""

    def __call__(self, params):
        p = np.atleast_2d(params)
        return np.column_stack([np.repeat(p[:, [1]] + p[:, [3]], 5, 1), np.repeat(p[:, [1]] * p[:, [3]], 5, 1)])


def test_problem_carries_the_groups_to_its_parameters():
    """The calibration problem's full parameter set (material + noise) keeps the material's groups: its prior is
    -inf in the other labelling and its canonical relabels into the kept one."""
    pars = ParameterSet(_terms(2).specs[:4], ordered=_terms(2).ordered)
    y = np.concatenate([np.full(5, 1.0), np.full(5, -6.0)])
    problem = CalibrationProblem([ExperimentTerm("t", np.arange(10.0), y, _Sum(), GaussianNoise(sd=0.1))], pars)
    assert problem.parameters.ordered_text == "a1 > a2"
    good = np.array([1.0, 3.0, 2.0, -2.0])
    swapped = np.array([2.0, -2.0, 1.0, 3.0])
    assert problem.log_likelihood(good) == pytest.approx(problem.log_likelihood(swapped))
    assert np.isfinite(problem.log_prior(good)) and not np.isfinite(problem.log_prior(swapped))
    np.testing.assert_array_equal(problem.canonical(swapped), good)


def test_swapping_two_groups_is_an_involution_and_folding_keeps_one_copy():
    """The mirror exchange of two column groups (the full model's fibre families 2 and 3): swapping twice is the
    identity, folding leaves rows with a0 >= b0 alone, swaps the others, and folding again changes nothing."""
    rng = np.random.default_rng(3)
    x = rng.random((200, 7))
    swap = ((1, 2, 3), (4, 5, 6))
    np.testing.assert_array_equal(swapped(swapped(x, swap), swap), x)
    np.testing.assert_array_equal(swapped(x, swap)[:, [0, 4, 5, 6, 1, 2, 3]], x)
    f = folded(x, swap)
    assert np.all(f[:, 1] >= f[:, 4])
    kept = x[:, 1] >= x[:, 4]
    assert 50 < kept.sum() < 150  # both branches are exercised
    np.testing.assert_array_equal(f[kept], x[kept])
    np.testing.assert_array_equal(f[~kept], swapped(x[~kept], swap))
    np.testing.assert_array_equal(folded(f, swap), f)
