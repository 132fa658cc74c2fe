"""The evidence under narrowed and widened log boxes (analyses.box_width) against closed forms.

The runs are importance samples of a box prior (uniform in ln theta on [1e-3, 1e3], a second, uniform parameter that
the likelihood ignores), weighted by a likelihood whose integral over any interval is a normal CDF or a flat
stretch, so every evidence is known in closed form. Tolerance 0.01 in ln Z: 200 000 points per run estimate a
posterior share of about 0.5 to a relative error of about 0.003."""

import math
from types import SimpleNamespace

import numpy as np
import pytest
from scipy.special import logsumexp
from scipy.stats import norm

from bayestissue.analyses.box_width import box_shift, box_shift_weighted, merge_runs

LO, HI = 1e-3, 1e3
A, B, W, LF = math.log(LO), math.log(HI), math.log(HI / LO), math.log(10.0)
SPECS = [SimpleNamespace(name="k", prior="loguniform", lower=LO, upper=HI),
         SimpleNamespace(name="g", prior="uniform", lower=0.0, upper=1.0)]  # fmt: skip


def _runs(log_like, n=200_000, n_runs=4, boot=False):
    runs = []
    for k in range(n_runs):
        rng = np.random.default_rng(k)
        u = rng.uniform(A, B, n)
        x = np.column_stack([np.exp(u), rng.uniform(0, 1, n)])
        lw = log_like(u)
        lw = lw - logsumexp(lw)
        reps = None
        if boot:
            reps = np.exp(lw)[:, None] * rng.poisson(1.0, (n, 50))
            reps = reps / reps.sum(axis=0)
        runs.append(SimpleNamespace(points=x, log_w=lw, bootstrap_weights=reps))
    return runs


def _gauss(m, s):
    return lambda u: norm.logpdf(u, m, s)


def _log_z_gauss(m, s, a, b):
    """ln of the evidence of the Gaussian likelihood in ln theta under a log-uniform prior on [e^a, e^b]."""
    return math.log(norm.cdf(b, m, s) - norm.cdf(a, m, s)) - math.log(b - a)


@pytest.mark.parametrize("m, s", [(0.0, 0.5 * LF), (A + 0.5 * LF, LF)])
def test_narrowing_matches_the_closed_form(m, s):
    """A posterior in the middle of the box (4 sd inside the new bounds) loses only prior volume; one against the
    lower bound also loses the mass below the new bound."""
    shift = box_shift(_runs(_gauss(m, s)), SPECS)
    exact = _log_z_gauss(m, s, A + LF, B - LF) - _log_z_gauss(m, s, A, B)
    assert shift.names == ["k"]
    assert shift.narrowed[0] == pytest.approx(exact, abs=0.01)
    assert all(v == pytest.approx(exact, abs=0.02) for v in shift.narrowed_runs)
    if m == 0.0:
        assert exact == pytest.approx(math.log(W / (W - 2 * LF)), abs=1e-3)
    else:
        assert exact < math.log(W / (W - 2 * LF)) - 0.5


def test_widening_the_volume_term_bounds_and_the_flat_estimate_matches_a_flat_likelihood():
    """Likelihood 1 below ln theta = A + 2 ln 10 (and so beyond the lower bound), a Gaussian fall above it: the
    exact widened evidence adds ln 10 of flat likelihood below the old bound. The volume term is a lower bound, the
    flat estimate exact (its one assumption holds)."""
    c, s = A + 2 * LF, 1.0

    def log_like(u):
        return np.where(u < c, 0.0, -0.5 * ((u - c) / s) ** 2)

    shift = box_shift(_runs(log_like), SPECS)
    mass_old = (c - A) + s * math.sqrt(2 * math.pi) / 2  # integral of L over the old box (in ln theta)
    exact = math.log((mass_old + LF) / (W + 2 * LF)) - math.log(mass_old / W)
    volume = -math.log((W + 2 * LF) / W)
    assert shift.widened_volume == pytest.approx(volume, rel=1e-12)
    assert volume < exact - 0.25
    assert shift.widened_flat == pytest.approx(exact, abs=0.01)
    lo, hi = shift.edge_share[0]
    assert lo == pytest.approx(LF / mass_old, abs=0.005) and hi < 1e-9


