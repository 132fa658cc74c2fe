"""One coordinate integrated out by quadrature (inference/sampling/collapsed.py): the inner integral against its
closed form and against scipy's adaptive quadrature, the evidence of a thin curved sheet of known evidence (where the
plain proposal fails), the counts of points it may have got wrong, seeds and bad settings."""

import dataclasses

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.special import expit, log_expit, logit

from bayestissue._validation import ValidationError
from bayestissue.inference.ordering import swapped
from bayestissue.inference.sampling.collapsed import fit_line
from bayestissue.inference.sampling.importance import ImportanceOptions, fit_unit_proposal, importance_evidence

K = 2  # the coordinate integrated out (not the last, so that the insertion is tested)
SD = 1e-4  # the sheet's thickness in logit units (the joint full model's: about 2e-4)


def _sheet_centre(z_rest):
    """The sheet's centre in z_K: curved (a parabola in one coordinate, a slope in another)."""
    return 0.4 * z_rest[:, 0] ** 2 + 0.3 * z_rest[:, 1] - 0.2


def _log_jac(z):
    return log_expit(z) + log_expit(-z)


def _sheet(skew=0.0):
    """A likelihood on the unit cube whose density in logit coordinates is
    :math:`p(z) = N(z_{-K}; 0, I)\\, N(z_K; c(z_{-K}), s^2)` (times :math:`e^{\\text{skew}\\, t^3}`, :math:`t` the
    standardised offset, when ``skew``): :math:`L(u) = p(z) / \\prod_j \\sigma(z_j)\\sigma(-z_j)`, so that
    :math:`Z = \\int p\\,dz = 1` and the inner integral is :math:`N(z_{-K}; 0, I)` over the other coordinates'
    Jacobian (without skew) exactly."""

    def log_l_unit(u):
        z = logit(u)
        zr = np.delete(z, K, axis=1)
        t = (z[:, K] - _sheet_centre(zr)) / SD
        log_p = -0.5 * np.sum(zr**2, axis=1) - 0.5 * t**2
        if skew:
            log_p = log_p + skew * t**3 / (1 + t**4)
        log_p -= 0.5 * z.shape[1] * np.log(2 * np.pi) + np.log(SD)
        with np.errstate(invalid="ignore"):  # a face of the cube (u rounded to 0 or 1): -inf - -inf
            out = log_p - np.sum(_log_jac(z), axis=1)
        return np.where(np.isnan(out), -np.inf, out)

    return log_l_unit


def _draws(n, d, rng):
    """Exact posterior draws of the sheet (unit cube)."""
    zr = rng.standard_normal((n, d - 1))
    zk = _sheet_centre(zr) + SD * rng.standard_normal(n)
    return expit(np.insert(zr, K, zk, axis=1))


def test_the_inner_integral_of_a_gaussian_conditional_is_exact():
    """Without skew :math:`L_c = N(z_{-K}; 0, I) / \\prod_{j \\ne K} \\sigma(z_j)\\sigma(-z_j)`: Gauss-Hermite is
    exact for a Gaussian conditional, so the only error is the Newton peak's and the central differences' round-off
    (1e-8 nats)."""
    d, rng = 4, np.random.default_rng(0)
    u = _draws(4000, d, rng)
    line = fit_line(u, np.full(len(u), 1 / len(u)), K)
    rest = np.delete(u, K, axis=1)[:50]
    zr = logit(rest)
    exact = -0.5 * np.sum(zr**2, axis=1) - 0.5 * (d - 1) * np.log(2 * np.pi) - np.sum(_log_jac(zr), axis=1)
    assert np.max(np.abs(line(_sheet(), rest) - exact)) < 1e-8
    assert (line.edge, line.flat, line.points) == (0, 0, 50)


