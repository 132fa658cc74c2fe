"""SURS selection, CE predictors and volume fractions: known answers and bad inputs."""

import numpy as np
import pytest

from bayestissue._validation import ValidationError
from bayestissue.stereology.known_object import TwoBallPhantom, _lattice_count, ce_check
from bayestissue.stereology.point_counts import PointCounts
from bayestissue.stereology.sections import (
    DISC_SHAPE_FACTOR,
    alpha_q,
    ce_sum,
    classic_ratio_ce,
    covariogram,
    fraction_covariance,
    nugget_variance,
    ratio_ce,
    smoothness_q_hat,
    successive_difference_sum,
    surs_indices,
    surs_sum_variance,
)

# docs/stereology.md example for the successive-difference identity
P_EXAMPLE = [2, 11, 19, 24, 27, 25, 20, 12, 3]


def test_alpha_q_limits():
    # Garcia-Finana & Cruz-Orive 2000: alpha(0) = 1/12, alpha(1) = 1/240, alpha(1/2) = 0.0219639 (limit)
    assert alpha_q(0.0) == pytest.approx(1 / 12, rel=1e-12)
    assert alpha_q(1.0) == pytest.approx(1 / 240, rel=1e-12)
    assert alpha_q(0.5) == pytest.approx(0.0219639, abs=5e-8)
    # continuous through the removable singularity, decreasing in q
    near = alpha_q([0.5 - 1e-7, 0.5 + 1e-7])
    assert near == pytest.approx([0.0219639] * 2, abs=1e-6)
    q = np.linspace(0, 1, 101)
    assert np.all(np.diff(alpha_q(q)) < 0)


def test_alpha_q_rejects_out_of_range():
    with pytest.raises(ValidationError, match="smoothness values in"):
        alpha_q(1.5)


def test_successive_difference_identity():
    C = covariogram(P_EXAMPLE, 2)
    assert 3 * C[0] - 4 * C[1] + C[2] == 78
    assert successive_difference_sum(P_EXAMPLE) == 78
    rng = np.random.default_rng(0)
    P = rng.integers(0, 50, size=(20, 13))
    C = covariogram(P, 2)
    np.testing.assert_allclose(3 * C[:, 0] - 4 * C[:, 1] + C[:, 2], successive_difference_sum(P))


def test_m0_cylinder_gives_T2c2_over_6():
    # a cylinder of cross-section c cut across its axis: P_i = c on every section hit
    T, c = 0.3, 7.0
    for n in (3, 8, 21):
        var = T**2 * surs_sum_variance(np.full(n, c), smoothness=0, nugget=0.0)
        assert var == pytest.approx(T**2 * c**2 / 6, rel=1e-12)
    # and that is the true variance of the Cavalieri volume averaged over cylinder lengths
    rng = np.random.default_rng(1)
    length = 2.0 + 10 * T * rng.random(200_000)  # a whole number of periods
    u = T * rng.random(length.size)
    n_hit = np.floor((length - u) / T) + 1
    true = np.var(T * c * n_hit - c * length)
    assert true == pytest.approx(T**2 * c**2 / 6, rel=0.02)


def test_m1_matches_ball_extension_term():
    # balls of random radius (averages the oscillating "Zitterbewegung"); exact section areas
    rng = np.random.default_rng(2)
    for T in (0.1, 0.2):
        u = T * (np.arange(1000) + 0.5) / 1000
        z = -1.3 + u[:, None] + T * np.arange(int(2.6 / T) + 2)
        true, pred = [], []
        for r in 1 + 0.3 * rng.random(100):
            A = np.pi * np.clip(r**2 - z**2, 0, None)
            V = T * A.sum(axis=1)
            true.append(V.var() / V.mean() ** 2)
            pred.append(np.mean(T**2 * surs_sum_variance(A, smoothness=1, nugget=0)) / V.mean() ** 2)
        assert np.mean(pred) / np.mean(true) == pytest.approx(1.0, abs=0.05)
        # m = 0 (for functions with jumps) overestimates a smooth body several-fold
        A = np.pi * np.clip(1.0 - z**2, 0, None)
        m0 = np.mean(surs_sum_variance(A, smoothness=0, nugget=0))
        m1 = np.mean(surs_sum_variance(A, smoothness=1, nugget=0))
        assert m0 > 5 * m1