def test_the_merged_error_uses_the_runs_own_bootstrap_or_their_scatter():
    shift = box_shift(_runs(_gauss(A + 0.5 * LF, LF), n=20_000, boot=True), SPECS)
    assert all(0 < e < 0.05 for e in shift.narrowed_errs)
    v, e = merge_runs(shift.narrowed_runs, shift.narrowed_errs)
    assert (v, e) == shift.narrowed
    scatter = np.std(shift.narrowed_runs, ddof=1) / 2
    own = math.sqrt(sum(x**2 for x in shift.narrowed_errs)) / 4
    assert e == pytest.approx(max(scatter, own))
    assert merge_runs([1.0, 3.0], [math.nan, math.nan]) == (2.0, pytest.approx(1.0))


def test_a_model_without_a_log_scaled_parameter_is_refused():
    with pytest.raises(ValueError, match="no log-uniform parameter"):
        box_shift(_runs(_gauss(0.0, 1.0), n=100, n_runs=1), SPECS[1:] * 2)


def _weighted(log_like, n, seed):
    """Importance draws of the box prior from a proposal that is not the prior (a Gaussian in ln theta, sd 3, centred
    1 above the box's middle, cut to the box), weighted by likelihood x prior / proposal."""
    rng = np.random.default_rng(seed)
    u = rng.normal(1.0, 3.0, 4 * n)
    u = u[(u > A) & (u < B)][:n]
    x = np.column_stack([np.exp(u), rng.uniform(0, 1, u.size)])
    lw = log_like(u) - norm.logpdf(u, 1.0, 3.0)
    w = np.exp(lw - lw.max())
    return x, w, w.sum() ** 2 / np.sum(w**2)


@pytest.mark.parametrize("m, s, inside", [(A + 0.5 * LF, LF, False), (0.0, 0.5 * LF, True)])
def test_weighted_draws_narrow_to_the_closed_form_within_their_stated_error(m, s, inside):
    """Over 200 independent weighted samples of 2 000 draws, the narrowed shift scatters about the closed form as
    its stated error says: mean within 3 standard errors of the mean, and, for a posterior against the bound (about
    half its mass cut), the spread of the standardised errors within 0.75-1.35 (the binomial error from the Kish size
    is an approximation; 200 replicates estimate a spread of 1 to about +-0.05). For a posterior 4 sd inside the new
    bounds (6e-5 of its mass cut) the error is that of a share of 1, an upper bound: the spread is below 0.1."""
    exact = _log_z_gauss(m, s, A + LF, B - LF) - _log_z_gauss(m, s, A, B)
    shifts = [box_shift_weighted(*_weighted(_gauss(m, s), 2000, k), SPECS) for k in range(200)]
    v = np.array([b.narrowed[0] for b in shifts])
    e = np.array([b.narrowed[1] for b in shifts])
    assert all(b.narrowed_runs == [b.narrowed[0]] and b.narrowed_errs == [b.narrowed[1]] for b in shifts)
    assert abs(v.mean() - exact) < 3 * v.std(ddof=1) / math.sqrt(v.size) + 1e-3
    z = (v - exact) / e
    assert z.std(ddof=1) < 0.1 if inside else 0.75 < z.std(ddof=1) < 1.35


def test_weighted_draws_all_inside_still_carry_an_error_and_match_the_runs_on_widening():
    """A posterior far inside the narrowed box (8 sd) keeps all its weight: the shift is the volume term alone, with
    the error of a share of 1 among n_e draws (about 1 / n_e). Widening and the edge shares are those of box_shift."""
    x, w, ess = _weighted(_gauss(0.0, 0.25 * LF), 50_000, 1)
    b = box_shift_weighted(x, w, ess, SPECS)
    assert b.narrowed[0] == pytest.approx(math.log(W / (W - 2 * LF)), abs=1e-9)
    assert 0.5 / (ess + 2) < b.narrowed[1] < 1.5 / (ess + 2)
    run = SimpleNamespace(points=x, log_w=np.log(w / w.sum()), bootstrap_weights=None)
    ref = box_shift([run], SPECS)
    assert b.widened_volume == ref.widened_volume
    assert b.widened_flat == pytest.approx(ref.widened_flat, abs=1e-15)
    assert np.allclose(b.edge_share, ref.edge_share, rtol=1e-12, atol=0)  # weights normalised once or twice


def test_weighted_draws_are_checked():
    x, w, ess = _weighted(_gauss(0.0, 1.0), 100, 2)
    with pytest.raises(ValueError, match=r"expected \(n, 2\) points"):
        box_shift_weighted(x[:, :1], w, ess, SPECS)
    with pytest.raises(ValueError, match="non-negative weights"):
        box_shift_weighted(x, -w, ess, SPECS)
    with pytest.raises(ValueError, match="effective sample size 0.5"):
        box_shift_weighted(x, w, 0.5, SPECS)