def test_the_inner_integral_agrees_with_adaptive_quadrature_where_the_conditional_is_skewed():
    """A skewed conditional (the cubic term shifts the peak by about 0.3 sd and the mass): 12 nodes against
    scipy.integrate.quad over +-15 sd (its own error below 1e-10 relative) agree within 5e-4 nats (2.1e-4
    found), 24 nodes within 5e-5 (1.9e-5 found; the rule converges as the nodes grow, slowly for this
    non-polynomial skew)."""
    d, rng = 4, np.random.default_rng(1)
    u = _draws(4000, d, rng)
    log_l = _sheet(skew=0.3)
    rest = np.delete(u, K, axis=1)[:5]
    errors = {}
    for nodes in (12, 24):
        line = fit_line(u, np.full(len(u), 1 / len(u)), K, nodes=nodes)
        got = line(log_l, rest)
        errors[nodes] = []
        for i in range(len(rest)):
            zr = logit(rest[i : i + 1])
            c = _sheet_centre(zr)[0]

            def integrand(zk, i=i, offset=got[i]):  # scaled by the estimate, so that quad integrates numbers near one
                u_full = expit(np.insert(logit(rest[i : i + 1]), K, zk, axis=1))
                return np.exp(log_l(u_full)[0] + _log_jac(np.array([zk]))[0] - offset)

            val, _ = quad(integrand, c - 15 * SD, c + 15 * SD, epsabs=0, epsrel=1e-11, limit=200)
            errors[nodes].append(abs(np.log(val)))
    assert max(errors[12]) < 5e-4 and max(errors[24]) < 5e-5 and max(errors[24]) < 0.2 * max(errors[12]), errors


def test_the_evidence_of_a_thin_curved_sheet_where_the_plain_proposal_fails():
    """log Z = 0 exactly. From 4000 exact draws: the plain proposal on all 4 coordinates (8 components, 20 000 draws)
    gives Pareto k-hat above 0.7 (4.6 here; the sheet, 1e-4 thick and curved, is tiled with gaps; at 2e-4 k-hat
    was 0.39-0.47 but log Z -0.22 +- 0.10); the collapsed one on the other 3 (the conditional integrated by
    quadrature; 5000 draws) is trusted and within 4 of its errors and 0.03 of zero (0.014 +- 0.010 and
    0.001 +- 0.010 for two seeds of the draws). The few points counted as doubtful (2-5 of 5000) are the defensive
    prior's draws far off the sheet, where the regression extrapolates; their weight is negligible."""
    d, rng = 4, np.random.default_rng(2)
    u = _draws(4000, d, rng)
    log_l = _sheet()
    opts = ImportanceOptions(n_draws=20_000, adapt_rounds=0, n_components=8)
    plain = importance_evidence(log_l, fit_unit_proposal(u, opts, seed=3), opts, rng=4)
    assert plain.k_hat > 0.7, plain.verdict()
    line = fit_line(u, np.full(len(u), 1 / len(u)), K)
    opts = ImportanceOptions(n_draws=5_000, adapt_rounds=0, n_components=8)
    res = importance_evidence(line.collapsed(log_l), fit_unit_proposal(np.delete(u, K, axis=1), opts, seed=3), opts,
                              rng=4)  # fmt: skip
    assert res.trusted, res.verdict()
    assert abs(res.log_z) < max(4 * res.log_z_err, 0.005) and abs(res.log_z) < 0.03, res.verdict()
    assert line.edge + line.flat <= 10 and line.points == 5_000


def test_draws_of_the_integrated_coordinate_follow_its_conditional():
    """z_K drawn by the quadrature's Gaussian: offsets from the sheet's centre have sd SD (within 5 %, 4000 draws)
    and mean 0 (within 4 standard errors); the other coordinates are kept as given. Drawn from the peaks an earlier
    call found (``last_peaks``, what the evidence check does for its estimate's draws) the points are the same bit
    for bit, without a call."""
    d, rng = 4, np.random.default_rng(5)
    u = _draws(4000, d, rng)
    line = fit_line(u, np.full(len(u), 1 / len(u)), K)
    rest = np.delete(u, K, axis=1)
    full = line.draw(_sheet(), rest, np.random.default_rng(6))
    assert np.allclose(np.delete(full, K, axis=1), rest, rtol=0, atol=1e-12)
    t = (logit(full[:, K]) - _sheet_centre(logit(rest))) / SD
    assert abs(t.std() - 1) < 0.05 and abs(t.mean()) < 4 / np.sqrt(len(t))
    line(_sheet(), rest[:1000])
    line(_sheet(), rest)
    calls = line.calls
    m, s = line.last_peaks(len(rest))
    again = line.draw_at(rest, m, s, np.random.default_rng(6))
    assert line.calls == calls and np.array_equal(again, full)
    with pytest.raises(ValidationError, match="line quadrature points"):
        line.last_peaks(len(rest) + 1001)