def test_nugget_matches_point_grid_on_discs():
    rng = np.random.default_rng(3)
    d, n = 0.05, 20000
    rho = 1.0 + 0.1 * (rng.random(n) - 0.5)
    ox, oy = d * rng.random((2, n))
    counts = _lattice_count(rho, ox, oy, d, rho.max())
    expected = np.pi * rho**2 / d**2
    pred = nugget_variance(expected[:, None], shape_factor=DISC_SHAPE_FACTOR)
    assert np.mean((counts - expected) ** 2) / np.mean(pred) == pytest.approx(1.0, abs=0.05)


def test_nugget_convention_inside_and_outside():
    P = np.array(P_EXAMPLE, dtype=float)
    nu = 5.0
    got = surs_sum_variance(P, smoothness=1, nugget=nu)
    assert got == pytest.approx(
        (3 * (covariogram(P, 2)[0] - nu) - 4 * covariogram(P, 2)[1] + covariogram(P, 2)[2]) / 240 + nu
    )
    # default nugget: 0.0724 (b / sqrt a) sqrt(n sum P), n = non-empty sections
    assert nugget_variance(P) == pytest.approx(0.0724 * 2 * np.sqrt(np.pi) * np.sqrt(9 * P.sum()))
    assert ce_sum(P, smoothness=1, nugget=nu) == pytest.approx(np.sqrt(got) / P.sum())


def test_q_hat_smooth_and_rough():
    z = np.linspace(-0.95, 0.95, 12)
    smooth = np.pi * (1 - z**2) * 100
    assert smoothness_q_hat(smooth) > 0.5
    assert smoothness_q_hat(np.full(12, 50.0)) == 0.0  # a cylinder: jumps, q = 0
    with pytest.raises(ValidationError, match=">= 5 sections"):
        smoothness_q_hat([1, 2, 3, 4])


def test_ratio_ce_equals_fraction_covariance_diagonal():
    rng = np.random.default_rng(4)
    P = rng.integers(200, 300, 12).astype(float)
    Q = np.round(P * (0.6 + 0.05 * np.sin(np.arange(12))))
    ce = ratio_ce(Q, P, smoothness=1, nugget=False)
    cov = fraction_covariance(np.stack([Q, P - Q], axis=1), smoothness=1, nugget=False)
    V = Q.sum() / P.sum()
    assert ce == pytest.approx(np.sqrt(cov[0, 0]) / V)
    # without nugget the two fractions' variances are equal (V_ecm = 1 - V_smc)
    assert cov[0, 0] == pytest.approx(cov[1, 1], rel=1e-10)
    assert cov[0, 1] == pytest.approx(-cov[0, 0], rel=1e-10)
    # phase = reference exactly (fraction 1) has zero ratio error
    assert ratio_ce(P, P, smoothness=1, nugget=False) == pytest.approx(0.0, abs=1e-12)


def test_classic_ratio_ce_by_hand():
    Q, P = np.array([1.0, 2.0, 3.0]), np.array([2.0, 2.0, 2.0])
    d = Q / 6 - P / 6
    assert classic_ratio_ce(Q, P) == pytest.approx(np.sqrt(1.5 * np.sum(d**2)))


def test_design_aware_ce_on_known_object():
    # 12 sections through the two-ball phantom with a real point grid, as in the paper (m = 12)
    ph = TwoBallPhantom(1.0, 0.75, 0.2)
    r = ce_check(
        ph,
        2.0 / 12,
        grid_spacing=0.1,
        size_jitter=0.3,
        n_starts=3000,
        n_naive=20,
        n_boot=200,
        rng=5,
    )
    assert abs(r["bias"]) < 0.005
    assert r["m1"] / r["true_ce"] == pytest.approx(1.0, abs=0.2)  # design-aware: within 20 %
    assert r["q_hat"] / r["true_ce"] == pytest.approx(1.0, abs=0.25)
    assert r["naive_bootstrap"] > 3 * r["true_ce"]  # the naive section bootstrap: several-fold too big
    assert r["classic"] > 3 * r["true_ce"]