def test_a_peak_outside_the_bracket_is_found_by_the_re_brackets():
    """A predictor moved off the sheet by twice the bracket (+-0.01, 11 points): the first bracket's maximum is on its
    edge at every point; the re-bracket centred there, twice as wide, holds the peak, so no point is counted and
    :math:`\\log L_c` is the closed form's (1e-8, as for the predictor on the sheet) at 11 more calls a point."""
    d, rng = 4, np.random.default_rng(7)
    u = _draws(500, d, rng)
    line = fit_line(u, np.full(len(u), 1 / len(u)), K, window=0.01, grid=11)
    line.coef = line.coef.copy()
    line.coef[0] += 0.02
    rest = np.delete(u, K, axis=1)[:40]
    zr = logit(rest)
    exact = -0.5 * np.sum(zr**2, axis=1) - 0.5 * (d - 1) * np.log(2 * np.pi) - np.sum(_log_jac(zr), axis=1)
    assert np.max(np.abs(line(_sheet(), rest) - exact)) < 1e-8
    assert (line.edge, line.flat) == (0, 0) and line.calls == 40 * (11 + 11 + 3 * 6 + 12)


@pytest.mark.parametrize(("shift", "rebracket"), [(0.02, 0), (0.5, 4)])
def test_a_peak_beyond_the_re_brackets_is_counted_not_hidden(shift, rebracket):
    """A peak the brackets cannot reach (twice the bracket off without re-brackets; 0.5 off, beyond the 31 windows
    that four doublings reach): every point is counted as on the edge, and the line says so (the estimate there would
    be low)."""
    d, rng = 4, np.random.default_rng(7)
    u = _draws(500, d, rng)
    line = fit_line(u, np.full(len(u), 1 / len(u)), K, window=0.01, grid=11, rebracket=rebracket)
    line.coef = line.coef.copy()
    line.coef[0] += shift
    line(_sheet(), np.delete(u, K, axis=1)[:40])
    assert line.edge == 40 and "edge at 40 of 40 points" in line.text()
    assert f"at most {rebracket} re-brackets" in line.text()


def test_same_seed_same_result():
    d = 4
    u = _draws(2000, d, np.random.default_rng(8))
    w = np.full(len(u), 1 / len(u))
    a, b = fit_line(u, w, K, seed=1), fit_line(u, w, K, seed=1)
    assert np.array_equal(a.coef, b.coef)
    rest = np.delete(u, K, axis=1)[:20]
    assert np.array_equal(a(_sheet(), rest), b(_sheet(), rest))


@pytest.mark.parametrize(
    ("kw", "field"),
    [({"window": 1e-6}, "line quadrature window"), ({"grid": 2}, "line quadrature grid"),
     ({"newton": 0}, "line quadrature newton"), ({"nodes": 1}, "line quadrature nodes"),
     ({"rebracket": -1}, "line quadrature rebracket")],
)  # fmt: skip
def test_bad_settings_name_the_field(kw, field):
    u = _draws(500, 4, np.random.default_rng(9))
    with pytest.raises(ValidationError, match=field):
        fit_line(u, np.full(len(u), 1 / len(u)), K, **kw)


def test_bad_draws_are_refused():
    u = _draws(100, 4, np.random.default_rng(10))
    with pytest.raises(ValidationError, match="line quadrature draws"):
        fit_line(u, np.full(len(u), 1 / len(u)), 4)


def test_a_mirror_symmetric_sheet_needs_the_regression_folded():
    """Two mirror copies of a sheet, exchanged by the other coordinates 1 and 2, whose centre in z_K is the same at a
    point and its mirror image (:math:`c = 0.5 |z_1 - z_2| + 0.2 z_0`, linear within each copy); the draws hold one
    copy only (as the joint full model's nautilus run did). Fitted without the fold, the regression predicts the
    other copy's peaks far off (more than 1 in logit, 10 000 sheet thicknesses) and, with the same bracket and no
    re-brackets, most of those points' peaks fall on its edge (counted); folded over the exchange it predicts both
    copies within half a thickness (the draws' own scatter about the centre), no peak is on the edge, and the
    evidence (log Z = 0 exactly; the proposal symmetrised) is within 4 errors and 0.03 of zero."""
    d, swap, rng = 5, ((1,), (2,)), np.random.default_rng(11)
    mu = np.array([0.0, 1.5, -1.5, 0.0])

    def centre(zr):
        return 0.5 * np.abs(zr[:, 1] - zr[:, 2]) + 0.2 * zr[:, 0]

    def log_l_unit(u):
        z = logit(u)
        zr = np.delete(z, K, axis=1)
        copies = [-0.5 * np.sum((zr - m) ** 2, axis=1) for m in (mu, mu[[0, 2, 1, 3]])]
        t = (z[:, K] - centre(zr)) / SD
        log_p = np.logaddexp(*copies) - np.log(2) - 0.5 * t**2 - 0.5 * d * np.log(2 * np.pi) - np.log(SD)
        with np.errstate(invalid="ignore"):
            out = log_p - np.sum(_log_jac(z), axis=1)
        return np.where(np.isnan(out), -np.inf, out)

    zr = mu + rng.standard_normal((4000, d - 1))  # one copy only
    zr = zr[zr[:, 1] > zr[:, 2]]
    u = expit(np.insert(zr, K, centre(zr) + SD * rng.standard_normal(len(zr)), axis=1))
    w = np.full(len(u), 1 / len(u))
    line = fit_line(u, w, K, swap=swap, window=0.5)
    # the same bracket, no fold, no re-brackets
    unfolded = dataclasses.replace(line, coef=fit_line(u, w, K).coef, swap=None, rebracket=0)
    mirrored = zr[:, [0, 2, 1, 3]][:300]
    assert np.max(np.abs(line.predict(mirrored) - centre(mirrored))) < 0.5 * SD
    assert np.median(np.abs(unfolded.predict(mirrored) - centre(mirrored))) > 1.0
    rest = expit(mirrored)
    unfolded(log_l_unit, rest)
    line(log_l_unit, rest)
    assert unfolded.edge > 0.5 * len(rest) and line.edge == 0, (unfolded.text(), line.text())
    opts = ImportanceOptions(n_draws=5_000, adapt_rounds=0, n_components=8)
    proposal = fit_unit_proposal(np.delete(u, K, axis=1), opts, seed=3, swap=swap)
    res = importance_evidence(line.collapsed(log_l_unit), proposal, opts, rng=4)
    assert res.trusted and abs(res.log_z) < max(4 * res.log_z_err, 0.005) and abs(res.log_z) < 0.03, res.verdict()


def test_finer_grids_rescue_the_newton_steps_where_the_conditional_is_far_narrower_than_the_spacing():
    """A conditional with heavy tails (Student t, 1 degree of freedom, scale 1e-5 in z_K: 300 times narrower than the
    default bracket's 0.003 spacing), its centre on the regression's prediction plus a point-to-point offset of up to
    half a spacing: from the bracket's best point, up to 150 scales off the peak, the central differences (0.3 of a
    spacing wide) lie in the convex tails and g'' stays non-negative at 287 of 300 points (198 after one finer
    grid); after two (spacing 7.5e-6) the steps start within a scale of the peak and every point is concave. Each
    finer grid costs one more bracket (41 calls) a point."""
    d, rng, scale = 4, np.random.default_rng(12), 1e-5
    zr = rng.standard_normal((300, d - 1))
    offset = rng.uniform(-0.0015, 0.0015, len(zr))

    def centre(z_rest):  # the sheet's centre, moved by each point's own offset (keyed by its first coordinate)
        return _sheet_centre(z_rest) + np.interp(z_rest[:, 0], np.sort(zr[:, 0]), offset[np.argsort(zr[:, 0])])

    def log_l_unit(u):
        z = logit(u)
        rest = np.delete(z, K, axis=1)
        t = (z[:, K] - centre(rest)) / scale
        return -0.5 * np.sum(rest**2, axis=1) - np.log1p(t**2) - np.sum(_log_jac(z), axis=1)

    u = expit(np.insert(zr, K, _sheet_centre(zr), axis=1))
    w = np.full(len(u), 1 / len(u))
    rest = np.delete(u, K, axis=1)
    plain, zoomed = fit_line(u, w, K), fit_line(u, w, K, zoom=2)
    plain(log_l_unit, rest)
    zoomed(log_l_unit, rest)
    assert plain.flat > 0.3 * len(rest) and zoomed.flat == 0 and zoomed.edge == 0, (plain.text(), zoomed.text())
    assert zoomed.calls == len(rest) * (3 * 41 + 3 * 6 + 12) and "2 finer grids" in zoomed.text()