def test_surs_indices():
    idx = surs_indices(72, 6, rng=0)
    assert idx.size == 12 and np.all(np.diff(idx) == 6) and 0 <= idx[0] < 6
    starts = np.array([surs_indices(72, 6, rng=s)[0] for s in range(600)])
    counts = np.bincount(starts, minlength=6)
    assert counts.min() > 70  # uniform start (expected 100 each)
    with pytest.raises(ValidationError, match="period"):
        surs_indices(5, 6)
    with pytest.raises(ValidationError, match="n_sections"):
        surs_indices(0, 1)


def test_bad_counts():
    with pytest.raises(ValidationError, match="counts >= 0"):
        ratio_ce([1, -2, 3], [4, 5, 6])
    with pytest.raises(ValidationError, match="phase counts <= reference counts"):
        ratio_ce([1, 7, 3], [4, 5, 6])
    with pytest.raises(ValidationError, match=">= 3 sections"):
        ratio_ce([1, 2], [4, 5])
    with pytest.raises(ValidationError, match=">= 3 sections"):
        surs_sum_variance([1, 2])
    with pytest.raises(ValidationError, match="finite counts"):
        surs_sum_variance([1, np.nan, 2])
    with pytest.raises(ValidationError, match="smoothness"):
        surs_sum_variance([1, 2, 3, 4], smoothness="m1")
    with pytest.raises(ValidationError, match="shape of P"):
        ratio_ce([1, 2, 3], [1, 2, 3, 4])
    with pytest.raises(ValidationError, match="an \\(n_sections, n_components\\) array"):
        fraction_covariance([1, 2, 3])
    with pytest.raises(ValidationError, match=">= 2 sections"):
        classic_ratio_ce([1], [2])


def _pc(**kw):
    counts = np.array([[10, 5, 3], [12, 6, 2], [11, 7, 4], [9, 8, 5]])
    args = dict(section=[0, 6, 12, 18], counts=counts, components=("smc", "ecm", "other"))
    args.update(kw)
    return PointCounts(**args, **({"excluded": ("other",)} if "excluded" not in kw else {}))


def test_point_counts_summary():
    pc = _pc()
    vf = pc.volume_fractions()
    assert vf["smc"] == pytest.approx(42 / 68) and vf["ecm"] == pytest.approx(26 / 68)
    s = pc.summary()
    assert set(s) == {"smc", "ecm"}
    assert np.isnan(s["smc"]["CE_q_hat"])  # 4 sections: q_hat needs 5
    assert s["smc"]["CE_classic"] > 0
    with pytest.raises(ValidationError, match="component: expected one of"):
        pc.column("collagen")


def test_point_counts_bad_inputs():
    with pytest.raises(ValidationError, match="counts >= 0"):
        _pc(counts=np.array([[10, -5, 3], [12, 6, 2], [11, 7, 4], [9, 8, 5]]))
    with pytest.raises(ValidationError, match="excluded: expected one of"):
        _pc(excluded=("cavity",))
    with pytest.raises(ValidationError, match="at least one component"):
        _pc(excluded=("smc", "ecm", "other"))
    with pytest.raises(ValidationError, match="distinct section positions"):
        _pc(section=[0, 6, 6, 18])
    with pytest.raises(ValidationError, match="distinct names"):
        _pc(components=("smc", "smc", "other"), excluded=())
    with pytest.raises(ValidationError, match="counts: expected \\(n_sections, 3\\)"):
        _pc(counts=np.ones((4, 2)))
    with pytest.raises(ValidationError, match="shape_factor"):
        _pc(shape_factor=0)