def _labelled_sheet():
    """Five coordinates, two exchangeable groups (z1, z2) and (z3, z4), each a key and a beta: in logit coordinates
    :math:`p(z) = N(z_0) N(z_1) N(z_3) N(\\beta_h) N(\\beta_s; c, s^2)` with :math:`\\beta_s` the beta of the group
    with the smaller key (the softer), :math:`\\beta_h` the other's and :math:`c = 0.3 z_0 + 0.2 \\min(z_1, z_3)`.
    Symmetric under the exchange, and :math:`Z = 1` exactly; the sheet lies across z4 only where z1 >= z3."""

    def log_l_unit(u):
        z = logit(u)
        soft_b = np.where(z[:, 1] >= z[:, 3], z[:, 4], z[:, 2])
        hard_b = np.where(z[:, 1] >= z[:, 3], z[:, 2], z[:, 4])
        t = (soft_b - 0.3 * z[:, 0] - 0.2 * np.minimum(z[:, 1], z[:, 3])) / SD
        log_p = -0.5 * (z[:, 0] ** 2 + z[:, 1] ** 2 + z[:, 3] ** 2 + hard_b**2 + t**2)
        log_p -= 2.5 * np.log(2 * np.pi) + np.log(SD)
        with np.errstate(invalid="ignore"):
            out = log_p - np.sum(_log_jac(z), axis=1)
        return np.where(np.isnan(out), -np.inf, out)

    return log_l_unit


def test_one_labelling_integrates_the_softer_groups_beta_and_doubles_its_half():
    """Draws of the labelled sheet folded onto z1 >= z3 (group (z3, z4) the softer): z4 integrated out on that
    labelling, the other half of the box given zero likelihood without a call, log 2 added: log Z = 0 within 4 errors
    and 0.03 (-0.004 +- 0.014; 5 000 draws; the proposal fitted to the folded draws spills past z1 = z3, and those
    605 draws are counted off the labelling). The same draws unfolded hold the sheet across z2 in half of them,
    where the regression of z4 has no sheet to follow."""
    log_l = _labelled_sheet()
    rng = np.random.default_rng(13)
    z = rng.standard_normal((4000, 5))  # exact draws on the labelling z1 >= z3: z4 the softer group's beta
    z[:, 1], z[:, 3] = np.maximum(z[:, 1], z[:, 3]), np.minimum(z[:, 1], z[:, 3])
    z[:, 4] = 0.3 * z[:, 0] + 0.2 * z[:, 3] + SD * rng.standard_normal(len(z))
    swap = ((1, 2), (3, 4))
    u = expit(z)
    assert np.max(np.abs(log_l(u) - log_l(swapped(u, swap)))) < 1e-9  # the exchange leaves it unchanged
    w = np.full(len(u), 1 / len(u))
    line = fit_line(u, w, 4, labelling=(1, 3))
    assert line.residual_max < 10 * SD
    opts = ImportanceOptions(n_draws=5_000, adapt_rounds=0, n_components=8)
    res = importance_evidence(line.collapsed(log_l), fit_unit_proposal(u[:, :4], opts, seed=3), opts, rng=4,
                              outside=lambda unit: ~line.inside(logit(unit)))  # fmt: skip
    assert res.trusted and abs(res.log_z) < max(4 * res.log_z_err, 0.005) and abs(res.log_z) < 0.03, res.verdict()
    # the draws off the labelling are zero likelihood by construction, counted apart from failed solves
    assert line.outside > 0 and line.points + line.outside == 5_000
    assert res.n_failed == 0 and res.n_outside == line.outside and res.n_calls == line.points
    assert line.calls == line.points * (41 + 3 * 6 + 12) and "draws off the labelling: no calls" in line.text()
    assert line.last_doubtful(5_000).shape == (5_000,)
    mixed = np.where((rng.random(len(u)) < 0.5)[:, None], swapped(u, swap), u)
    assert fit_line(mixed, w, 4).residual_max > 1.0
